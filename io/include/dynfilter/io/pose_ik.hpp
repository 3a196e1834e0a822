#pragma once
/// @file
/// Whole-body inverse kinematics for retargeting and reference clean-up: position and
/// orientation targets of points on bodies and a posture, met in the weighted
/// least-squares sense within the joint position limits, with the model's own Jacobians
/// (IDynamicsModel::pointJacobian), so it works for any URDF and backend.
///
/// Per iteration (Gauss–Newton with Levenberg damping): with e_i the target errors —
/// position p*_i − p_i (m, world) and orientation log(R*_i R_iᵀ) (rad, world) — and the
/// posture error e_q = q_posture ⊖ q (v coordinates), solve
///   min_dv Σ_i w_i² ‖J_i dv − e_i‖² + Σ_c w_c² (dv_c − e_q,c)² + λ ‖dv‖²
/// subject to q_lower − q ≤ dv_joints ≤ q_upper − q by an active set on the bounds
/// (coordinates that would leave their limits are fixed at the limit and the rest
/// solved again), with the step limited to 0.5 (rad, m) per coordinate. Levenberg–
/// Marquardt: the diagonal is raised by μ (H_cc + 1); a step that does not lower the
/// objective is retried with 10 μ, an accepted one lowers μ 3× (not below 1e-6). Stops
/// when ‖dv‖∞ < tolerance, when no step lowers the objective (converged: a minimum within
/// the bounds), or after max_iterations. Before, a step was halved at most 7 times and
/// then taken even when it raised the objective: where a stretched leg made J nearly
/// singular the answer oscillated by millimetres from frame to frame.
/// Not for per-tick use (allocates).

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/dynamics_model.hpp"

namespace dynfilter::io {

/// A target for the point P fixed on a body.
struct IkTarget {
  int body = -1;
  Eigen::Vector3d p_BP = Eigen::Vector3d::Zero();  ///< P in the body frame (m)
  Eigen::Vector3d p_WP = Eigen::Vector3d::Zero();  ///< where P should be (world, m)
  Eigen::Matrix3d R_WB = Eigen::Matrix3d::Identity();  ///< orientation the body should have
  double position_weight = 1.0;     ///< 1/m; 0: no position target
  double orientation_weight = 0.0;  ///< 1/rad; 0: no orientation target
};

struct IkOptions {
  int max_iterations = 50;
  double tolerance = 1e-7;   ///< on ‖dv‖∞ (rad, m)
  double damping = 1e-6;     ///< λ
  /// w_c (1/rad, 1/m): with a previous answer given, adds w_c² ‖q ⊖ q_previous‖² to the
  /// objective, so that a sequence of solves follows one branch of the solution instead of
  /// jumping between local minima from one frame to the next.
  double continuity_weight = 0.0;
};

struct IkResult {
  int iterations = 0;
  bool converged = false;
};

/// Solves in place: @p q (dim nq) is the start and the answer; it is first clamped into
/// the joint limits. @p q_posture dim nq, @p posture_weights dim nv (per v coordinate);
/// @p q_previous (dim nq, or null) is the configuration IkOptions::continuity_weight holds
/// the answer near. Changes the model's state.
IkResult solvePoseIk(IDynamicsModel& model, const std::vector<IkTarget>& targets,
                     const Eigen::VectorXd& q_posture, const Eigen::VectorXd& posture_weights,
                     const IkOptions& options, Eigen::VectorXd& q,
                     const Eigen::VectorXd* q_previous = nullptr);

/// Errors of a target at the model's current state: position (m) and orientation (rad).
void ikTargetError(const IDynamicsModel& model, const IkTarget& target, double& position_m,
                   double& orientation_rad);

}  // namespace dynfilter::io
