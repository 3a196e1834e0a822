#pragma once
/// @file
/// Gains and options of the dynamics filter. Defaults work on the human figure at a
/// 1 kHz control rate and on 120 Hz mocap offline; every number is in SI units.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "dynfilter/core/qp_solver.hpp"

namespace dynfilter {

/// Joint-space feedback (Eq. 17): v̇ᵈ⁰ = v̇ʳᵉᶠ + K_D (vʳᵉᶠ − v) + K_P (qʳᵉᶠ ⊖ q).
struct JointFeedbackGains {
  double base_linear_kp = 100.0;   ///< 1/s², base translation
  double base_linear_kd = 20.0;    ///< 1/s
  double base_angular_kp = 100.0;  ///< 1/s², base rotation
  double base_angular_kd = 20.0;   ///< 1/s
  double joint_kp = 400.0;         ///< 1/s², every joint
  double joint_kd = 40.0;          ///< 1/s
};

/// Task feedback of a point P on the upper body (Eq. 18–20).
struct TaskPointOptions {
  bool enabled = true;
  /// Link of P; empty: chosen from the model's structure (chooseTrunkBody in
  /// kinematic_tree.hpp: the trunk, e.g. the torso that carries the arms), see
  /// DynamicsFilter::taskBody().
  std::string body;
  Eigen::Vector3d p_BP = Eigen::Vector3d(0.0, 0.0, 0.3);         ///< P in that link (m)
  double kp_linear = 100.0, kd_linear = 20.0;    ///< 1/s², 1/s
  double kp_angular = 100.0, kd_angular = 20.0;  ///< 1/s², 1/s
  /// false: Eq. 19–20, P's desired acceleration corrects v̇ᵈ through J_P^# before the solve.
  /// true: Eq. 16, P's desired acceleration becomes 6 more equality rows of the solve.
  bool as_constraint_rows = false;
  /// Weight of the joint coordinates relative to the base ones in the weighted
  /// pseudo-inverse J_P^# = Wq⁻¹ J_Pᵀ (J_P Wq⁻¹ J_Pᵀ)⁻¹: > 1 moves the correction onto the base.
  double joint_weight = 10.0;
};

/// Virtual links from collision (Sect. 3.1) and how they are held.
struct ContactOptions {
  int max_links = 8;                 ///< virtual links held at once (each up to 6 axes)
  /// Baumgarte stabilisation of the virtual link error e: θ̈_C = −kd θ̇_C − kp e.
  double stabilization_kp = 2500.0;  ///< 1/s²
  double stabilization_kd = 100.0;   ///< 1/s
  /// Points of one body closer than this in the contact plane merge into one (m).
  double merge_distance_m = 2e-3;
  /// A link whose normal force stays below this for release_ticks ticks is released (N).
  double release_force_n = 0.0;
  int release_ticks = 3;
  /// A released body–object pair re-engages only when it penetrates this deep (m).
  double reengage_depth_m = 1e-4;
  /// On reset, a reference penetrating deeper than this is lifted out along world z (m).
  double initial_penetration_tolerance_m = 1e-3;
  /// Reset the velocity by a plastic impact when a virtual link appears.
  bool plastic_impact = true;
};

/// The paper's solve (Eq. 21–23).
struct PaperSolverOptions {
  double accel_weight = 1.0;   ///< weight of v̇ in the weighted pseudo-inverse W^#
  double force_weight = 1e-4;  ///< weight of τ_C in W^#; τ_J is not weighted
  double sr_damping = 1e-4;    ///< k of the SR inverse V_G^* = V_Gᵀ (V_G V_Gᵀ + k I)⁻¹
};

/// How Eq. 12 is solved each tick.
enum class FilterMode : int {
  kPaper = 0,  ///< the paper's Eq. 21–23: bilateral virtual links, no limits
  kQp = 1,     ///< the contact-consistent QP (contact_qp.hpp): unilateral, friction, CoP, limits
};

/// Parses "paper" / "qp"; returns false on anything else.
bool parseFilterMode(const std::string& text, FilterMode& mode);
const char* toString(FilterMode mode);

/// The QP mode (FilterMode::kQp): the paper's objective and equality rows plus the
/// inequalities of a physical contact and of the robot's limits.
struct QpModeOptions {
  /// Objective ½ w_a ‖v̇ − v̇ᵈ‖² + ½ w_f ‖τ_C‖² + ½ w_τ ‖τ_J‖².
  double accel_weight = 1.0;    ///< w_a
  double force_weight = 1e-6;   ///< w_f (per N² and (N m)²)
  double torque_weight = 1e-6;  ///< w_τ (per (N m)²)
  /// Normal force of every held contact ≥ this (N); a link sitting at it for
  /// ContactOptions::release_ticks ticks is released.
  double min_normal_force_n = 1.0;
  /// Facets of the linearised friction cone (inscribed pyramid), ≥ 3.
  int friction_facets = 4;
  /// The centre of pressure stays this far inside the support rectangle of a face or
  /// edge contact (m).
  double cop_margin_m = 0.0;
  /// When the reference lifts a held contact point this high above its anchor (m), the
  /// link's normal-force bound ramps down to the minimum over release_transition_s, then
  /// the link is released. Whatever the reason, a held link's normal force never drops
  /// faster than max(body weight, ramp start force) / release_transition_s.
  double liftoff_clearance_m = 0.02;
  double release_transition_s = 0.05;
  /// Joint position limits become acceleration bounds that stop the joint at its limit
  /// within this horizon (s, ≥ dt); velocity limits bound the acceleration over one tick.
  double joint_limit_horizon_s = 0.05;
  /// The limits never demand a deceleration beyond this (rad/s², m/s²): torque limits
  /// are hard, joint limits give way (a joint arriving too fast overshoots a little).
  double joint_limit_max_decel = 50.0;
  bool enforce_torque_limits = true;
  bool enforce_joint_limits = true;
  /// Edge and face links pivot about their normal when holding their yaw needs more twist
  /// than friction gives (|m_z| ≤ μ r f_z): the yaw row gives way and the twist sits at
  /// the bound, opposing the pivot (Coulomb), until the pivot stops.
  bool yaw_slip = true;
  /// Contacts slide (Coulomb): a link of a body out of the reference's stance (the balance
  /// layer's schedule, BalanceLayer::heldStance: lifted, or gliding while another body
  /// stands) whose contact point moves along the surface faster than 1 cm/s slides instead
  /// of sticking. Its two tangential rows give way for kinetic
  /// friction f_t = −μ f_n ŝ, ŝ the point's direction of motion, and its anchor follows the
  /// point. In the reference's stance a slide goes on until the point is slower than 5 cm/s.
  /// A new link's impact stops a sliding link only where that impulse lies within its
  /// friction cone. Needs the balance layer (its schedule); off: links stick (the paper).
  bool tangential_slip = true;
  QpSolverSettings solver;
};

/// Divergence guard: when the filter's state drifts too far from the reference or its solve
/// degrades, the state re-seeds from the reference (kStatusReseeded, FilterOutput::
/// reseed_reason). Errors are measured before the tick, qʳᵉᶠ ⊖ q.
struct DivergenceOptions {
  double max_base_error_m = 0.5;        ///< base position error (m)
  double max_base_rotation_rad = 1.0;   ///< base orientation error, angle of the SO(3) log (rad)
  double max_joint_error_rad = 2.0;     ///< any joint's error (rad, or m for a slider)
  /// Eq. 12 base rows beyond this fraction of the body weight: the tick's answer is not
  /// published (the last good output stays) and the state re-seeds.
  double max_base_residual_rel = 1e-6;
  /// This many consecutive ticks with a degraded solve (rank-deficient rows regularised,
  /// or a QP fallback) re-seed.
  int max_degraded_ticks = 200;
};

/// A body whose sole the balance layer keeps flat on the ground while it is in contact.
struct SoleOptions {
  std::string body;                                           ///< URDF link name
  Eigen::Vector3d n_B = Eigen::Vector3d::UnitZ();             ///< sole normal, body frame
};

/// The balance layer (QP mode, beyond the paper; balance.hpp): a centroidal task that the
/// whole-body QP tracks above the joint tracking of Eq. 17. The desired CoM acceleration
/// comes from divergent-component-of-motion (DCM, capture point) feedback towards a DCM
/// computed over the reference's future with its centre of pressure kept in its support.
struct BalanceOptions {
  bool enabled = true;
  /// Weight of the CoM acceleration rows (per (m/s²)², against 1 per (rad/s²)² of Eq. 17).
  double com_weight = 100.0;
  /// DCM feedback gain k: CoP command p = p_d + (1 + k)(ξ − ξ_d) (dimensionless).
  double dcm_gain = 4.0;
  /// CoM height feedback (1/s², 1/s).
  double height_kp = 100.0, height_kd = 20.0;
  /// Centroidal angular momentum damping L̇ = −k L (1/s) and the weight of its rows
  /// (per (N m)²).
  double angular_momentum_damping = 10.0;
  double angular_momentum_weight = 0.0;
  /// Look-ahead: the reference frames up to this far ahead of the tick enter the DCM
  /// (s, ≥ 0; the real-time process's reference delay, 50 ms, is its natural minimum).
  double preview_s = 0.05;
  /// Future reference frames kept (count).
  int preview_capacity = 512;
  /// A reference body point this close to the ground (m) and slower than stance_speed
  /// along the surface (m/s) supports the reference: the support polygon of its centre of
  /// pressure, and the contact schedule of the virtual links.
  double stance_height_m = 0.02;
  double stance_speed_mps = 0.5;
  /// Soles kept flat on the ground while their body holds a contact (feet).
  std::vector<SoleOptions> soles;
  double sole_weight = 10.0;            ///< per (rad/s²)²
  /// A held sole's points this close to the surface join its link (m): it becomes a face.
  double sole_margin_m = 0.005;
  double sole_kp = 400.0, sole_kd = 40.0;  ///< 1/s², 1/s
  /// Flat landing: a sole that touches down on a corner or an edge tilted by at most this
  /// (rad) holds a face link over its whole sole at once, anchored flat on the surface
  /// about the touching point; the link's stabilisation brings the sole down flat. 0: off.
  /// Never for a sole whose leg has fewer than six joints (it cannot lay the sole flat).
  double flat_landing_max_tilt_rad = 0.5;
  /// Rolling soles (heel-off, push-off): while the reference has a sole on its toes, tilted
  /// from its surface by more than this (rad), and lifts it within 0.25 s, a held face link
  /// of that sole becomes an edge link along its front edge, the sole task follows the
  /// reference's tilt, and the link does not upgrade back to a face until the reference's
  /// sole is flat again or the sole lands (BalanceLayer::rollSoles). 0: off.
  double roll_tilt_rad = 0.1;
};

/// The reference leash (reference_leash.hpp; off by default): a heading lag beyond
/// `max_heading_rad` and a base offset along the ground beyond `max_offset_m` move the
/// reference (and its preview) rigidly towards the figure instead of growing until the
/// divergence guard re-seeds. The figure then follows the reference's motion from where it stands: no
/// teleport for a turn or a drift it did not follow; falls still re-seed. Joint tracking is
/// unaffected; base and task-point targets move with the reference
/// (FilterOutput::X_reference_offset says by how much).
struct LeashOptions {
  bool enabled = false;
  double max_offset_m = 0.1;      ///< base offset along the ground (m), > 0
  double max_heading_rad = 0.17;  ///< heading lag (rad), > 0
};

struct FilterOptions {
  double dt_s = 1e-3;  ///< control tick (s)
  FilterMode mode = FilterMode::kPaper;
  QpModeOptions qp;
  JointFeedbackGains feedback;
  TaskPointOptions task;
  ContactOptions contacts;
  PaperSolverOptions solver;
  DivergenceOptions divergence;
  BalanceOptions balance;
  LeashOptions leash;

  /// Throws std::invalid_argument naming the option when a value is out of range.
  void validate() const;
};

}  // namespace dynfilter
