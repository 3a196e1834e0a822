#pragma once
/// @file
/// Centroidal feasibility of a reference motion: where its zero-moment point (ZMP) lies
/// against its support, and the horizontal centre-of-mass shift that brings it inside.
/// The clean-up's balance stage (reference_cleanup.hpp) is built on these.
///
/// ZMP: the point of the ground plane about which the contact wrench the motion needs —
/// force F = m (c̈ − g), moment L̇ about the CoM c — has no moment along the plane. In the
/// plane frame P (x, y along the plane, z its normal; h = c's height above the plane):
///   p_x = c_x − (h F_x + L̇_y) / F_z,   p_y = c_y − (h F_y − L̇_x) / F_z.
/// F and L̇ come from central differences of the motion's ċ and L, Gaussian-smoothed over
/// σ = 40 ms (captured motion's second derivative is noisy; the pendulum's time constant is
/// ~0.3 s). The ZMP is defined where F_z > 0.2 m g and some body supports the motion.
///
/// Shift: moving the CoM by δ(t) along the plane moves the ZMP by δ − δ̈/ω² (linear
/// inverted pendulum, ω = √(g/h)). The δ that moves each frame's ZMP by e_k solves
/// δ_k − (δ_{k+1} − 2δ_k + δ_{k−1}) / (ω² Δt²) = e_k with zero slope at both ends: a
/// symmetric, diagonally dominant tridiagonal system, solved exactly. Its answer is e
/// smoothed by the kernel (ω/2) e^{−ω|t|}: it uses the past and the future of the clip.
/// Not for per-tick use (allocates).

#include <vector>

#include <Eigen/Core>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/io/reference_motion.hpp"

namespace dynfilter::io {

/// The ground's plane frame: rows are its x, y axes along the plane and its normal (world).
Eigen::Matrix3d groundPlaneFrame(const IDynamicsModel& model);

/// One frame's ZMP against its support, in the plane frame (m).
struct ZmpSample {
  bool defined = false;   ///< F_z > 0.2 m g and a support polygon
  Eigen::Vector2d zmp = Eigen::Vector2d::Zero();
  Eigen::Vector2d nearest = Eigen::Vector2d::Zero();  ///< nearest point of the support
  double outside_m = 0.0;  ///< |zmp − nearest|
  double com_height_m = 0.0;
  double vertical_load = 0.0;  ///< F_z / (m g)
};

/// The ZMP of every frame of @p motion (q, v and v̇ used) against @p support_W[k], the
/// world points whose convex hull (in the plane) supports frame k (none: no support).
/// Changes the model's state. @throws std::invalid_argument on a fixed-base model or
/// mismatched sizes.
std::vector<ZmpSample> zmpAgainstSupport(const ReferenceMotion& motion, IDynamicsModel& model,
                                         const std::vector<std::vector<Eigen::Vector3d>>& support_W);

/// δ (plane frame, m) per frame with δ − δ̈/ω² = @p e (see file comment); @p dt_s the frame
/// period, @p omega ω (1/s). @throws std::invalid_argument on dt_s or omega ≤ 0.
std::vector<Eigen::Vector2d> comShiftForZmp(const std::vector<Eigen::Vector2d>& e, double dt_s, double omega);

}  // namespace dynfilter::io
