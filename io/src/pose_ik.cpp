#include "dynfilter/io/pose_ik.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

#include "dynfilter/core/lie_group.hpp"

namespace dynfilter::io {
namespace {
constexpr double kMaxStep = 0.5;  // largest change of a coordinate per iteration (rad, m)
constexpr double kMinLambda = 1e-6;  // Levenberg–Marquardt damping floor, relative to H's diagonal
}  // namespace

void ikTargetError(const IDynamicsModel& model, const IkTarget& target, double& position_m,
                   double& orientation_rad) {
  const Eigen::Isometry3d X = model.bodyPose(target.body);
  position_m = (target.p_WP - X * target.p_BP).norm();
  orientation_rad = logSO3(target.R_WB * X.linear().transpose()).norm();
}

namespace {
// The objective at the model's current state (q given for the posture term).
double ikCost(const IDynamicsModel& model, const std::vector<IkTarget>& targets,
              const Eigen::VectorXd& q, const Eigen::VectorXd& q_posture,
              const Eigen::VectorXd& posture_weights, const Eigen::VectorXd* q_previous,
              double continuity_weight, Eigen::VectorXd& e_q) {
  double cost = 0.0;
  for (const IkTarget& t : targets) {
    const Eigen::Isometry3d X = model.bodyPose(t.body);
    if (t.position_weight > 0)
      cost += t.position_weight * t.position_weight * (t.p_WP - X * t.p_BP).squaredNorm();
    if (t.orientation_weight > 0)
      cost += t.orientation_weight * t.orientation_weight *
              logSO3(t.R_WB * X.linear().transpose()).squaredNorm();
  }
  differenceConfiguration(model.info().floating_base, q, q_posture, e_q);
  cost += (posture_weights.array() * e_q.array()).square().sum();
  if (q_previous) {
    differenceConfiguration(model.info().floating_base, q, *q_previous, e_q);
    cost += continuity_weight * continuity_weight * e_q.squaredNorm();
  }
  return cost;
}
}  // namespace

IkResult solvePoseIk(IDynamicsModel& model, const std::vector<IkTarget>& targets,
                     const Eigen::VectorXd& q_posture, const Eigen::VectorXd& posture_weights,
                     const IkOptions& options, Eigen::VectorXd& q,
                     const Eigen::VectorXd* q_previous) {
  const ModelInfo& info = model.info();
  const int nv = info.nv;
  for (int j = 0; j < info.nj; ++j) {
    const int qi = info.configurationIndex(j);
    q[qi] = std::clamp(q[qi], info.q_lower[j], info.q_upper[j]);
  }
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(nv);
  Matrix6Xd J(6, nv);
  Eigen::MatrixXd H(nv, nv);
  Eigen::VectorXd g(nv), e_q(nv), dv(nv), lo(nv), hi(nv), q_try(q.size());
  double lambda = kMinLambda;
  IkResult result;
  for (int it = 0; it < options.max_iterations; ++it) {
    model.setState(q, v0);
    H.setZero();
    g.setZero();
    for (const IkTarget& t : targets) {
      const Eigen::Isometry3d X = model.bodyPose(t.body);
      model.pointJacobian(t.body, t.p_BP, J);
      if (t.position_weight > 0) {
        const double w2 = t.position_weight * t.position_weight;
        const Eigen::Vector3d e = t.p_WP - X * t.p_BP;
        H.noalias() += w2 * J.topRows<3>().transpose() * J.topRows<3>();
        g.noalias() += w2 * J.topRows<3>().transpose() * e;
      }
      if (t.orientation_weight > 0) {
        const double w2 = t.orientation_weight * t.orientation_weight;
        const Eigen::Vector3d e = logSO3(t.R_WB * X.linear().transpose());
        H.noalias() += w2 * J.bottomRows<3>().transpose() * J.bottomRows<3>();
        g.noalias() += w2 * J.bottomRows<3>().transpose() * e;
      }
    }
    differenceConfiguration(info.floating_base, q, q_posture, e_q);
    for (int c = 0; c < nv; ++c) {
      const double w2 = posture_weights[c] * posture_weights[c];
      H(c, c) += w2 + options.damping;
      g[c] += w2 * e_q[c];
    }
    const Eigen::VectorXd* previous = nullptr;
    if (q_previous && options.continuity_weight > 0) {
      previous = q_previous;
      differenceConfiguration(info.floating_base, q, *q_previous, e_q);
      const double w2 = options.continuity_weight * options.continuity_weight;
      H.diagonal().array() += w2;
      g += w2 * e_q;
    }
    lo.setConstant(-1e300);
    hi.setConstant(1e300);
    for (int j = 0; j < info.nj; ++j) {
      const int qi = info.configurationIndex(j), vi = info.velocityIndex(j);
      lo[vi] = info.q_lower[j] - q[qi];
      hi[vi] = info.q_upper[j] - q[qi];
    }
    const double cost0 = ikCost(model, targets, q, q_posture, posture_weights, previous, options.continuity_weight, e_q);
    // Levenberg–Marquardt: a step that does not lower the objective is retried with 10×
    // the damping; an accepted one lowers it 3×. No step lowers it: converged.
    bool accepted = false;
    for (int attempt = 0; attempt < 12 && !accepted; ++attempt) {
      // Active set on the bounds: fix violators at their bound, solve the rest again.
      std::vector<char> fixed(static_cast<std::size_t>(nv), 0);
      dv.setZero();
      for (int round = 0; round < nv; ++round) {
        std::vector<int> free_idx;
        for (int c = 0; c < nv; ++c)
          if (!fixed[static_cast<std::size_t>(c)]) free_idx.push_back(c);
        const int nf = static_cast<int>(free_idx.size());
        Eigen::MatrixXd Hf(nf, nf);
        Eigen::VectorXd gf(nf);
        for (int a = 0; a < nf; ++a) {
          gf[a] = g[free_idx[static_cast<std::size_t>(a)]];
          for (int c = 0; c < nv; ++c)
            if (fixed[static_cast<std::size_t>(c)]) gf[a] -= H(free_idx[static_cast<std::size_t>(a)], c) * dv[c];
          for (int b = 0; b < nf; ++b)
            Hf(a, b) = H(free_idx[static_cast<std::size_t>(a)], free_idx[static_cast<std::size_t>(b)]);
          Hf(a, a) += lambda * (Hf(a, a) + 1.0);  // Marquardt's scaling
        }
        const Eigen::VectorXd x = Hf.ldlt().solve(gf);
        bool violated = false;
        for (int a = 0; a < nf; ++a) {
          const int c = free_idx[static_cast<std::size_t>(a)];
          dv[c] = x[a];
          if (dv[c] < lo[c] - 1e-12 || dv[c] > hi[c] + 1e-12) {
            dv[c] = std::clamp(dv[c], lo[c], hi[c]);
            fixed[static_cast<std::size_t>(c)] = 1;
            violated = true;
          }
        }
        if (!violated) break;
      }
      const double step = dv.lpNorm<Eigen::Infinity>();
      if (step > kMaxStep) dv *= kMaxStep / step;  // inside the bounds too: lo ≤ 0 ≤ hi
      integrateConfiguration(info.floating_base, q, dv, 1.0, q_try);
      for (int j = 0; j < info.nj; ++j) {
        const int qi = info.configurationIndex(j);
        q_try[qi] = std::clamp(q_try[qi], info.q_lower[j], info.q_upper[j]);
      }
      model.setState(q_try, v0);
      if (ikCost(model, targets, q_try, q_posture, posture_weights, previous, options.continuity_weight, e_q) <= cost0) {
        accepted = true;
        lambda = std::max(lambda / 3.0, kMinLambda);
      } else {
        lambda *= 10.0;
      }
    }
    result.iterations = it + 1;
    if (!accepted) {  // no step lowers the objective: a minimum (within the bounds)
      result.converged = true;
      break;
    }
    q = q_try;
    if (dv.lpNorm<Eigen::Infinity>() < options.tolerance) {
      result.converged = true;
      break;
    }
  }
  model.setState(q, v0);
  return result;
}

}  // namespace dynfilter::io
