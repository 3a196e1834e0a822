#include "dynfilter/core/lie_group.hpp"

#include <algorithm>
#include <cmath>

namespace dynfilter {
namespace {

// Below this angle the ratios of sines and cosines lose digits to cancellation; their
// Taylor series (truncation error below 1e-17 here) take over.
constexpr double kSeriesAngle = 1e-2;

// Left Jacobian of SO(3): V(ω) with p = V(ω) v in expSE3.
Eigen::Matrix3d leftJacobianSO3(const Eigen::Vector3d& omega) {
  const double theta2 = omega.squaredNorm();
  const double theta = std::sqrt(theta2);
  const Eigen::Matrix3d K = skew(omega);
  double a, b;  // V = I + a K + b K²
  if (theta < kSeriesAngle) {
    a = 0.5 - theta2 / 24.0 + theta2 * theta2 / 720.0;
    b = 1.0 / 6.0 - theta2 / 120.0 + theta2 * theta2 / 5040.0;
  } else {
    const double s = std::sin(0.5 * theta);
    a = 2.0 * s * s / theta2;  // (1 − cos θ) / θ² without cancellation
    b = (theta - std::sin(theta)) / (theta2 * theta);
  }
  return Eigen::Matrix3d::Identity() + a * K + b * K * K;
}

Eigen::Matrix3d leftJacobianInverseSO3(const Eigen::Vector3d& omega) {
  const double theta2 = omega.squaredNorm();
  const double theta = std::sqrt(theta2);
  const Eigen::Matrix3d K = skew(omega);
  double c;  // V⁻¹ = I − K/2 + c K²
  if (theta < kSeriesAngle) {
    c = 1.0 / 12.0 + theta2 / 720.0 + theta2 * theta2 / 30240.0;
  } else {
    const double half = 0.5 * theta;
    c = (1.0 - half * std::cos(half) / std::sin(half)) / theta2;
  }
  return Eigen::Matrix3d::Identity() - 0.5 * K + c * K * K;
}

// Heading of a base about world z: its x axis on the ground, or its y axis turned by −π/2
// where x is within 45° of vertical (tiltAndHeading).
double headingOf(const Eigen::Matrix3d& R_WB) {
  const Eigen::Vector3d& x = R_WB.col(0);
  if (x.head<2>().norm() >= std::sqrt(0.5)) return std::atan2(x.y(), x.x());
  const Eigen::Vector3d& y = R_WB.col(1);
  return std::atan2(-y.x(), y.y());
}

}  // namespace

Eigen::Matrix3d skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d S;
  S << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return S;
}

Eigen::Matrix3d expSO3(const Eigen::Vector3d& omega) {
  // Rodrigues: R = I + (sin θ / θ) K + ((1 − cos θ) / θ²) K², both ratios evaluated
  // without cancellation.
  const double theta2 = omega.squaredNorm();
  const double theta = std::sqrt(theta2);
  const Eigen::Matrix3d K = skew(omega);
  double a, b;
  if (theta < kSeriesAngle) {
    a = 1.0 - theta2 / 6.0 + theta2 * theta2 / 120.0;
    b = 0.5 - theta2 / 24.0 + theta2 * theta2 / 720.0;
  } else {
    const double s = std::sin(0.5 * theta);
    a = std::sin(theta) / theta;
    b = 2.0 * s * s / theta2;
  }
  return Eigen::Matrix3d::Identity() + a * K + b * K * K;
}

Eigen::Vector3d logSO3(const Eigen::Matrix3d& R) {
  // Through the quaternion: accurate at both small angles and near π.
  Eigen::Quaterniond quat(R);
  if (quat.w() < 0.0) quat.coeffs() = -quat.coeffs();  // angle in [0, π]
  const double sin_half = quat.vec().norm();
  if (sin_half < 1e-12) return 2.0 * quat.vec();
  const double theta = 2.0 * std::atan2(sin_half, quat.w());
  return quat.vec() * (theta / sin_half);
}

Eigen::Isometry3d expSE3(const Vector6d& twist) {
  const Eigen::Vector3d v = twist.head<3>();
  const Eigen::Vector3d omega = twist.tail<3>();
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = expSO3(omega);
  X.translation() = leftJacobianSO3(omega) * v;
  return X;
}

Vector6d logSE3(const Eigen::Isometry3d& X) {
  Vector6d twist;
  const Eigen::Vector3d omega = logSO3(X.linear());
  twist.tail<3>() = omega;
  twist.head<3>() = leftJacobianInverseSO3(omega) * X.translation();
  return twist;
}

void moveBase(const Eigen::Isometry3d& X_WW, Eigen::Ref<Eigen::VectorXd> q) {
  setBasePoseInConfiguration(X_WW * basePoseFromConfiguration(q), q);
}

Eigen::Isometry3d basePoseFromConfiguration(const Eigen::Ref<const Eigen::VectorXd>& q) {
  Eigen::Quaterniond quat(q[3], q[4], q[5], q[6]);
  quat.normalize();
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = quat.toRotationMatrix();
  X.translation() = q.head<3>();
  return X;
}

void setBasePoseInConfiguration(const Eigen::Isometry3d& X_WB, Eigen::Ref<Eigen::VectorXd> q) {
  const Eigen::Quaterniond quat(X_WB.linear());
  q.head<3>() = X_WB.translation();
  q[3] = quat.w();
  q[4] = quat.x();
  q[5] = quat.y();
  q[6] = quat.z();
}

void integrateConfiguration(bool floating_base, const Eigen::Ref<const Eigen::VectorXd>& q,
                            const Eigen::Ref<const Eigen::VectorXd>& v, double dt,
                            Eigen::Ref<Eigen::VectorXd> q_out) {
  if (!floating_base) {
    q_out = q + dt * v;
    return;
  }
  const int nj = static_cast<int>(v.size()) - kFloatingBaseNv;
  const Eigen::Isometry3d X_WB = basePoseFromConfiguration(q);
  const Vector6d base_step = dt * v.head<6>();
  const Eigen::Isometry3d X_WB_next = X_WB * expSE3(base_step);
  q_out.tail(nj) = q.tail(nj) + dt * v.tail(nj);
  setBasePoseInConfiguration(X_WB_next, q_out);
}

void differenceConfiguration(bool floating_base, const Eigen::Ref<const Eigen::VectorXd>& q0,
                             const Eigen::Ref<const Eigen::VectorXd>& q1,
                             Eigen::Ref<Eigen::VectorXd> dv_out) {
  if (!floating_base) {
    dv_out = q1 - q0;
    return;
  }
  const int nj = static_cast<int>(dv_out.size()) - kFloatingBaseNv;
  const Eigen::Isometry3d X_B0B1 =
      basePoseFromConfiguration(q0).inverse() * basePoseFromConfiguration(q1);
  dv_out.head<6>() = logSE3(X_B0B1);
  dv_out.tail(nj) = q1.tail(nj) - q0.tail(nj);
}

TiltHeading tiltAndHeading(const Eigen::Matrix3d& R_WA, const Eigen::Matrix3d& R_WB) {
  TiltHeading out;
  out.tilt_rad = std::acos(std::clamp(R_WA.col(2).dot(R_WB.col(2)), -1.0, 1.0));
  out.heading_rad = std::remainder(headingOf(R_WB) - headingOf(R_WA), 2.0 * M_PI);
  if (out.heading_rad <= -M_PI) out.heading_rad += 2.0 * M_PI;
  return out;
}

}  // namespace dynfilter
