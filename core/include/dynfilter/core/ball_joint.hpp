#pragma once
/// @file
/// The coordinates of a ball (spherical) joint, the same in every backend.
///
/// A ball joint contributes three joint coordinates, named `<joint>_x`, `<joint>_y`,
/// `<joint>_z`: q = θ, the rotation vector (rad) of the child's joint frame C relative to
/// the parent's joint frame P, R_PC = expSO3(θ), read back with |θ| ≤ π (logSO3); and
/// v = θ̇ (rad/s). So q̇ = v holds for a ball joint as for every other joint, and the
/// core's joint-space integration (q + v dt) and differences (q₁ − q₀) stay exact as long
/// as the joint does not cross |θ| = π (where the read-back wraps to the other side).
///
/// The child's angular velocity relative to the parent, in C, is ω_C = J_r(θ) θ̇ with
/// J_r the right Jacobian of SO(3); by power balance the generalized force of a torque
/// t_C about the joint (in C, on the child, −t_C on the parent) is τ = J_r(θ)ᵀ t_C, so an
/// engine applies t_C = J_r(θ)⁻ᵀ τ. J_r is invertible for |θ| < 2π.

#include <Eigen/Core>

namespace dynfilter {

/// Coordinates per ball joint.
constexpr int kBallJointDofs = 3;

/// Right Jacobian of SO(3): ω_C = J_r(θ) θ̇ for R_PC = expSO3(θ).
Eigen::Matrix3d rightJacobianSO3(const Eigen::Vector3d& theta);

/// The drift J̇_r(θ, θ̇) θ̇ (rad/s²): the part of ω̇_C that does not come from θ̈, so that
/// ω̇_C = J_r θ̈ + J̇_r θ̇. No heap allocation.
Eigen::Vector3d rightJacobianSO3DotTimes(const Eigen::Vector3d& theta,
                                         const Eigen::Vector3d& theta_dot);

}  // namespace dynfilter
