#pragma once
/// @file
/// Lie-group helpers for the floating base and the configuration space.
///
/// Conventions (fixed for the whole project, see model_info.hpp):
/// - a twist / tangent vector of SE(3) is ordered [linear; angular] and expressed in the
///   moving (body) frame, so `X_WB_next = X_WB * exp6(twist_B * dt)`;
/// - q = [p_WB (3, m); quaternion (w, x, y, z) of R_WB (4); joint positions (nj)],
///   v = [linear velocity of B in B (3, m/s); angular velocity of B in B (3, rad/s);
///   joint velocities (nj)] for a floating base. A fixed-base model has q = joints, v = rates.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/types.hpp"

namespace dynfilter {

/// Skew-symmetric matrix with `skew(a) * b == a.cross(b)`.
Eigen::Matrix3d skew(const Eigen::Vector3d& a);

/// SO(3) exponential: rotation matrix of the rotation vector @p omega (rad).
Eigen::Matrix3d expSO3(const Eigen::Vector3d& omega);

/// SO(3) logarithm: rotation vector (rad, angle in [0, π]) of @p R.
Eigen::Vector3d logSO3(const Eigen::Matrix3d& R);

/// SE(3) exponential of a body twist [linear; angular] (integrated over unit time).
Eigen::Isometry3d expSE3(const Vector6d& twist);

/// SE(3) logarithm: the body twist [linear; angular] with `expSE3(logSE3(X)) == X`.
Vector6d logSE3(const Eigen::Isometry3d& X);

/// Number of configuration / velocity coordinates of the base part.
constexpr int kFloatingBaseNq = 7;
constexpr int kFloatingBaseNv = 6;

/// Base pose X_WB from the first 7 entries of a floating-base q (quaternion normalised).
Eigen::Isometry3d basePoseFromConfiguration(const Eigen::Ref<const Eigen::VectorXd>& q);

/// Writes X_WB into the first 7 entries of q (quaternion as w, x, y, z; w ≥ 0 not enforced).
void setBasePoseInConfiguration(const Eigen::Isometry3d& X_WB, Eigen::Ref<Eigen::VectorXd> q);

/// Moves the base pose in a floating-base q by the rigid motion X_WW' (world): X_WB ← X_WW' X_WB.
/// Joints, and the base-frame velocities that go with q, are unchanged.
void moveBase(const Eigen::Isometry3d& X_WW, Eigen::Ref<Eigen::VectorXd> q);

/// q_out = q ⊕ (v·dt): base by `X_WB * expSE3(v_base * dt)`, joints by `q + v dt`.
/// @param floating_base whether q/v carry the 7/6 base coordinates in front
/// @param q      dim nq
/// @param v      dim nv
/// @param q_out  dim nq; may alias @p q. The quaternion of q_out is unit norm.
/// No heap allocation.
void integrateConfiguration(bool floating_base, const Eigen::Ref<const Eigen::VectorXd>& q,
                            const Eigen::Ref<const Eigen::VectorXd>& v, double dt,
                            Eigen::Ref<Eigen::VectorXd> q_out);

/// dv = q1 ⊖ q0: the velocity that carries q0 to q1 in unit time, i.e.
/// `integrateConfiguration(fb, q0, dv, 1, q)` gives q1. Base part: logSE3(X_WB0⁻¹ X_WB1).
/// @param dv_out dim nv. No heap allocation.
void differenceConfiguration(bool floating_base, const Eigen::Ref<const Eigen::VectorXd>& q0,
                             const Eigen::Ref<const Eigen::VectorXd>& q1,
                             Eigen::Ref<Eigen::VectorXd> dv_out);

/// How two base orientations differ, split into what balance cares about and what it does
/// not (world z up): `tilt_rad` is the angle between the bases' z axes ([0, π]); `heading_rad`
/// is the turn about world z from A's heading to B's ((−π, π]), a base's heading being the
/// direction of its x axis projected on the ground (of its y axis turned by −π/2 where x is
/// within 45° of vertical). tilt ≤ the angle of R_WA⁻¹ R_WB; a turn about world z alone
/// gives tilt 0 and heading = that turn.
struct TiltHeading {
  double tilt_rad = 0.0;
  double heading_rad = 0.0;
};
TiltHeading tiltAndHeading(const Eigen::Matrix3d& R_WA, const Eigen::Matrix3d& R_WB);

}  // namespace dynfilter
