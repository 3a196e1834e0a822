#pragma once
// Shared by the attach tests: comparing an attached model with a URDF-built one whose
// joints may come in another order.
#include <algorithm>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/model_sampling.hpp"

namespace dynfilter {
namespace test {
/// @p x as "1.23e-12" (std::to_string prints 0.000000).
inline std::string scientific(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", x);
  return buffer;
}
}  // namespace test

constexpr double kTolerance = 1e-9;

inline double relative(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

// Coordinates of model `to` by name from those of model `from` (same robot, joints in
// another order): P maps v_from → v_to, and q likewise (base first).
struct Reorder {
  std::vector<int> v_from;  // v_to[i] = v_from[v_from_index[i]]
  std::vector<int> q_from;
  Reorder(const ModelInfo& from, const ModelInfo& to) {
    const int base_v = to.floating_base ? 6 : 0, base_q = to.floating_base ? 7 : 0;
    for (int i = 0; i < base_v; ++i) v_from.push_back(i);
    for (int i = 0; i < base_q; ++i) q_from.push_back(i);
    for (int j = 0; j < to.nj; ++j) {
      const int k = from.findJoint(to.joint_names[static_cast<std::size_t>(j)]);
      EXPECT_GE(k, 0) << to.joint_names[static_cast<std::size_t>(j)];
      v_from.push_back(from.velocityIndex(k));
      q_from.push_back(from.configurationIndex(k));
    }
  }
  Eigen::VectorXd v(const Eigen::VectorXd& x) const {
    Eigen::VectorXd out(static_cast<Eigen::Index>(v_from.size()));
    for (std::size_t i = 0; i < v_from.size(); ++i) out[static_cast<Eigen::Index>(i)] = x[v_from[i]];
    return out;
  }
  Eigen::VectorXd q(const Eigen::VectorXd& x) const {
    Eigen::VectorXd out(static_cast<Eigen::Index>(q_from.size()));
    for (std::size_t i = 0; i < q_from.size(); ++i) out[static_cast<Eigen::Index>(i)] = x[q_from[i]];
    return out;
  }
  Eigen::MatrixXd cols(const Eigen::MatrixXd& M) const {
    Eigen::MatrixXd out(M.rows(), static_cast<Eigen::Index>(v_from.size()));
    for (std::size_t i = 0; i < v_from.size(); ++i) out.col(static_cast<Eigen::Index>(i)) = M.col(v_from[i]);
    return out;
  }
  Eigen::MatrixXd both(const Eigen::MatrixXd& M) const {
    const Eigen::MatrixXd c = cols(M);
    Eigen::MatrixXd out(static_cast<Eigen::Index>(v_from.size()), c.cols());
    for (std::size_t i = 0; i < v_from.size(); ++i) out.row(static_cast<Eigen::Index>(i)) = c.row(v_from[i]);
    return out;
  }
};

// A, b and, at every body, J and J̇·v of a point: @p attached against @p reference at
// random states of the reference (mapped by joint name). Returns the worst relative gap.
inline double worstGap(IDynamicsModel& reference, IDynamicsModel& attached, int states, unsigned seed) {
  const ModelInfo& ri = reference.info();
  const ModelInfo& ai = attached.info();
  EXPECT_EQ(ri.nv, ai.nv);
  EXPECT_EQ(ri.floating_base, ai.floating_base);
  const Reorder reorder(ri, ai);
  std::mt19937 rng(seed);
  Eigen::VectorXd q, v;
  Eigen::MatrixXd A_r(ri.nv, ri.nv), A_a(ai.nv, ai.nv);
  Eigen::VectorXd b_r(ri.nv), b_a(ai.nv);
  Matrix6Xd J_r(6, ri.nv), J_a(6, ai.nv);
  const Eigen::Vector3d p_BP(0.03, -0.02, 0.05);
  double worst = 0.0;
  for (int s = 0; s < states; ++s) {
    randomState(ri, rng, 2.0, q, v);
    reference.setState(q, v);
    attached.setState(reorder.q(q), reorder.v(v));
    reference.massMatrix(A_r);
    attached.massMatrix(A_a);
    reference.bias(b_r);
    attached.bias(b_a);
    worst = std::max(worst, relative(A_a, reorder.both(A_r)));
    worst = std::max(worst, relative(b_a, reorder.v(b_r)));
    for (int body = 0; body < static_cast<int>(ai.body_names.size()); ++body) {
      const int rb = ri.findBody(ai.body_names[static_cast<std::size_t>(body)]);
      EXPECT_GE(rb, 0) << ai.body_names[static_cast<std::size_t>(body)];
      if (rb < 0) continue;
      EXPECT_LT(relative(attached.bodyPose(body).matrix(), reference.bodyPose(rb).matrix()), kTolerance)
          << ai.body_names[static_cast<std::size_t>(body)];
      reference.pointJacobian(rb, p_BP, J_r);
      attached.pointJacobian(body, p_BP, J_a);
      worst = std::max(worst, relative(J_a, reorder.cols(J_r)));
      worst = std::max(worst, relative(attached.pointJacobianDotTimesV(body, p_BP),
                                       reference.pointJacobianDotTimesV(rb, p_BP)));
    }
  }
  return worst;
}

}  // namespace dynfilter
