#pragma once
/// @file
/// The dynamics filter (Yamane & Nakamura 2000), paper mode: one step per control tick.
///
/// Per tick, from the filter's own state (q, v):
///  1. collision → virtual links (virtual_links.hpp), plastic impact when a link appears;
///  2. joint-space feedback, Eq. 17, with the SE(3) difference for the base;
///  3. task feedback of the point P, Eq. 18–20, with a weighted, singularity-robust
///     pseudo-inverse (or, with
///     TaskPointOptions::as_constraint_rows, as the task rows of Eq. 16);
///  4. Eq. 12 (or 16) solved by Eq. 21–23 (paper_solver.hpp), or in the QP mode by the
///     contact-consistent QP (contact_qp.hpp) with the paper solve as its fallback;
///  5. semi-implicit Euler on the manifold: v ← v + v̇ dt, q ← q ⊕ v dt.
/// The output pairs the state at which Eq. 12 was solved with v̇, τ_J and τ_C, so that any
/// backend can re-evaluate Eq. 12 on it. step() does not allocate on the heap.

#include <chrono>
#include <cstdint>
#include <memory>

#include <Eigen/Core>

#include "dynfilter/core/balance.hpp"
#include "dynfilter/core/constrained_dynamics.hpp"
#include "dynfilter/core/contact_qp.hpp"
#include "dynfilter/core/contact.hpp"
#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/core/filter_output.hpp"
#include "dynfilter/core/paper_solver.hpp"
#include "dynfilter/core/reference_frame.hpp"
#include "dynfilter/core/virtual_links.hpp"

namespace dynfilter {

class DynamicsFilter {
 public:
  /// The filter uses @p model for every query and changes its state; it must outlive the
  /// filter. FilterMode::kQp needs @p qp_solver (e.g. dynfilter::proxqp::factory()).
  /// Throws std::invalid_argument on invalid options, an unknown task body, or the QP mode
  /// without a solver factory.
  DynamicsFilter(IDynamicsModel& model, const FilterOptions& options,
                 const QpSolverFactory& qp_solver = {});

  /// Starts from the reference frame's state. When the model then penetrates the
  /// environment, the base is raised along world z until it no longer does (a floating
  /// base only). Throws InvalidStateError on an invalid frame.
  void reset(const ReferenceFrame& reference);

  /// Replaces the filter's state by a measured one (closing the loop on a robot): the next
  /// tick starts from it. The virtual links are kept. Returns false, changing nothing, on
  /// an invalid state (sizes, non-finite, quaternion); no allocation.
  bool setMeasuredState(const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& v);

  /// One control tick towards @p reference. Never throws; an invalid reference is
  /// replaced by the last valid one and flagged in the status.
  const FilterOutput& step(const ReferenceFrame& reference);

  /// Look-ahead (QP mode with the balance layer): hands the filter a reference frame of
  /// the future, ahead of the ticks and in time order (offline: the clip's frames up to
  /// balance.preview_s ahead; on-line: every frame as it arrives). Poses the model; call
  /// between ticks. Returns false when there is no balance layer or the frame is invalid.
  /// No allocation.
  bool previewFrame(const ReferenceFrame& frame);

  /// The balance layer's quantities of the last tick (nullptr without the layer).
  const BalanceState* balance() const { return balance_ ? &balance_->state() : nullptr; }

  const FilterOutput& output() const { return out_; }
  const Eigen::VectorXd& q() const { return q_; }
  const Eigen::VectorXd& v() const { return v_; }
  const FilterOptions& options() const { return options_; }
  /// Body that carries the task point P (the configured task.body, or the one chosen from
  /// the model when task.body is empty); −1 when the task is disabled.
  int taskBody() const { return task_body_; }
  const VirtualLinkSet& links() const { return links_; }

 private:
  bool referenceValid(const ReferenceFrame& reference) const;
  void desiredAcceleration(const ReferenceFrame& reference);
  void reseed(const ReferenceFrame& reference);
  // A new link's impact: sliding links whose stopping impulse lies within their friction
  // cone stick (VirtualLinkSet::stopSlide); @p impulse is scratch (N_C).
  void stickWithinFriction(const Eigen::Ref<const Eigen::MatrixXd>& H_C, Eigen::Ref<Eigen::VectorXd> impulse);
  // Eq. 21–23 (with the task rows of Eq. 16 when configured); returns status bits.
  std::uint32_t solvePaper(Eigen::Ref<Eigen::MatrixXd> H_C, Eigen::Ref<Eigen::VectorXd> u_C,
                           Eigen::Ref<Eigen::VectorXd> tau_C);
  // QP mode: solve, or fall back to the paper solve with clamped torques.
  std::uint32_t solveQp(Eigen::Ref<Eigen::MatrixXd> H_C, Eigen::Ref<Eigen::VectorXd> u_C,
                        Eigen::Ref<Eigen::VectorXd> tau_C);

  IDynamicsModel& model_;
  FilterOptions options_;
  int nv_, nb_, nj_, task_body_ = -1;
  double weight_n_ = 0.0;      // body weight (N), scales the Eq. 12 divergence guard
  int degraded_ticks_ = 0;     // consecutive ticks with a degraded solve
  bool measured_ = false;      // the state of this tick was measured (setMeasuredState)
  Eigen::VectorXd q_, v_;
  ReferenceFrame last_reference_;
  bool has_reference_ = false;
  // The reference leash: the rigid motion applied to every reference frame (world).
  Eigen::Isometry3d X_leash_ = Eigen::Isometry3d::Identity();
  ReferenceFrame preview_frame_;  // a preview frame moved by X_leash_
  // Moves last_reference_ (already leashed) so that it is within the leash of the state.
  void followWithLeash();

  VirtualLinkSet links_;
  ContactList candidates_;
  PaperSolver solver_;
  std::unique_ptr<ContactQp> contact_qp_;  // QP mode only
  std::unique_ptr<BalanceLayer> balance_;  // QP mode with balance.enabled, floating base
  QpObjectiveTasks balance_tasks_;
  ConstrainedDynamics constrained_;
  FilterOutput out_;

  // Workspace (sized once).
  Eigen::MatrixXd A_, H_C_, H_impact_;  // H_impact_: the rows a plastic impact stops
  Eigen::VectorXd b_, u_C_, tau_C_, vdot_desired_, vdot_solved_, tau_J_solved_;
  Eigen::VectorXd kp_, kd_, dq_, scratch_, v_impact_;
  // Task point P at the reference state: position, orientation, velocity, acceleration.
  Eigen::Vector3d task_p_ref_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d task_R_ref_ = Eigen::Matrix3d::Identity();
  Vector6d task_rdot_ref_ = Vector6d::Zero();
  Vector6d task_rddot_ref_ = Vector6d::Zero();
  Vector6d task_rhs_ = Vector6d::Zero();  // Eq. 16 rows: r̈_Pᵈ − J̇_P v
  Matrix6Xd J_P_;
  Eigen::MatrixXd JW_;          // 6 × nv: J_P Wq⁻¹
  Eigen::VectorXd task_weight_inv_;  // nv
};

/// One tick of a filter attached to a running simulation (the backends' AttachedFilter):
/// on the first call with a valid measured state the filter starts on @p reference
/// (contacts and feedback), and @p started is set; every tick then runs from the measured
/// state (q_measured: nq, v_measured: nv). Writes the filter's τ_J clamped to the model's
/// torque limits into @p tau_J (nj), zero when the filter did not run (an invalid first
/// reference or state) or its torques are not finite. Returns whether the filter ran; the
/// model is then at the filter's integrated state. No allocation.
bool stepOnMeasuredState(DynamicsFilter& filter, const ModelInfo& info, bool& started,
                         const Eigen::Ref<const Eigen::VectorXd>& q_measured,
                         const Eigen::Ref<const Eigen::VectorXd>& v_measured,
                         const ReferenceFrame& reference, Eigen::Ref<Eigen::VectorXd> tau_J);

}  // namespace dynfilter
