#include "dynfilter/io/reference_balance.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "dynfilter/core/balance.hpp"
#include "dynfilter/core/polygon.hpp"

namespace dynfilter::io {
namespace {
constexpr std::size_t kMaxSupportPoints = 128;
// The needed wrench is smoothed over this σ (s): the second derivative of captured motion
// is noisy, and the pendulum (time constant 1/ω ≈ 0.3 s) does not feel faster changes.
constexpr double kWrenchSigmaS = 0.04;
}  // namespace

Eigen::Matrix3d groundPlaneFrame(const IDynamicsModel& model) {
  const Environment& env = model.environment();
  const Eigen::Vector3d n = env.has_ground ? env.ground.n_W : Eigen::Vector3d::UnitZ();
  Eigen::Vector3d x = Eigen::Vector3d::UnitX() - n * n.x();
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitY() - n * n.y();
  x.normalize();
  Eigen::Matrix3d R_PW;
  R_PW.row(0) = x.transpose();
  R_PW.row(1) = n.cross(x).transpose();
  R_PW.row(2) = n.transpose();
  return R_PW;
}

namespace {

// The CoM of every frame and the wrench the motion needs (plane frame, smoothed).
struct NeededWrench {
  Eigen::Matrix3d R_PW;
  double offset_m = 0.0;  // the ground plane's offset along its normal
  std::vector<Eigen::Vector3d> c_P, F, M;  // per frame
};

NeededWrench neededWrench(const ReferenceMotion& motion, IDynamicsModel& model) {
  const ModelInfo& info = model.info();
  if (!info.floating_base) throw std::invalid_argument("reference balance: the model must have a floating base");
  const std::size_t n = motion.frames.size();
  const Environment& env = model.environment();
  NeededWrench w;
  w.offset_m = env.has_ground ? env.ground.offset_m : 0.0;
  w.R_PW = groundPlaneFrame(model);
  const double mass = info.total_mass;
  Eigen::MatrixXd A(info.nv, info.nv);
  std::vector<CentroidalState> cs(n);
  w.c_P.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const ReferenceFrame& f = motion.frames[k];
    model.setState(f.q, f.v);
    model.massMatrix(A);
    cs[k] = centroidalState(A, f.q, f.v, mass);
    w.c_P[k] = w.R_PW * cs[k].c_W;
  }
  // F = m (c̈ − g) and L̇ by central differences (one-sided at the ends), in the plane
  // frame, then smoothed by the clean-up's own zero-phase Gaussian (σ = kWrenchSigmaS):
  // [F; L̇] as the "configuration" of time-stamped frames.
  w.F.assign(n, Eigen::Vector3d::Zero());
  w.M.assign(n, Eigen::Vector3d::Zero());
  for (std::size_t k = 0; k < n && n >= 3; ++k) {
    const std::size_t a = k == 0 ? 0 : k - 1, b = std::min(n - 1, k + 1);
    const double dt = motion.frames[b].time_s - motion.frames[a].time_s;
    if (!(dt > 0)) continue;
    w.F[k] = w.R_PW * (mass * ((cs[b].cdot_W - cs[a].cdot_W) / dt + Eigen::Vector3d(0.0, 0.0, kStandardGravity)));
    w.M[k] = w.R_PW * ((cs[b].L_W - cs[a].L_W) / dt);
  }
  std::vector<ReferenceFrame> wrench(n, ReferenceFrame(6, 6));
  for (std::size_t k = 0; k < n; ++k) {
    wrench[k].time_s = motion.frames[k].time_s;
    wrench[k].q << w.F[k], w.M[k];
  }
  lowPassConfigurations(wrench, false, 0.1325 / kWrenchSigmaS);
  for (std::size_t k = 0; k < n; ++k) {
    w.F[k] = wrench[k].q.head<3>();
    w.M[k] = wrench[k].q.tail<3>();
  }
  return w;
}

// The hull (counter-clockwise, plane frame) of one frame's support points.
std::vector<Eigen::Vector2d> planeHull(const std::vector<Eigen::Vector3d>& points_W, const Eigen::Matrix3d& R_PW) {
  std::array<Eigen::Vector2d, kMaxSupportPoints> points;
  std::array<Eigen::Vector2d, kMaxSupportPoints> hull;
  int m = 0;
  for (const Eigen::Vector3d& p : points_W)
    if (m < static_cast<int>(points.size())) points[static_cast<std::size_t>(m++)] = (R_PW * p).head<2>();
  const int h = m > 0 ? polygon::convexHull(points, m, hull) : 0;
  return std::vector<Eigen::Vector2d>(hull.begin(), hull.begin() + h);
}

}  // namespace

std::vector<ZmpSample> zmpAgainstSupport(const ReferenceMotion& motion, IDynamicsModel& model,
                                         const std::vector<std::vector<Eigen::Vector3d>>& support_W) {
  const std::size_t n = motion.frames.size();
  if (support_W.size() != n) throw std::invalid_argument("zmpAgainstSupport: one support per frame");
  const NeededWrench w = neededWrench(motion, model);
  const double mass = model.info().total_mass;
  std::vector<ZmpSample> out(n);
  std::array<Eigen::Vector2d, kMaxSupportPoints> hull;
  for (std::size_t k = 0; k < n; ++k) {
    ZmpSample& s = out[k];
    const Eigen::Vector3d& c_P = w.c_P[k];
    const Eigen::Vector3d& F = w.F[k];
    const Eigen::Vector3d& M = w.M[k];
    s.com_height_m = c_P.z() - w.offset_m;
    if (n < 3 || support_W[k].empty() || F.z() < 0.2 * mass * kStandardGravity) continue;
    s.zmp = Eigen::Vector2d(c_P.x() - (s.com_height_m * F.x() + M.y()) / F.z(),
                            c_P.y() - (s.com_height_m * F.y() - M.x()) / F.z());
    const std::vector<Eigen::Vector2d> h = planeHull(support_W[k], w.R_PW);
    std::copy(h.begin(), h.end(), hull.begin());
    s.nearest = polygon::clampToHull(s.zmp, hull, static_cast<int>(h.size()));
    s.outside_m = (s.zmp - s.nearest).norm();
    s.vertical_load = F.z() / (mass * kStandardGravity);
    s.defined = true;
  }
  return out;
}

std::vector<PendulumSample> pendulumSamples(const ReferenceMotion& motion, IDynamicsModel& model,
                                            const std::vector<std::vector<Eigen::Vector3d>>& support_W) {
  const std::size_t n = motion.frames.size();
  if (support_W.size() != n) throw std::invalid_argument("pendulumSamples: one support per frame");
  const NeededWrench w = neededWrench(motion, model);
  const double mass = model.info().total_mass;
  std::vector<PendulumSample> out(n);
  for (std::size_t k = 0; k < n; ++k) {
    PendulumSample& s = out[k];
    s.time_s = motion.frames[k].time_s;
    s.c = w.c_P[k].head<2>();
    s.load = w.F[k].z() / (mass * kStandardGravity);
    if (support_W[k].empty() || s.load < 0.2) continue;
    const double h = w.c_P[k].z() - w.offset_m;
    s.beta_s2 = h / (s.load * kStandardGravity);
    s.moment_offset = Eigen::Vector2d(-w.M[k].y(), w.M[k].x()) / w.F[k].z();
    s.support = planeHull(support_W[k], w.R_PW);
  }
  return out;
}

std::vector<Eigen::Vector2d> feasibleComPath(const std::vector<PendulumSample>& samples,
                                             const FeasibleComOptions& options,
                                             const QpSolverFactory& qp_solver, FeasibleComReport* report) {
  options.validate();
  if (!qp_solver) throw std::invalid_argument("feasibleComPath: no QP solver");
  const std::size_t n = samples.size();
  std::vector<Eigen::Vector2d> out(n);
  for (std::size_t k = 0; k < n; ++k) out[k] = samples[k].c;
  if (n < 3) return out;
  // The grid: every stride-th frame, and the last.
  const double frame_dt = (samples.back().time_s - samples.front().time_s) / static_cast<double>(n - 1);
  if (!(frame_dt > 0)) throw std::invalid_argument("feasibleComPath: times must increase");
  const std::size_t stride = static_cast<std::size_t>(std::max(1L, std::lround(options.grid_s / frame_dt)));
  std::vector<std::size_t> grid;
  for (std::size_t k = 0; k < n; k += stride) grid.push_back(k);
  if (grid.back() != n - 1) grid.push_back(n - 1);
  const int G = static_cast<int>(grid.size());
  std::vector<Eigen::Vector2d> x(static_cast<std::size_t>(G));
  const int P = std::min(G, std::max(4, static_cast<int>(std::lround(options.window_s / options.grid_s)) + 1));
  const int step = std::max(2, P / 2);
  if (report) *report = FeasibleComReport{};
  for (int i0 = 0;; i0 += step) {
    const int i1 = std::min(G, i0 + P);  // points [i0, i1)
    const int m = i1 - i0;
    std::size_t max_edges = 0;
    for (int i = i0; i < i1; ++i) max_edges = std::max(max_edges, samples[grid[static_cast<std::size_t>(i)]].support.size());
    const int rows_per_point = static_cast<int>(max_edges) + 2;
    const int nx = 3 * m;  // x, y, slack per point
    const int n_eq = (i0 > 0 ? 4 : 2) + 2;
    const int n_in = m * rows_per_point;
    DenseQp qp(nx, n_eq, n_in);
    qp.H.setZero();
    qp.g.setZero();
    qp.C.setZero();
    qp.l.setConstant(-kQpInfinity);
    qp.u.setConstant(kQpInfinity);
    for (int j = 0; j < m; ++j) {
      const PendulumSample& s = samples[grid[static_cast<std::size_t>(i0 + j)]];
      for (int a = 0; a < 2; ++a) {
        qp.H(2 * j + a, 2 * j + a) += 2.0;
        qp.g[2 * j + a] = -2.0 * s.c[a];
        qp.x_lower[2 * j + a] = s.c[a] - options.max_shift_m;
        qp.x_upper[2 * j + a] = s.c[a] + options.max_shift_m;
      }
      const int sj = 2 * m + j;
      qp.H(sj, sj) = 2.0 * options.slack_weight;
      qp.g[sj] = options.slack_weight * 0.01;
      qp.x_lower[sj] = 0.0;
      qp.x_upper[sj] = kQpInfinity;
    }
    // Acceleration cost and rows: c̈_j = (x_{j+1} − 2 x_j + x_{j−1}) / h² (h: the grid's step).
    const auto h2 = [&](int j) {
      const double a = samples[grid[static_cast<std::size_t>(i0 + j)]].time_s - samples[grid[static_cast<std::size_t>(i0 + j - 1)]].time_s;
      const double b = samples[grid[static_cast<std::size_t>(i0 + j + 1)]].time_s - samples[grid[static_cast<std::size_t>(i0 + j)]].time_s;
      return 0.5 * (a + b) * 0.5 * (a + b);
    };
    for (int j = 1; j + 1 < m; ++j) {
      const double w = 2.0 * options.accel_weight / (h2(j) * h2(j));
      const int idx[3] = {j - 1, j, j + 1};
      const double coef[3] = {1.0, -2.0, 1.0};
      for (int a = 0; a < 2; ++a)
        for (int p = 0; p < 3; ++p)
          for (int q = 0; q < 3; ++q) qp.H(2 * idx[p] + a, 2 * idx[q] + a) += w * coef[p] * coef[q];
    }
    for (int j = 1; j + 1 < m; ++j) {
      const PendulumSample& s = samples[grid[static_cast<std::size_t>(i0 + j)]];
      const double inv_h2 = 1.0 / h2(j);
      int r = j * rows_per_point;
      // Friction of the whole contact force: |c̈_x|, |c̈_y| ≤ μ g (load).
      const double a_max = options.friction * kStandardGravity * std::max(0.0, s.load);
      for (int a = 0; a < 2; ++a, ++r) {
        qp.C(r, 2 * (j - 1) + a) = inv_h2;
        qp.C(r, 2 * j + a) = -2.0 * inv_h2;
        qp.C(r, 2 * (j + 1) + a) = inv_h2;
        qp.l[r] = -a_max;
        qp.u[r] = a_max;
      }
      // ZMP = x_j − β c̈_j + o inside every edge of the support: nᵀ ZMP − slack ≤ nᵀ v.
      const std::size_t E = s.support.size();
      if (E < 3) continue;
      for (std::size_t e = 0; e < E; ++e, ++r) {
        const Eigen::Vector2d& v0 = s.support[e];
        const Eigen::Vector2d& v1 = s.support[(e + 1) % E];
        Eigen::Vector2d normal(v1.y() - v0.y(), v0.x() - v1.x());  // outward for counter-clockwise
        if (normal.norm() < 1e-12) continue;
        normal.normalize();
        for (int a = 0; a < 2; ++a) {
          qp.C(r, 2 * (j - 1) + a) = -s.beta_s2 * inv_h2 * normal[a];
          qp.C(r, 2 * j + a) = (1.0 + 2.0 * s.beta_s2 * inv_h2) * normal[a];
          qp.C(r, 2 * (j + 1) + a) = -s.beta_s2 * inv_h2 * normal[a];
        }
        qp.C(r, 2 * m + j) = -1.0;
        qp.u[r] = normal.dot(v0) - normal.dot(s.moment_offset);
      }
    }
    // The previous window's first two points of this one are kept; the clip's start and
    // every window's end hold the shift still (δ_1 = δ_0, δ_{m−1} = δ_{m−2}), so that no
    // window leans on the pendulum's divergence past its horizon.
    qp.A.setZero();
    int row = 0;
    const auto shiftStill = [&](int j0, int j1) {
      const Eigen::Vector2d dc = samples[grid[static_cast<std::size_t>(i0 + j1)]].c - samples[grid[static_cast<std::size_t>(i0 + j0)]].c;
      for (int a = 0; a < 2; ++a, ++row) {
        qp.A(row, 2 * j1 + a) = 1.0;
        qp.A(row, 2 * j0 + a) = -1.0;
        qp.b[row] = dc[a];
      }
    };
    if (i0 > 0) {
      for (int j = 0; j < 2; ++j)
        for (int a = 0; a < 2; ++a, ++row) {
          qp.A(row, 2 * j + a) = 1.0;
          qp.b[row] = x[static_cast<std::size_t>(i0 + j)][a];
        }
    } else {
      shiftStill(0, 1);
    }
    shiftStill(m - 2, m - 1);
    QpSolverSettings settings;
    settings.eps_abs = 1e-7;
    // The walk's 3–6 s window does not converge under the adapter's 5 Newton steps per
    // iteration; capped here (38 s at 1000). Its converged answer (20+ steps) was measured
    // worse for the filter (docs/balance.md §29).
    settings.max_iterations = 200;
    settings.warm_start = false;
    std::unique_ptr<IQpSolver> solver = qp_solver(nx, n_eq, n_in, settings);
    Eigen::VectorXd sol(nx);
    const QpSolveInfo info = solver->solve(qp, sol);
    if (report) {
      ++report->windows;
      report->unsolved += info.status != QpSolveStatus::kSolved;
    }
    const bool usable = sol.allFinite() && info.status != QpSolveStatus::kNotFinite;
    const int keep_from = i0 == 0 ? 0 : 2;
    const int keep_to = i1 == G ? m : std::min(m, step + 2);
    for (int j = keep_from; j < keep_to; ++j) {
      const PendulumSample& s = samples[grid[static_cast<std::size_t>(i0 + j)]];
      x[static_cast<std::size_t>(i0 + j)] = usable ? Eigen::Vector2d(sol[2 * j], sol[2 * j + 1]) : s.c;
      if (report && usable) report->max_violation_m = std::max(report->max_violation_m, sol[2 * m + j]);
    }
    if (i1 == G) break;
  }
  // The shift x − c, linear between grid points, added to every frame's CoM.
  for (int i = 0; i + 1 < G; ++i) {
    const std::size_t a = grid[static_cast<std::size_t>(i)], b = grid[static_cast<std::size_t>(i + 1)];
    const Eigen::Vector2d da = x[static_cast<std::size_t>(i)] - samples[a].c;
    const Eigen::Vector2d db = x[static_cast<std::size_t>(i + 1)] - samples[b].c;
    for (std::size_t k = a; k <= b; ++k) {
      const double u = b > a ? static_cast<double>(k - a) / static_cast<double>(b - a) : 0.0;
      out[k] = samples[k].c + (1.0 - u) * da + u * db;
    }
  }
  return out;
}

void FeasibleComOptions::validate() const {
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(grid_s) || !positive(window_s) || !positive(max_shift_m) || !positive(friction) ||
      !positive(slack_weight) || !(std::isfinite(accel_weight) && accel_weight >= 0.0))
    throw std::invalid_argument(
        "FeasibleComOptions: grid_s, window_s, max_shift_m, friction and slack_weight must be > 0, "
        "accel_weight >= 0");
  if (window_s < 3.0 * grid_s) throw std::invalid_argument("FeasibleComOptions: window_s must be >= 3 grid_s");
}

}  // namespace dynfilter::io
