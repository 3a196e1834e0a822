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
/// Shift: the nearest CoM path whose ZMP, as a pendulum's (c − β c̈ + the reference's own
/// L̇ share, β = h / (g + z̈)), stays in the support: a QP per window of the clip, so that it
/// uses the past and the future (feasibleComPath). Not for per-tick use (allocates).

#include <vector>

#include <Eigen/Core>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/qp_solver.hpp"
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

/// One frame of a reference motion as a pendulum on its support (plane frame P).
/// ZMP = c − β c̈ + o along the plane, with β = h / (g + z̈) and o the share of the
/// reference's L̇ (both from the smoothed wrench the motion needs).
struct PendulumSample {
  double time_s = 0.0;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();  ///< CoM along the plane (m)
  double load = 0.0;      ///< F_z / (m g) of the needed force
  double beta_s2 = 0.0;   ///< β (s²); 0 where the frame has no support or load < 0.2
  Eigen::Vector2d moment_offset = Eigen::Vector2d::Zero();  ///< o (m)
  std::vector<Eigen::Vector2d> support;  ///< hull, counter-clockwise; empty: no support
};

/// The pendulum of every frame of @p motion against @p support_W (as zmpAgainstSupport).
/// Changes the model's state. @throws std::invalid_argument on a fixed-base model or
/// mismatched sizes.
std::vector<PendulumSample> pendulumSamples(const ReferenceMotion& motion, IDynamicsModel& model,
                                            const std::vector<std::vector<Eigen::Vector3d>>& support_W);

/// Settings of feasibleComPath.
struct FeasibleComOptions {
  double grid_s = 1.0 / 30.0;  ///< the path's time step (s); the frames between are interpolated
  double window_s = 3.0;       ///< each QP plans this far; consecutive windows overlap by half
  double max_shift_m = 0.25;   ///< |c* − c| per axis (m)
  double friction = 0.7;       ///< |c̈| per axis ≤ friction · g · load
  double accel_weight = 1e-3;  ///< per (m/s²)² and grid point, against 1 per m² of shift
  double slack_weight = 1e4;   ///< per m² of ZMP outside the support
  /// @throws std::invalid_argument on a value out of range.
  void validate() const;
};

/// What feasibleComPath met.
struct FeasibleComReport {
  int windows = 0;
  int unsolved = 0;               ///< windows whose QP stopped short of its tolerance
  double max_violation_m = 0.0;   ///< largest ZMP distance outside the support left (slack)
};

/// The centre-of-mass path nearest to the samples' that the pendulum can follow: per grid
/// point, ZMP inside the support (softly: a slack per point, weighted heavily) and the
/// horizontal force inside a friction box, with a small acceleration cost; a QP per
/// window, solved by @p qp_solver, each continuing the last. Frames between grid points
/// get the shift interpolated linearly. Not for per-tick use (allocates).
/// @throws std::invalid_argument on invalid options, times that do not increase or no solver.
std::vector<Eigen::Vector2d> feasibleComPath(const std::vector<PendulumSample>& samples,
                                             const FeasibleComOptions& options,
                                             const QpSolverFactory& qp_solver,
                                             FeasibleComReport* report = nullptr);

}  // namespace dynfilter::io
