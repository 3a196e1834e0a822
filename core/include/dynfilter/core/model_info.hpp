#pragma once
/// @file
/// Immutable description of a model's coordinates, names and limits, shared by every backend.
///
/// Coordinates (one convention, every backend, every file and message):
/// - floating base: q = [p_WB (3, m, world); quat_WB (w, x, y, z); joints (nj)],
///   nq = 7 + nj; v = [v_B (3, m/s, base frame); ω_B (3, rad/s, base frame); joints (nj)],
///   nv = 6 + nj (the paper's N_G). This is Pinocchio's free-flyer convention.
/// - fixed base: q = joints, v = joint rates, nq = nv = nj.
/// - joints are the moving joints of the URDF (revolute, continuous, prismatic) in the
///   order they appear in the file; fixed joints carry no coordinate.
///   A model attached to a user's own simulation takes their joints in their order; a ball
///   joint there carries three coordinates (ball_joint.hpp: q = θ, v = θ̇).
/// - bodies are all URDF links in file order; a body index addresses a link everywhere.
/// SI units throughout (m, rad, kg, s, N, N m).

#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace dynfilter {

/// Largest accepted |‖quat‖ − 1| of a base quaternion handed to a model.
constexpr double kUnitQuaternionTolerance = 1e-6;

/// Result of a non-throwing state check (per-tick paths use this, not exceptions).
struct StateCheck {
  bool ok = true;
  int index = -1;              ///< offending entry of q (or of v when in_velocity)
  bool in_velocity = false;    ///< whether @ref index refers to v
  const char* reason = "";     ///< static string, e.g. "not finite"
};

struct ModelInfo {
  std::string name;                 ///< robot name from the URDF
  bool floating_base = true;
  int nq = 0;                       ///< configuration size
  int nv = 0;                       ///< velocity size (N_G)
  int nj = 0;                       ///< actuated joints (N_J)
  std::vector<std::string> joint_names;  ///< dim nj, URDF file order
  std::vector<std::string> body_names;   ///< all links, URDF file order
  /// Joints of the description welded on request (e.g. --lock-joints), URDF file order: not
  /// in joint_names; a reference's columns for them are not read.
  std::vector<std::string> locked_joint_names;
  Eigen::VectorXd q_lower;   ///< dim nj; −inf for continuous joints (rad or m)
  Eigen::VectorXd q_upper;   ///< dim nj; +inf for continuous joints (rad or m)
  Eigen::VectorXd v_max;     ///< dim nj; |q̇| bound (rad/s or m/s); +inf when absent
  Eigen::VectorXd tau_max;   ///< dim nj; |τ| bound (N m or N); +inf when absent
  double total_mass = 0.0;   ///< kg

  /// Index in v of joint @p j (0 ≤ j < nj).
  int velocityIndex(int j) const { return (floating_base ? 6 : 0) + j; }
  /// Index in q of joint @p j (0 ≤ j < nj).
  int configurationIndex(int j) const { return (floating_base ? 7 : 0) + j; }
  /// Joint index by name, −1 when unknown.
  int findJoint(std::string_view joint_name) const;
  /// Body index by link name, −1 when unknown.
  int findBody(std::string_view link_name) const;

  /// Non-throwing check of sizes, finiteness and the unit base quaternion.
  StateCheck checkState(const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& v) const;
  /// Throws InvalidStateError with a message naming the entry when checkState fails.
  void requireValidState(const Eigen::Ref<const Eigen::VectorXd>& q,
                         const Eigen::Ref<const Eigen::VectorXd>& v) const;
  /// The neutral configuration: base at the origin with identity orientation, joints at 0
  /// (clamped into their limits).
  Eigen::VectorXd neutralConfiguration() const;
};

}  // namespace dynfilter
