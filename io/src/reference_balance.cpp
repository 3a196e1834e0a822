#include "dynfilter/io/reference_balance.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "dynfilter/core/balance.hpp"
#include "dynfilter/core/polygon.hpp"

namespace dynfilter::io {
namespace {
constexpr double kGravity = 9.81;  // m/s², along −z
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

std::vector<ZmpSample> zmpAgainstSupport(const ReferenceMotion& motion, IDynamicsModel& model,
                                         const std::vector<std::vector<Eigen::Vector3d>>& support_W) {
  const ModelInfo& info = model.info();
  if (!info.floating_base) throw std::invalid_argument("zmpAgainstSupport: the model must have a floating base");
  const std::size_t n = motion.frames.size();
  if (support_W.size() != n) throw std::invalid_argument("zmpAgainstSupport: one support per frame");
  const Environment& env = model.environment();
  const double offset = env.has_ground ? env.ground.offset_m : 0.0;
  const Eigen::Matrix3d R_PW = groundPlaneFrame(model);
  const double mass = info.total_mass;
  Eigen::MatrixXd A(info.nv, info.nv);
  std::vector<CentroidalState> cs(n);
  for (std::size_t k = 0; k < n; ++k) {
    const ReferenceFrame& f = motion.frames[k];
    model.setState(f.q, f.v);
    model.massMatrix(A);
    cs[k] = centroidalState(A, f.q, f.v, mass);
  }
  // The wrench the motion needs, per frame: F = m (c̈ − g) and L̇, by central differences
  // (one-sided at the ends), in the plane frame, then Gaussian-smoothed over kWrenchSigmaS.
  std::vector<Eigen::Vector3d> F(n, Eigen::Vector3d::Zero()), M(n, Eigen::Vector3d::Zero());
  for (std::size_t k = 0; k < n && n >= 3; ++k) {
    const std::size_t a = k == 0 ? 0 : k - 1, b = std::min(n - 1, k + 1);
    const double dt = motion.frames[b].time_s - motion.frames[a].time_s;
    if (!(dt > 0)) continue;
    F[k] = R_PW * (mass * ((cs[b].cdot_W - cs[a].cdot_W) / dt + Eigen::Vector3d(0.0, 0.0, kGravity)));
    M[k] = R_PW * ((cs[b].L_W - cs[a].L_W) / dt);
  }
  // Smoothed by the clean-up's own zero-phase Gaussian (σ = kWrenchSigmaS): [F; L̇] as the
  // "configuration" of time-stamped frames.
  std::vector<ReferenceFrame> wrench(n, ReferenceFrame(6, 6));
  for (std::size_t k = 0; k < n; ++k) {
    wrench[k].time_s = motion.frames[k].time_s;
    wrench[k].q << F[k], M[k];
  }
  lowPassConfigurations(wrench, false, 0.1325 / kWrenchSigmaS);
  for (std::size_t k = 0; k < n; ++k) {
    F[k] = wrench[k].q.head<3>();
    M[k] = wrench[k].q.tail<3>();
  }
  std::vector<ZmpSample> out(n);
  std::array<Eigen::Vector2d, kMaxSupportPoints> points;
  std::array<Eigen::Vector2d, kMaxSupportPoints> hull;
  for (std::size_t k = 0; k < n; ++k) {
    ZmpSample& s = out[k];
    const Eigen::Vector3d c_P = R_PW * cs[k].c_W;
    s.com_height_m = c_P.z() - offset;
    if (n < 3 || support_W[k].empty() || F[k].z() < 0.2 * mass * kGravity) continue;
    s.zmp = Eigen::Vector2d(c_P.x() - (s.com_height_m * F[k].x() + M[k].y()) / F[k].z(),
                            c_P.y() - (s.com_height_m * F[k].y() - M[k].x()) / F[k].z());
    int m = 0;
    for (const Eigen::Vector3d& p : support_W[k])
      if (m < static_cast<int>(points.size())) points[static_cast<std::size_t>(m++)] = (R_PW * p).head<2>();
    const int h = polygon::convexHull(points, m, hull);
    s.nearest = polygon::clampToHull(s.zmp, hull, h);
    s.outside_m = (s.zmp - s.nearest).norm();
    s.vertical_load = F[k].z() / (mass * kGravity);
    s.defined = true;
  }
  return out;
}

std::vector<Eigen::Vector2d> comShiftForZmp(const std::vector<Eigen::Vector2d>& e, double dt_s, double omega) {
  if (!(dt_s > 0) || !(omega > 0)) throw std::invalid_argument("comShiftForZmp: dt and omega must be > 0");
  const std::size_t n = e.size();
  std::vector<Eigen::Vector2d> x(n, Eigen::Vector2d::Zero());
  if (n == 0) return x;
  if (n == 1) {
    x[0] = e[0];
    return x;
  }
  // −a δ_{k−1} + (1 + 2a) δ_k − a δ_{k+1} = e_k; the ends (1 + a) on the diagonal.
  const double a = 1.0 / (omega * omega * dt_s * dt_s);
  std::vector<double> c(n);  // Thomas: modified super-diagonal
  auto diag = [&](std::size_t k) { return (k == 0 || k + 1 == n) ? 1.0 + a : 1.0 + 2.0 * a; };
  double d = diag(0);
  c[0] = -a / d;
  x[0] = e[0] / d;
  for (std::size_t k = 1; k < n; ++k) {
    d = diag(k) + a * c[k - 1];
    c[k] = -a / d;
    x[k] = (e[k] + a * x[k - 1]) / d;
  }
  for (std::size_t k = n - 1; k-- > 0;) x[k] -= c[k] * x[k + 1];
  return x;
}

}  // namespace dynfilter::io
