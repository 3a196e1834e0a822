#include "dynfilter/core/ball_joint.hpp"

#include <cmath>

#include "dynfilter/core/lie_group.hpp"

namespace dynfilter {
namespace {

// J_r(θ) = I − a(φ) K + b(φ) K², K = [θ]×, φ = |θ|, with a = (1 − cos φ)/φ² and
// b = (φ − sin φ)/φ³; below kSeries their Taylor series (the closed forms cancel).
constexpr double kSeries = 0.1;

struct Coefficients {
  double a, b;              // as above
  double da_over_phi;       // a'(φ)/φ
  double db_over_phi;       // b'(φ)/φ
};

Coefficients coefficients(double phi) {
  const double p2 = phi * phi;
  if (phi < kSeries) {
    const double p4 = p2 * p2;
    return {0.5 - p2 / 24.0 + p4 / 720.0, 1.0 / 6.0 - p2 / 120.0 + p4 / 5040.0,
            -1.0 / 12.0 + p2 / 180.0 - p4 / 6720.0, -1.0 / 60.0 + p2 / 1260.0 - p4 / 60480.0};
  }
  const double s = std::sin(phi), c = std::cos(phi);
  const double p3 = p2 * phi;
  return {(1.0 - c) / p2, (phi - s) / p3, (phi * s - 2.0 * (1.0 - c)) / (p2 * p2),
          ((1.0 - c) * phi - 3.0 * (phi - s)) / (p3 * p2)};
}

}  // namespace

Eigen::Matrix3d rightJacobianSO3(const Eigen::Vector3d& theta) {
  const Coefficients k = coefficients(theta.norm());
  const Eigen::Matrix3d K = skew(theta);
  return Eigen::Matrix3d::Identity() - k.a * K + k.b * K * K;
}

Eigen::Vector3d rightJacobianSO3DotTimes(const Eigen::Vector3d& theta,
                                         const Eigen::Vector3d& theta_dot) {
  // d/dt(J_r) θ̇ = −ȧ θ×θ̇ + ḃ θ×(θ×θ̇) + b θ̇×(θ×θ̇) (the terms with θ̇×θ̇ vanish),
  // ȧ = a'(φ) φ̇ = (a'/φ)(θ·θ̇).
  const Coefficients k = coefficients(theta.norm());
  const double rate = theta.dot(theta_dot);
  const Eigen::Vector3d cross = theta.cross(theta_dot);
  return -k.da_over_phi * rate * cross + k.db_over_phi * rate * theta.cross(cross) +
         k.b * theta_dot.cross(cross);
}

}  // namespace dynfilter
