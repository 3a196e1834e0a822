#pragma once
/// @file
/// What one filter tick produces: the filtered state, torques, contact wrenches, the
/// Eq. 12 residual, errors, timings and a status (MuJoCo-style: every tick reports).

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/types.hpp"

namespace dynfilter {

/// Per-tick outcome. Bits may combine; kOk is 0.
enum FilterStatusBits : std::uint32_t {
  kStatusOk = 0,
  kStatusContactOverflow = 1u << 0,   ///< more virtual links than max_links; extras ignored
  kStatusRankDeficient = 1u << 1,     ///< constraint rows were (near) dependent; regularised
  kStatusNonFinite = 1u << 2,         ///< the solve produced NaN/Inf; state held, not published
  kStatusReferenceInvalid = 1u << 3,  ///< the reference frame was rejected; previous one used
  kStatusReseeded = 1u << 4,          ///< divergence: the state was reset to the reference
  kStatusImpact = 1u << 5,            ///< a plastic impact reset the velocity this tick
  kStatusTorqueClamped = 1u << 6,     ///< a published torque was clamped to its URDF limit
  kStatusStaleReference = 1u << 7,    ///< no reference for the timeout: holding posture
  /// QP mode: the QP was infeasible, hit its iteration limit or violated a constraint
  /// family (FilterOutput::qp_violated); the tick used the paper-mode solution with
  /// torques clamped to their limits (Eq. 14 re-solved so that Eq. 12 still holds).
  kStatusQpFallback = 1u << 8,
  /// QP mode: the full QP was infeasible; this tick's answer is that of a relaxation
  /// (FilterOutput::qp_relaxation; FilterOutput::qp_violated says what the full QP violated).
  kStatusQpRelaxed = 1u << 9,
  /// The reference cannot be followed physically (FilterOutput::infeasible_reason, e.g.
  /// hanging in the air); the filter keeps its physical state and does not re-seed on
  /// tracking errors while this lasts.
  kStatusReferenceInfeasible = 1u << 10,
  /// QP mode: a QP solve of this tick stopped at its iteration cap (QpSolverSettings::
  /// max_iterations); its iterate was used if it passed the constraint check, else the
  /// fallback above.
  kStatusQpIterationLimit = 1u << 11,
};

/// Why the state was re-seeded from the reference (with kStatusReseeded).
enum class ReseedReason : int {
  kNone = 0,
  kNonFinite = 1,      ///< the solve produced NaN/Inf
  kBasePosition = 2,   ///< DivergenceOptions::max_base_error_m
  kBaseRotation = 3,   ///< DivergenceOptions::max_base_rotation_rad
  kJoint = 4,          ///< DivergenceOptions::max_joint_error_rad
  kResidual = 5,       ///< DivergenceOptions::max_base_residual_rel
  kDegradedSolve = 6,  ///< DivergenceOptions::max_degraded_ticks
};
/// "non-finite solve", "base position error", ...; a static string ("" for kNone).
const char* toString(ReseedReason reason);

/// Running counters since the filter was made (every tick reports them).
struct FilterCounters {
  std::uint64_t ticks = 0;
  std::uint64_t impacts = 0;              ///< ticks with a plastic impact
  std::uint64_t reseeds = 0;              ///< divergence or non-finite re-seeds
  std::uint64_t invalid_references = 0;   ///< ticks whose reference was rejected
  std::uint64_t links_released = 0;       ///< virtual links released
  std::uint64_t qp_solves = 0;            ///< QP mode: QPs solved and accepted
  std::uint64_t qp_fallbacks = 0;         ///< QP mode: ticks that fell back to paper mode
  std::uint64_t qp_relaxed = 0;           ///< QP mode: ticks answered by a relaxation
  std::uint64_t pivot_ticks = 0;          ///< QP mode: ticks with a sole pivoting (ContactOutput::pivot)
  std::uint64_t slide_ticks = 0;          ///< QP mode: ticks with a contact sliding (ContactOutput::slide_W)
  std::uint64_t qp_iterations = 0;        ///< QP mode: total solver iterations
  std::uint64_t leash_ticks = 0;          ///< ticks on which the reference leash moved the reference
};

/// Kinds of virtual link, by the number of constrained axes of the contact frame.
enum class ContactKind : int { kPoint = 3, kEdge = 5, kFace = 6 };

/// One virtual link's result this tick. Frame A: the link's anchor, z = surface normal.
struct ContactOutput {
  int body = -1;
  int object = -1;
  ContactKind kind = ContactKind::kPoint;
  Eigen::Vector3d p_WC = Eigen::Vector3d::Zero();   ///< contact frame origin (m)
  Eigen::Vector3d n_W = Eigen::Vector3d::UnitZ();   ///< surface normal
  Vector6d wrench_W = Vector6d::Zero();             ///< [force; moment about p_WC], world (N, N m)
  double normal_force_n = 0.0;                      ///< force along n_W (N); < 0 pulls
  Eigen::Vector2d cop_A = Eigen::Vector2d::Zero();  ///< centre of pressure in the anchor xy (m)
  /// Support rectangle of the link in the anchor xy about its origin (m): where the CoP may
  /// lie (zero for a point; an edge's along x only).
  Eigen::Vector2d support_min_A = Eigen::Vector2d::Zero();
  Eigen::Vector2d support_max_A = Eigen::Vector2d::Zero();
  /// Edges, faces (QP mode): 0 while the link holds its yaw; ±1 while it pivots about n_W,
  /// the sign σ of its twist wrench·n = σ μ r f_n at friction's bound (QpModeOptions::yaw_slip).
  int pivot = 0;
  /// QP mode (QpModeOptions::tangential_slip): the unit direction in which the contact point
  /// slides along the surface, world; zero while the link sticks. The tangential force is then
  /// −μ · normal_force_n along it.
  Eigen::Vector3d slide_W = Eigen::Vector3d::Zero();
};

struct FilterOutput {
  double time_s = 0.0;
  std::uint32_t status = kStatusOk;
  Eigen::VectorXd q;      ///< dim nq, filtered configuration after the tick
  Eigen::VectorXd v;      ///< dim nv
  Eigen::VectorXd vdot;   ///< dim nv, the acceleration that satisfies Eq. 12
  Eigen::VectorXd tau_J;  ///< dim nj, joint torques (N m / N)
  std::vector<ContactOutput> contacts;  ///< capacity max_links; first num_contacts valid
  int num_contacts = 0;
  Eigen::VectorXd tracking_error;  ///< dim nv: qʳᵉᶠ ⊖ q before the tick
  Vector6d task_error = Vector6d::Zero();  ///< P pose error [m; rad] before the tick
  double eq12_residual = 0.0;  ///< max |W x − u| over all rows (N, N m, m/s²)
  double base_residual_n = 0.0;  ///< max |row| of the six unactuated base rows (N, N m)
  double solve_time_s = 0.0;     ///< Eq. 21–23 only
  double tick_time_s = 0.0;      ///< the whole tick
  double max_penetration_m = 0.0;
  ReseedReason reseed_reason = ReseedReason::kNone;  ///< this tick's, with kStatusReseeded
  /// The rigid motion the reference leash (LeashOptions) has applied to the reference so
  /// far, X_WW' (world): the reference this tick tracked is the one received moved by it.
  /// Identity without the leash.
  Eigen::Isometry3d X_reference_offset = Eigen::Isometry3d::Identity();
  /// With kStatusReferenceInfeasible: why (InfeasibleReason of balance.hpp; 0 none).
  int infeasible_reason = 0;
  /// QP mode with the balance layer: centre of mass of the filtered state and of the
  /// reference (world, m), before the tick.
  Eigen::Vector3d com_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d com_reference_W = Eigen::Vector3d::Zero();
  // QP mode (FilterMode::kQp); zero in paper mode.
  int qp_status = 0;                ///< QpSolveStatus of this tick's solve (0 solved)
  int qp_iterations = 0;            ///< solver iterations this tick
  double qp_solver_time_s = 0.0;    ///< of solve_time_s, the time inside the QP engine
  std::uint32_t qp_violated = 0;    ///< QpConstraintFamily bits the full QP's answer violated
  /// Relaxations used this tick (bits): 1 joint-limit bounds dropped, 2 release ramps
  /// dropped, 4 contacts released; before that, the floor's rungs (ContactQpReport::
  /// floor_rung): 8 dependent contact rows freed, 16 every edge and face tipped
  /// (held as points), 32 every link a frictionless point.
  std::uint32_t qp_relaxation = 0;
  FilterCounters counters;

  FilterOutput() = default;
  FilterOutput(int nq, int nv, int nj, int max_links)
      : q(Eigen::VectorXd::Zero(nq)),
        v(Eigen::VectorXd::Zero(nv)),
        vdot(Eigen::VectorXd::Zero(nv)),
        tau_J(Eigen::VectorXd::Zero(nj)),
        contacts(static_cast<std::size_t>(max_links)),
        tracking_error(Eigen::VectorXd::Zero(nv)) {}
};

}  // namespace dynfilter
