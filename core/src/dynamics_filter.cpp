#include "dynfilter/core/dynamics_filter.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/kinematic_tree.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/reference_leash.hpp"
#include "dynfilter/core/tick_clock.hpp"

namespace dynfilter {
namespace {

// The joints' block of A at the neutral configuration must be regular: a combination of
// joints that moves no inertia (a point-mass head on neck axes that meet at it) has
// accelerations no torque decides, and both solves then drift without bound (a neck turned
// by thousands of radians, contact forces of 1e10 N). Throws, naming the joints.
constexpr double kSingularInertiaRatio = 1e-9;  // smallest over largest eigenvalue of A_JJ

void requireRegularJointInertia(IDynamicsModel& model) {
  const ModelInfo& info = model.info();
  const int nj = info.nj;
  if (nj == 0) return;
  const Eigen::VectorXd q_saved = model.q(), v_saved = model.v();
  model.setState(info.neutralConfiguration(), Eigen::VectorXd::Zero(info.nv));
  Eigen::MatrixXd A(info.nv, info.nv);
  model.massMatrix(A);
  model.setState(q_saved, v_saved);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(A.bottomRightCorner(nj, nj));
  const double largest = eig.eigenvalues()[nj - 1];
  if (eig.eigenvalues()[0] > kSingularInertiaRatio * largest) return;
  const Eigen::VectorXd mode = eig.eigenvectors().col(0);
  std::string joints;
  for (int j = 0; j < nj; ++j)
    if (std::abs(mode[j]) >= 0.1) joints += (joints.empty() ? "\"" : ", \"") + info.joint_names[static_cast<std::size_t>(j)] + "\"";
  throw std::invalid_argument("model \"" + info.name + "\": joint(s) " + joints +
                              " together move no inertia at the neutral configuration (the mass matrix is "
                              "singular): no torque decides their accelerations and the filter would drift "
                              "without bound; lock one of them (--lock-joints) or give the links they move a "
                              "rotational inertia");
}

// Capacity of the collision candidate list: several points per touching shape.
constexpr std::size_t kMaxCandidates = 64;

}  // namespace

DynamicsFilter::DynamicsFilter(IDynamicsModel& model, const FilterOptions& options,
                               const QpSolverFactory& qp_solver)
    : model_(model),
      options_((options.validate(), options)),
      nv_(model.nv()),
      nb_(model.info().floating_base ? kFloatingBaseNv : 0),
      nj_(model.nj()),
      links_(options.contacts, model.nv()),
      candidates_(kMaxCandidates),
      solver_(model.nv(), model.info().floating_base ? kFloatingBaseNv : 0,
              6 * options.contacts.max_links, options.solver),
      constrained_(model.nv(), model.info().floating_base ? kFloatingBaseNv : 0,
                   6 * options.contacts.max_links),
      out_(model.nq(), model.nv(), model.nj(), options.contacts.max_links) {
  const ModelInfo& info = model.info();
  requireRegularJointInertia(model_);
  if (options_.task.enabled) {
    task_body_ = options_.task.body.empty() ? chooseTrunkBody(model_)
                                            : info.findBody(options_.task.body);
    if (task_body_ < 0)
      throw std::invalid_argument("filter option task.body: \"" + options_.task.body +
                                  "\" is not a link of model \"" + info.name + "\"");
  }
  if (options_.mode == FilterMode::kQp) {
    if (options_.task.enabled && options_.task.as_constraint_rows)
      throw std::invalid_argument(
          "filter option task.as_constraint_rows: the QP mode keeps only the rows of Eq. 12 as "
          "equalities; use the task feedback of Eq. 19-20 (as_constraint_rows: false)");
    contact_qp_ = std::make_unique<ContactQp>(info, options_.contacts.max_links, options_.dt_s,
                                              options_.qp, qp_solver);
    if (options_.balance.enabled && info.floating_base) {
      balance_ = std::make_unique<BalanceLayer>(model, options_.balance);
      balance_tasks_ = QpObjectiveTasks(balance_->maxTaskRows(), nv_ + 6 * options_.contacts.max_links);
      contact_qp_->setObjectiveTasks(&balance_tasks_);
      links_.enableSliding(options_.qp.tangential_slip);
    }
  }
  const int max_rows = 6 * options_.contacts.max_links;
  weight_n_ = std::max(info.total_mass, 1e-9) * kStandardGravity;
  q_ = info.neutralConfiguration();
  v_.setZero(nv_);
  last_reference_ = ReferenceFrame(info.nq, nv_);
  preview_frame_ = ReferenceFrame(info.nq, nv_);
  A_.setZero(nv_, nv_);
  H_C_.setZero(max_rows, nv_);
  H_impact_.setZero(max_rows, nv_);
  v_impact_.setZero(nv_);
  b_.setZero(nv_);
  u_C_.setZero(max_rows);
  tau_C_.setZero(max_rows);
  vdot_desired_.setZero(nv_);
  vdot_solved_.setZero(nv_);
  tau_J_solved_.setZero(nj_);
  dq_.setZero(nv_);
  scratch_.setZero(nv_);
  J_P_.setZero(6, nv_);
  JW_.setZero(6, nv_);
  kp_.setConstant(nv_, options_.feedback.joint_kp);
  kd_.setConstant(nv_, options_.feedback.joint_kd);
  task_weight_inv_.setConstant(nv_, 1.0 / options_.task.joint_weight);
  if (nb_ > 0) {
    kp_.head<3>().setConstant(options_.feedback.base_linear_kp);
    kd_.head<3>().setConstant(options_.feedback.base_linear_kd);
    kp_.segment<3>(3).setConstant(options_.feedback.base_angular_kp);
    kd_.segment<3>(3).setConstant(options_.feedback.base_angular_kd);
    task_weight_inv_.head<6>().setOnes();
  }
}

bool DynamicsFilter::referenceValid(const ReferenceFrame& reference) const {
  return std::isfinite(reference.time_s) && model_.info().checkState(reference.q, reference.v).ok &&
         reference.vdot.size() == nv_ && reference.vdot.allFinite();
}

void DynamicsFilter::reset(const ReferenceFrame& reference) {
  model_.info().requireValidState(reference.q, reference.v);
  if (reference.vdot.size() != nv_ || !reference.vdot.allFinite())
    throw InvalidStateError("reference acceleration must have nv = " + std::to_string(nv_) +
                            " finite entries");
  // The leash starts over; preview frames already moved by it are moved back.
  if (balance_ && !X_leash_.isApprox(Eigen::Isometry3d::Identity(), 0.0))
    balance_->transformPreview(X_leash_.inverse());
  X_leash_.setIdentity();
  out_.X_reference_offset.setIdentity();
  last_reference_.time_s = reference.time_s;
  last_reference_.q = reference.q;
  last_reference_.q.segment(3, nb_ > 0 ? 4 : 0).normalize();
  last_reference_.v = reference.v;
  last_reference_.vdot = reference.vdot;
  has_reference_ = true;
  reseed(last_reference_);
}

void DynamicsFilter::reseed(const ReferenceFrame& reference) {
  q_ = reference.q;
  v_ = reference.v;
  links_.clear();
  if (contact_qp_ && options_.qp.enforce_joint_limits) {
    // The QP mode keeps joints in their limits; it starts inside them.
    const ModelInfo& info = model_.info();
    for (int j = 0; j < nj_; ++j) {
      double& qj = q_[info.configurationIndex(j)];
      qj = std::clamp(qj, info.q_lower[j], info.q_upper[j]);
      double& vj = v_[info.velocityIndex(j)];
      vj = std::clamp(vj, -info.v_max[j], info.v_max[j]);
    }
  }
  if (nb_ == 0) return;
  // Lift the base out of the environment when the reference sinks into it deeper than
  // the tolerance: the filter must not start inside the floor. Shallower contact is left
  // to the constraint stabilisation.
  for (int iteration = 0; iteration < 10; ++iteration) {
    model_.setState(q_, v_);
    model_.detectContacts(candidates_);
    double lift = 0.0, depth = 0.0;
    for (const ContactCandidate& c : candidates_) {
      depth = std::max(depth, c.depth_m);
      lift = std::max(lift, c.depth_m / std::max(c.n_W.z(), 0.1));
    }
    if (depth <= options_.contacts.initial_penetration_tolerance_m) break;
    q_[2] += lift;
  }
}

bool DynamicsFilter::previewFrame(const ReferenceFrame& frame) {
  if (!balance_) return false;
  if (!options_.leash.enabled) return balance_->pushPreview(model_, frame);
  if (frame.q.size() != preview_frame_.q.size() || frame.v.size() != nv_) return false;
  preview_frame_.time_s = frame.time_s;
  preview_frame_.q = frame.q;
  preview_frame_.v = frame.v;
  moveBase(X_leash_, preview_frame_.q);
  return balance_->pushPreview(model_, preview_frame_);
}

void DynamicsFilter::followWithLeash() {
  const Environment& environment = model_.environment();
  const Eigen::Vector3d n_W = environment.has_ground ? environment.ground.n_W : Eigen::Vector3d::UnitZ();
  const Eigen::Isometry3d X = leashMotion(options_.leash, n_W, q_, last_reference_.q);
  if (X.isApprox(Eigen::Isometry3d::Identity(), 0.0)) return;
  X_leash_ = X * X_leash_;
  moveBase(X, last_reference_.q);
  if (balance_) balance_->transformPreview(X);
  ++out_.counters.leash_ticks;
}

bool DynamicsFilter::setMeasuredState(const Eigen::Ref<const Eigen::VectorXd>& q,
                                      const Eigen::Ref<const Eigen::VectorXd>& v) {
  if (!model_.info().checkState(q, v).ok) return false;
  q_ = q;
  v_ = v;
  if (nb_ > 0) q_.segment<4>(3).normalize();
  measured_ = true;
  return true;
}

void DynamicsFilter::desiredAcceleration(const ReferenceFrame& reference) {
  // Eq. 17 with qʳᵉᶠ ⊖ q on SE(3) × Rⁿ.
  differenceConfiguration(nb_ > 0, q_, reference.q, dq_);
  vdot_desired_ = reference.vdot;
  vdot_desired_.array() +=
      kd_.array() * (reference.v - v_).array() + kp_.array() * dq_.array();
  if (task_body_ < 0) return;

  // Eq. 18–20: pose feedback of P, mapped by a weighted pseudo-inverse of J_P.
  const TaskPointOptions& task = options_.task;
  const Eigen::Isometry3d X_WB = model_.bodyPose(task_body_);
  model_.pointJacobian(task_body_, task.p_BP, J_P_);
  const Vector6d drift = model_.pointJacobianDotTimesV(task_body_, task.p_BP);
  const Vector6d rdot = J_P_ * v_;
  Vector6d& error = out_.task_error;
  error.head<3>() = task_p_ref_ - X_WB * task.p_BP;
  error.tail<3>() = logSO3(task_R_ref_ * X_WB.linear().transpose());
  Vector6d rddot_desired = task_rddot_ref_;
  rddot_desired.head<3>() += task.kd_linear * (task_rdot_ref_.head<3>() - rdot.head<3>()) +
                             task.kp_linear * error.head<3>();
  rddot_desired.tail<3>() += task.kd_angular * (task_rdot_ref_.tail<3>() - rdot.tail<3>()) +
                             task.kp_angular * error.tail<3>();
  if (task.as_constraint_rows) {  // Eq. 16: J_P v̇ = r̈_Pᵈ − J̇_P v as rows of the solve
    task_rhs_ = rddot_desired - drift;
    return;
  }
  const Vector6d rddot_d0 = J_P_ * vdot_desired_ + drift;
  JW_ = J_P_ * task_weight_inv_.asDiagonal();
  // Singularity-robust (damped) weighted pseudo-inverse: J_P may lose rank (a fixed base,
  // a stretched chain); the damping is the solver's SR factor relative to J W⁻¹ Jᵀ's size.
  Matrix6d S = JW_ * J_P_.transpose();
  S.diagonal().array() += options_.solver.sr_damping * S.trace() / 6.0;
  const Eigen::LLT<Matrix6d> llt(S);
  const Vector6d s = llt.solve(rddot_desired - rddot_d0);
  vdot_desired_.noalias() += JW_.transpose() * s;
}

const FilterOutput& DynamicsFilter::step(const ReferenceFrame& reference) {
  const detail::TickClock::time_point t0 = detail::TickClock::now();
  ++out_.counters.ticks;
  std::uint32_t status = kStatusOk;
  if (referenceValid(reference)) {
    last_reference_.time_s = reference.time_s;
    last_reference_.q = reference.q;
    if (nb_ > 0) last_reference_.q.segment<4>(3).normalize();
    last_reference_.v = reference.v;
    last_reference_.vdot = reference.vdot;
    if (contact_qp_ && options_.qp.enforce_joint_limits) {
      // The QP mode keeps the joints in their limits: a reference beyond them is tracked
      // at the limit (the feedback would otherwise push against the stop for ever).
      const ModelInfo& info = model_.info();
      for (int j = 0; j < nj_; ++j) {
        double& qj = last_reference_.q[info.configurationIndex(j)];
        qj = std::clamp(qj, info.q_lower[j], info.q_upper[j]);
      }
    }
    if (nb_ > 0 && options_.leash.enabled) {
      moveBase(X_leash_, last_reference_.q);
      if (has_reference_) followWithLeash();
    }
    if (!has_reference_) {
      has_reference_ = true;
      reseed(last_reference_);
    }
  } else {
    status |= kStatusReferenceInvalid;
    ++out_.counters.invalid_references;
    if (!has_reference_) {  // nothing to hold on to yet
      out_.status = status;
      return out_;
    }
  }
  const ReferenceFrame& ref = last_reference_;

  // Reference kinematics: the task point P, and (QP mode) contact points the reference lifts.
  if (task_body_ >= 0 || contact_qp_) model_.setState(ref.q, ref.v);
  out_.infeasible_reason = 0;
  if (contact_qp_ && !balance_) links_.startLiftoffReleases(model_, options_.qp.liftoff_clearance_m);
  if (balance_) {
    balance_->prepare(model_, ref, options_.dt_s);
    links_.applyReferenceSchedule(balance_->heldStance());
    const InfeasibleReason infeasible = balance_->state().infeasible;
    if (infeasible != InfeasibleReason::kNone) {
      status |= kStatusReferenceInfeasible;
      out_.infeasible_reason = static_cast<int>(infeasible);
    }
  }
  if (task_body_ >= 0) {
    const Eigen::Isometry3d X_WB = model_.bodyPose(task_body_);
    task_p_ref_ = X_WB * options_.task.p_BP;
    task_R_ref_ = X_WB.linear();
    model_.pointJacobian(task_body_, options_.task.p_BP, J_P_);
    task_rdot_ref_ = J_P_ * ref.v;
    task_rddot_ref_ = J_P_ * ref.vdot + model_.pointJacobianDotTimesV(task_body_, options_.task.p_BP);
  }

  // Contacts at the filter's state, and the plastic impact of new links.
  model_.setState(q_, v_);
  if (measured_) links_.reanchor(model_);  // the robot's contact is where it is
  measured_ = false;
  model_.detectContacts(candidates_);
  out_.max_penetration_m = 0.0;
  for (const ContactCandidate& c : candidates_)
    out_.max_penetration_m = std::max(out_.max_penetration_m, c.depth_m);
  if (balance_) balance_->addSoleCandidates(model_, q_, v_, links_, candidates_);
  int created = links_.update(model_, candidates_, status);
  if (balance_) created += balance_->flattenLandings(model_, links_);
  if (balance_) created += balance_->rollSoles(links_);
  const int nc = links_.numRows();
  auto H_C = H_C_.topRows(nc);
  auto u_C = u_C_.head(nc);
  auto tau_C = tau_C_.head(nc);
  model_.massMatrix(A_);
  if (created > 0 && nc > 0 && options_.contacts.plastic_impact) {
    links_.assemble(model_, H_C, u_C);
    if (links_.anySliding()) stickWithinFriction(H_C, tau_C);
    const int stopped = links_.impactRows(H_C, H_impact_);
    if (stopped > 0 && constrained_.plasticImpact(A_, H_impact_.topRows(stopped), v_, tau_C.head(stopped))) {
      model_.setState(q_, v_);
      status |= kStatusImpact;
      ++out_.counters.impacts;
    }
  }
  model_.bias(b_);
  links_.assemble(model_, H_C, u_C);
  desiredAcceleration(ref);
  if (balance_) {
    balance_->buildTasks(model_, A_, q_, v_, links_, balance_tasks_);
    out_.com_W = balance_->state().filter.c_W;
    out_.com_reference_W = balance_->state().reference.c_W;
  }

  const detail::TickClock::time_point t_solve = detail::TickClock::now();
  status |= contact_qp_ ? solveQp(H_C, u_C, tau_C) : solvePaper(H_C, u_C, tau_C);
  out_.solve_time_s = detail::secondsSince(t_solve);

  // The rows that hold: the QP mode may have released every link (contacts that could not
  // be held), leaving none.
  const int nc_held = links_.numRows();
  const auto H_held = H_C_.topRows(nc_held);
  const auto u_held = u_C_.head(nc_held);
  const auto tau_held = tau_C_.head(nc_held);
  const bool finite = vdot_solved_.allFinite() && tau_J_solved_.allFinite() && tau_held.allFinite();
  const Eq12Residual residual =
      finite ? eq12Residual(A_, b_, H_held, u_held, nb_, vdot_solved_, tau_held, tau_J_solved_, scratch_)
             : Eq12Residual{};
  const bool consistent = residual.base_max_abs <= options_.divergence.max_base_residual_rel * weight_n_;
  if (!finite || !consistent) {
    // Not published: the last good output stays; the state starts over from the reference.
    status |= kStatusReseeded | (finite ? kStatusOk : kStatusNonFinite);
    out_.reseed_reason = finite ? ReseedReason::kResidual : ReseedReason::kNonFinite;
    ++out_.counters.reseeds;
    degraded_ticks_ = 0;
    reseed(ref);
    out_.status = status;
    out_.tick_time_s = detail::secondsSince(t0);
    return out_;
  }
  out_.eq12_residual = residual.max_abs;
  out_.base_residual_n = residual.base_max_abs;
  const int links_before = links_.size();
  if (contact_qp_) {
    const double f_min = options_.qp.min_normal_force_n;
    out_.num_contacts = links_.finishTick(model_, tau_held, out_.contacts, true,
                                          f_min + std::max(1e-3, 1e-3 * f_min), options_.dt_s,
                                          options_.qp.release_transition_s);
  } else {
    out_.num_contacts = links_.finishTick(model_, tau_held, out_.contacts, true,
                                          options_.contacts.release_force_n, options_.dt_s, 0.0);
  }
  out_.counters.links_released += static_cast<std::uint64_t>(links_before - links_.size());
  bool pivots = false, slides = false;
  for (int i = 0; i < out_.num_contacts; ++i) {
    const ContactOutput& c = out_.contacts[static_cast<std::size_t>(i)];
    pivots = pivots || c.pivot != 0;
    slides = slides || !c.slide_W.isZero();
  }
  out_.counters.pivot_ticks += pivots ? 1 : 0;
  out_.counters.slide_ticks += slides ? 1 : 0;
  out_.time_s = ref.time_s;
  out_.X_reference_offset = X_leash_;
  out_.q = q_;
  out_.v = v_;
  out_.vdot = vdot_solved_;
  out_.tau_J = tau_J_solved_;
  out_.tracking_error = dq_;

  // Semi-implicit Euler on the manifold.
  v_.noalias() += options_.dt_s * vdot_solved_;
  integrateConfiguration(nb_ > 0, q_, v_, options_.dt_s, q_);

  // Divergence: errors before the tick, and a solve that stays degraded.
  degraded_ticks_ = (status & (kStatusRankDeficient | kStatusQpFallback)) != 0 ? degraded_ticks_ + 1 : 0;
  const DivergenceOptions& guard = options_.divergence;
  ReseedReason reason = ReseedReason::kNone;
  if (nb_ > 0 && dq_.head<3>().norm() > guard.max_base_error_m)
    reason = ReseedReason::kBasePosition;
  else if (nb_ > 0 && dq_.segment<3>(3).norm() > guard.max_base_rotation_rad)
    reason = ReseedReason::kBaseRotation;
  else if (nj_ > 0 && dq_.tail(nj_).cwiseAbs().maxCoeff() > guard.max_joint_error_rad)
    reason = ReseedReason::kJoint;
  else if (degraded_ticks_ >= guard.max_degraded_ticks)
    reason = ReseedReason::kDegradedSolve;
  // A reference that cannot be followed physically is reported (kStatusReferenceInfeasible),
  // not chased by teleports: tracking errors do not re-seed while it lasts.
  if ((status & kStatusReferenceInfeasible) && reason != ReseedReason::kDegradedSolve)
    reason = ReseedReason::kNone;
  out_.reseed_reason = reason;
  if (reason != ReseedReason::kNone) {
    status |= kStatusReseeded;
    ++out_.counters.reseeds;
    degraded_ticks_ = 0;
    reseed(ref);
  }
  out_.status = status;
  out_.tick_time_s = detail::secondsSince(t0);
  return out_;
}

void DynamicsFilter::stickWithinFriction(const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                                         Eigen::Ref<Eigen::VectorXd> impulse) {
  // Coulomb at the impulse level: a sliding link whose impulse, were it stopped with the
  // others, would lie within its friction cone sticks; the others slide through the impact.
  v_impact_ = v_;
  if (!constrained_.plasticImpact(A_, H_C, v_impact_, impulse)) return;
  const Environment& environment = model_.environment();
  int row = 0;
  for (int i = 0; i < links_.size(); ++i) {
    const VirtualLink& link = links_[i];
    const double mu = environment.friction(link.object);
    if (!link.slide_A.isZero() && std::hypot(impulse[row], impulse[row + 1]) <= mu * impulse[row + 2])
      links_.stopSlide(i);
    row += link.num_axes;
  }
}

std::uint32_t DynamicsFilter::solvePaper(Eigen::Ref<Eigen::MatrixXd> H_C,
                                         Eigen::Ref<Eigen::VectorXd> u_C,
                                         Eigen::Ref<Eigen::VectorXd> tau_C) {
  // Eq. 21–23.
  const bool task_rows = task_body_ >= 0 && options_.task.as_constraint_rows;
  std::uint32_t solve_status = kStatusRankDeficient;
  if (task_rows)
    solve_status = solver_.solve(A_, b_, H_C, u_C, J_P_, task_rhs_, vdot_desired_, vdot_solved_,
                                 tau_C, tau_J_solved_);
  // Task rows that depend on the physics rows (e.g. the chest cannot rise while the knees
  // are straight) are dropped for the tick: Eq. 12 itself must hold exactly.
  if (solve_status & kStatusRankDeficient) {
    solve_status = task_rows ? std::uint32_t{kStatusRankDeficient} : std::uint32_t{kStatusOk};
    solve_status |= solver_.solve(A_, b_, H_C, u_C, vdot_desired_, vdot_solved_, tau_C, tau_J_solved_);
  }
  return solve_status;
}

std::uint32_t DynamicsFilter::solveQp(Eigen::Ref<Eigen::MatrixXd> H_C,
                                      Eigen::Ref<Eigen::VectorXd> u_C,
                                      Eigen::Ref<Eigen::VectorXd> tau_C) {
  const ContactQpReport report =
      contact_qp_->solve(A_, b_, H_C, u_C, links_, model_.environment(), q_, v_, vdot_desired_,
                         vdot_solved_, tau_C, tau_J_solved_);
  out_.qp_status = static_cast<int>(report.info.status);
  out_.qp_iterations = report.info.iterations;
  out_.qp_solver_time_s = report.solver_time_s;
  out_.qp_relaxation = (report.joint_limits_dropped ? 1u : 0u) | (report.ramps_dropped ? 2u : 0u) |
                       (report.contacts_released ? 4u : 0u) |
                       (report.floor_rung > 0 ? 4u << report.floor_rung : 0u);
  out_.qp_violated = out_.qp_relaxation != 0 ? report.violated_first : report.violated;
  out_.counters.qp_iterations += static_cast<std::uint64_t>(std::max(0, report.info.iterations));
  for (int i = 0; i < links_.size(); ++i) links_.setYawSlip(i, report.ok ? contact_qp_->yawSlip(i) : 0);
  // A row that held no equality in the answer (a pivot's yaw, a slide's tangents, a row the
  // floor rungs freed) states the motion it took; Eq. 9 holds on the others. Without an
  // answer (the fallback below) every row holds, and the failed solve's iterate is not used.
  if (report.ok)
    for (int r = 0; r < links_.numRows(); ++r)
      if (contact_qp_->rowFree(r)) u_C[r] = H_C.row(r).dot(vdot_solved_);
  const std::uint32_t capped =
      report.info.status == QpSolveStatus::kMaxIterations ? kStatusQpIterationLimit : kStatusOk;
  if (report.ok) {
    ++out_.counters.qp_solves;
    if (out_.qp_relaxation == 0) return capped;
    ++out_.counters.qp_relaxed;
    if (report.contacts_released) links_.releaseAll();
    return kStatusQpRelaxed | capped;
  }
  out_.qp_violated |= report.violated;
  // Fallback: the paper's solve, torques clamped to their limits, then Eq. 14 with the
  // clamped torques so that Eq. 12 still holds for what is published.
  ++out_.counters.qp_fallbacks;
  std::uint32_t status = kStatusQpFallback | capped;
  status |= solvePaper(H_C, u_C, tau_C);
  const Eigen::VectorXd& tau_max = model_.info().tau_max;
  bool clamped = false;
  for (int j = 0; j < nj_; ++j) {
    const double limited = std::clamp(tau_J_solved_[j], -tau_max[j], tau_max[j]);
    clamped = clamped || limited != tau_J_solved_[j];
    tau_J_solved_[j] = limited;
  }
  if (clamped) {
    status |= kStatusTorqueClamped;
    if (!constrained_.forward(A_, b_, H_C, u_C, tau_J_solved_, vdot_solved_, tau_C))
      status |= kStatusRankDeficient;
  }
  return status;
}

bool stepOnMeasuredState(DynamicsFilter& filter, const ModelInfo& info, bool& started,
                         const Eigen::Ref<const Eigen::VectorXd>& q_measured,
                         const Eigen::Ref<const Eigen::VectorXd>& v_measured,
                         const ReferenceFrame& reference, Eigen::Ref<Eigen::VectorXd> tau_J) {
  tau_J.setZero();
  if (!started) {
    try {
      filter.reset(reference);  // contacts and feedback start on the reference ...
      started = true;
    } catch (const std::exception&) {
      return false;  // an invalid first reference: nothing to start on
    }
  }
  if (!filter.setMeasuredState(q_measured, v_measured)) return false;  // ... the state is the world's
  const FilterOutput& out = filter.step(reference);
  if (out.tau_J.allFinite()) tau_J = out.tau_J.cwiseMax(-info.tau_max).cwiseMin(info.tau_max);
  return true;
}

}  // namespace dynfilter
