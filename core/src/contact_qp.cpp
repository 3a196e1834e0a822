#include "dynfilter/core/contact_qp.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#include "dynfilter/core/constrained_dynamics.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/tick_clock.hpp"

namespace dynfilter {
namespace {

constexpr double kForceTolerance = 1e-6;  // N and N m: checks of the inequality families
constexpr double kAccelTolerance = 1e-6;  // m/s², rad/s²
constexpr double kPi = 3.14159265358979323846;
// A held link starts to pivot when its last twist was this close to friction's bound.
constexpr double kPivotOnset = 0.95;
// The pivot attempt is a guess that the relaxations follow when it fails (6 of 7 times on
// the CMU clips): it gets this share of the engine's cap. Pivots that held there needed at
// most half of DAQP's (72 working-set changes); failures ran to the whole cap.
constexpr double kPivotAttemptShare = 2.0 / 3.0;

double finiteOr(double x, double fallback) { return std::isfinite(x) ? x : fallback; }

}  // namespace

struct ContactQp::SizeClass {
  int capacity = 0;       // τ_C slots
  int link_capacity = 0;  // links whose rows fit
  DenseQp qp;
  std::unique_ptr<IQpSolver> solver;
  Eigen::VectorXd x;
  std::uint64_t signature = 0;  // which links, of which kinds, the last solve had
};

QpSolveInfo ContactQp::timedSolve(SizeClass& sc, ContactQpReport& report, bool bounds_only) {
  const detail::TickClock::time_point t0 = detail::TickClock::now();
  const QpSolveInfo info =
      bounds_only ? sc.solver->resolveWithNewBounds(sc.qp, sc.x) : sc.solver->solve(sc.qp, sc.x);
  report.solver_time_s += detail::secondsSince(t0);
  return info;
}

const char* describeQpFamilies(std::uint32_t families, char* buffer, int size) {
  static constexpr struct {
    std::uint32_t bit;
    const char* name;
  } kNames[] = {{kQpFamilyEquality, "equality"},   {kQpFamilyUnilateral, "unilateral"},
                {kQpFamilyFriction, "friction"},   {kQpFamilyCop, "cop"},
                {kQpFamilyTorque, "torque"},       {kQpFamilyJointLimit, "joint_limit"}};
  if (size <= 0) return buffer;
  buffer[0] = '\0';
  int used = 0;
  for (const auto& entry : kNames) {
    if (!(families & entry.bit)) continue;
    const int written = std::snprintf(buffer + used, static_cast<std::size_t>(size - used), "%s%s",
                                      used > 0 ? "," : "", entry.name);
    if (written < 0 || used + written >= size) break;
    used += written;
  }
  return buffer;
}

ContactQp::ContactQp(const ModelInfo& info, int max_links, double dt_s,
                     const QpModeOptions& options, const QpSolverFactory& factory)
    : options_(options),
      dt_s_(dt_s),
      nv_(info.nv),
      nb_(info.floating_base ? kFloatingBaseNv : 0),
      nj_(info.nj),
      max_links_(max_links),
      q_lower_(info.q_lower),
      q_upper_(info.q_upper),
      v_max_(info.v_max),
      tau_max_(info.tau_max) {
  if (!factory)
    throw std::invalid_argument(
        "filter mode qp needs a QP solver: pass a QpSolverFactory (e.g. dynfilter::proxqp::factory())");
  const int K = options.friction_facets;
  facet_cos_.resize(K);
  facet_sin_.resize(K);
  for (int k = 0; k < K; ++k) {
    const double theta = 2.0 * kPi * k / K;
    facet_cos_[k] = std::cos(theta);
    facet_sin_[k] = std::sin(theta);
  }
  // Size classes: two flat feet (12 rows) need no padding; then 24; then the capacity.
  const int max_rows = 6 * max_links;
  for (int capacity : {12, 24, max_rows}) {
    capacity = std::min(capacity, max_rows);
    if (!classes_.empty() && classes_.back()->capacity >= capacity) continue;
    auto c = std::make_unique<SizeClass>();
    c->capacity = capacity;
    c->link_capacity = std::min(max_links, capacity / 3);
    const int n = nv_ + capacity;
    const int n_in = nj_ + c->link_capacity * (K + 6);  // facets, CoP (4), torsion (2)
    c->qp = DenseQp(n, nb_ + capacity, n_in);
    c->solver = factory(n, nb_ + capacity, n_in, options.solver);
    if (!c->solver) throw std::invalid_argument("the QP solver factory returned no solver");
    c->x.setZero(n);
    classes_.push_back(std::move(c));
  }
  accel_lo_.setConstant(nj_, -kQpInfinity);
  accel_hi_.setConstant(nj_, kQpInfinity);
  M_.setZero(nj_, nv_ + max_rows);
  residual_.setZero(nv_ + max_rows);
  basis_.setZero(nv_, max_rows);
  row_free_.assign(static_cast<std::size_t>(max_rows), 0);
  link_bounds_.resize(static_cast<std::size_t>(max_links));
  weight_n_ = std::max(info.total_mass, 1e-9) * kStandardGravity;
  equality_tolerance_ = 1e-8 * std::max(weight_n_, kStandardGravity);
}

ContactQp::~ContactQp() = default;

void ContactQp::buildJointBounds(const Eigen::Ref<const Eigen::VectorXd>& q,
                                 const Eigen::Ref<const Eigen::VectorXd>& v) {
  const double h = options_.joint_limit_horizon_s;
  const int q0 = nb_ > 0 ? 7 : 0;
  for (int j = 0; j < nj_; ++j) {
    double lo = -kQpInfinity, hi = kQpInfinity;
    if (options_.enforce_joint_limits) {
      const double qj = q[q0 + j], vj = v[nb_ + j];
      // Demands are capped at the deceleration the joint is credited with, so that the
      // bounds never ask more than that of the torque limits (which are hard).
      const double cap = options_.joint_limit_max_decel;
      if (std::isfinite(v_max_[j])) {
        hi = std::min(hi, std::max((v_max_[j] - vj) / dt_s_, -cap));
        lo = std::max(lo, std::min((-v_max_[j] - vj) / dt_s_, cap));
      }
      // Stop at the limit within the horizon: q + v h + ½ a h² within [q_lower, q_upper].
      if (std::isfinite(q_upper_[j]))
        hi = std::min(hi, std::max(2.0 * (q_upper_[j] - qj - vj * h) / (h * h), -cap));
      if (std::isfinite(q_lower_[j]))
        lo = std::max(lo, std::min(2.0 * (q_lower_[j] - qj - vj * h) / (h * h), cap));
      if (lo > hi) lo = hi = 0.5 * (lo + hi);  // both sides cannot hold: meet half way
    }
    accel_lo_[j] = lo;
    accel_hi_[j] = hi;
  }
}

ContactQpReport ContactQp::solve(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                 const Eigen::Ref<const Eigen::VectorXd>& b,
                                 const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                                 const Eigen::Ref<const Eigen::VectorXd>& u_C,
                                 const VirtualLinkSet& links, const Environment& environment,
                                 const Eigen::Ref<const Eigen::VectorXd>& q,
                                 const Eigen::Ref<const Eigen::VectorXd>& v,
                                 const Eigen::Ref<const Eigen::VectorXd>& vdot_desired,
                                 Eigen::Ref<Eigen::VectorXd> vdot, Eigen::Ref<Eigen::VectorXd> tau_C,
                                 Eigen::Ref<Eigen::VectorXd> tau_J) {
  ContactQpReport report;
  const int nc = static_cast<int>(H_C.rows());
  const int num_links = std::min(links.size(), max_links_);
  SizeClass* size_class = classes_.back().get();
  for (const auto& c : classes_) {
    if (c->capacity >= nc && c->link_capacity >= num_links) {
      size_class = c.get();
      break;
    }
  }
  SizeClass& sc = *size_class;
  report.force_capacity = sc.capacity;
  DenseQp& qp = sc.qp;
  const int cap = sc.capacity, K = options_.friction_facets;
  const double wa = options_.accel_weight, wf = options_.force_weight, wt = options_.torque_weight;

  buildJointBounds(q, v);

  // τ_J = M x + b_J with M = [A_J, −H_C,Jᵀ].
  auto M = M_.leftCols(nv_ + nc);
  M.leftCols(nv_) = A.bottomRows(nj_);
  M.rightCols(nc) = -H_C.rightCols(nj_).transpose();
  const auto b_J = b.tail(nj_);

  // Objective.
  qp.H.setZero();
  if (wt > 0.0) qp.H.topLeftCorner(nv_ + nc, nv_ + nc).noalias() = wt * M.transpose() * M;
  qp.H.diagonal().head(nv_).array() += wa;
  qp.H.diagonal().tail(cap).array() += wf;
  qp.g.setZero();
  qp.g.head(nv_) = -wa * vdot_desired;
  if (wt > 0.0) qp.g.head(nv_ + nc).noalias() += wt * M.transpose() * b_J;
  addObjectiveTasks(qp, nc);

  // Equalities: base rows, contact rows, unused τ_C slots = 0.
  qp.A.setZero();
  qp.A.topLeftCorner(nb_, nv_) = A.topRows(nb_);
  qp.A.block(0, nv_, nb_, nc) = -H_C.leftCols(nb_).transpose();
  qp.A.block(nb_, 0, nc, nv_) = H_C;
  for (int k = nc; k < cap; ++k) qp.A(nb_ + k, nv_ + k) = 1.0;
  qp.b.setZero();
  qp.b.head(nb_) = -b.head(nb_);
  qp.b.segment(nb_, nc) = u_C;

  // Inequalities: torques, then per link friction and CoP; unused rows unbounded.
  qp.C.setZero();
  qp.l.setConstant(-kQpInfinity);
  qp.u.setConstant(kQpInfinity);
  qp.C.topLeftCorner(nj_, nv_ + nc) = M;
  if (options_.enforce_torque_limits) {
    for (int j = 0; j < nj_; ++j) {
      const double limit = finiteOr(tau_max_[j], kQpInfinity);
      qp.l[j] = -limit - b_J[j];
      qp.u[j] = limit - b_J[j];
    }
  }
  qp.x_lower.setConstant(-kQpInfinity);
  qp.x_upper.setConstant(kQpInfinity);
  qp.x_lower.segment(nb_, nj_) = accel_lo_;
  qp.x_upper.segment(nb_, nj_) = accel_hi_;

  int row = nj_;
  int slot = 0;
  num_links_ = num_links;
  std::fill(row_free_.begin(), row_free_.end(), 0);
  const double cone_scale = std::cos(kPi / K);
  for (int i = 0; i < num_links; ++i) {
    const VirtualLink& link = links[i];
    LinkBounds& lb = link_bounds_[static_cast<std::size_t>(i)];
    lb.row = slot;
    lb.num_axes = link.num_axes;
    lb.mu = environment.friction(link.object);
    lb.f_max = links.normalForceUpperBound(i, options_.min_normal_force_n,
                                           options_.release_transition_s);
    // No jerk: a held link unloads no faster than max(weight, its ramp's start force) per
    // release_transition_s — whether the reference lifts it (ramp) or the solver would
    // rather drop it at once. New links start free.
    lb.f_min = options_.min_normal_force_n;
    if (!link.created_this_tick && options_.release_transition_s > 0.0) {
      const double rate = std::max(weight_n_, link.release_start_force_n) / options_.release_transition_s;
      lb.f_min = std::max(lb.f_min, std::min(link.normal_force_n, lb.f_max) - rate * dt_s_);
    }
    lb.torsion_arm_m = std::hypot(std::max(std::abs(link.support_min.x()), std::abs(link.support_max.x())),
                                  std::max(std::abs(link.support_min.y()), std::abs(link.support_max.y())));
    const double margin = options_.cop_margin_m;
    lb.cop_min = link.support_min.array() + margin;
    lb.cop_max = link.support_max.array() - margin;
    for (int d = 0; d < 2; ++d) {
      if (lb.cop_min[d] > lb.cop_max[d]) lb.cop_min[d] = lb.cop_max[d] = 0.5 * (lb.cop_min[d] + lb.cop_max[d]);
    }
    const int fx = nv_ + slot, fy = fx + 1, fz = fx + 2;
    qp.x_lower[fz] = lb.f_min;
    qp.x_upper[fz] = finiteOr(lb.f_max, kQpInfinity);
    lb.facet_row = row;
    for (int k = 0; k < K; ++k, ++row) {
      qp.C(row, fx) = facet_cos_[k];
      qp.C(row, fy) = facet_sin_[k];
      qp.C(row, fz) = -lb.mu * cone_scale;
      qp.u[row] = 0.0;
    }
    // CoP along A's x: cop_x = −m_y / f_z; along y (faces): cop_y = m_x / f_z.
    if (link.kind != ContactKind::kPoint) {
      const int my = link.kind == ContactKind::kFace ? fx + 4 : fx + 3;
      qp.C(row, my) = -1.0;  // −m_y − x_max f_z ≤ 0
      qp.C(row, fz) = -lb.cop_max.x();
      qp.u[row++] = 0.0;
      qp.C(row, my) = 1.0;   //  m_y + x_min f_z ≤ 0
      qp.C(row, fz) = lb.cop_min.x();
      qp.u[row++] = 0.0;
      // Torsion (setTorsionRows).
      lb.torsion_row = row;
      setTorsionRows(qp, lb);
      row += 2;
    }
    if (link.kind == ContactKind::kFace) {
      const int mx = fx + 3;
      qp.C(row, mx) = 1.0;   //  m_x − y_max f_z ≤ 0
      qp.C(row, fz) = -lb.cop_max.y();
      qp.u[row++] = 0.0;
      qp.C(row, mx) = -1.0;  // −m_x + y_min f_z ≤ 0
      qp.C(row, fz) = lb.cop_min.y();
      qp.u[row++] = 0.0;
    }
    lb.yaw_slip = 0;
    lb.pivot_from_rest = false;
    lb.rotations_free = lb.tangents_free = false;
    if (options_.yaw_slip && link.kind != ContactKind::kPoint && link.yaw_slip != 0) {
      pivot(qp, i, link.yaw_slip, /*from_rest=*/false, H_C, u_C);
    }
    lb.slide = link.slide_A;
    if (!lb.slide.isZero()) slide(qp, i);
    slot += link.num_axes;
  }

  // A different contact set changes what some rows mean, not those of the joints nor of the
  // links held on: start from the last answer's working set, less the rows whose active
  // side is now unbounded (same answers as cold; BENCHMARKS.md), not cold.
  std::uint64_t signature = 1469598103934665603ull ^ static_cast<std::uint64_t>(nc);
  for (int i = 0; i < num_links; ++i) {
    const VirtualLink& link = links[i];
    const LinkBounds& lb = link_bounds_[static_cast<std::size_t>(i)];
    const int pivot = lb.yaw_slip * (lb.pivot_from_rest ? 2 : 1);
    const int slides = lb.slide.isZero() ? 0 : 1;
    for (const int value : {link.body, link.object, link.num_axes, link.created_this_tick ? 1 : 0, pivot, slides})
      signature = (signature ^ static_cast<std::uint64_t>(value + 2)) * 1099511628211ull;
  }
  if (signature != sc.signature) sc.solver->restartFromLastSolution();
  sc.signature = signature;
  report.info = timedSolve(sc, report, /*bounds_only=*/false);
  // The check is the criterion: an iterate stopped by the iteration limit that satisfies
  // every family to tolerance is as good as a converged one.
  auto acceptable = [&]() {
    return (report.info.status == QpSolveStatus::kSolved ||
            report.info.status == QpSolveStatus::kMaxIterations) &&
           report.violated == kQpFamilyNone;
  };
  auto extract = [&]() {
    vdot = sc.x.head(nv_);
    tau_C = sc.x.segment(nv_, nc);
    tau_J = b_J;
    tau_J.noalias() += M * sc.x.head(nv_ + nc);
    if (!sc.x.allFinite()) report.info.status = QpSolveStatus::kNotFinite;
    report.violated = check(A, b, H_C, u_C, vdot, tau_C, tau_J);
    return acceptable();
  };
  // A re-solve, and the next tick's solve, start from the working set of the last answer
  // (the previous tick's, or this one's): the answers are those of cold starts (a strictly
  // convex QP), reached in about half the working-set changes (BENCHMARKS.md).
  auto resolve = [&](bool bounds_only) {
    const int earlier_iterations = report.info.iterations;
    sc.solver->restartFromLastSolution();
    report.info = timedSolve(sc, report, bounds_only);
    report.info.iterations += earlier_iterations;
    sc.solver->restartFromLastSolution();
  };
  report.ok = extract();
  report.violated_first = report.violated;
  bool rows_restored = false;  // the solver's factors are of another problem's rows
  int pivots_started = 0;
  if (!report.ok && options_.yaw_slip) {
    // No answer holds every yaw: soles pivot, before any other bound gives way. Only then:
    // a pivot the answer does not need lets the sole drift in yaw, which nothing restores
    // (tried as the first attempt: 104 re-seeding ticks over the check matrix against 77).
    for (int i = 0; i < num_links; ++i) {
      const VirtualLink& link = links[i];
      const LinkBounds& lb = link_bounds_[static_cast<std::size_t>(i)];
      if (link.kind == ContactKind::kPoint || lb.yaw_slip != 0) continue;
      // A sole already turning slides on (kinetic friction against the turn); one at rest
      // starts to turn against the twist it held at the bound.
      const double yaw_rate = H_C.row(yawRow(lb)).dot(v);
      const double bound = lb.mu * lb.torsion_arm_m * std::max(link.normal_force_n, 0.0);
      if (std::abs(yaw_rate) > kPivotRestRate) {
        pivot(qp, i, yaw_rate > 0.0 ? -1 : 1, /*from_rest=*/false, H_C, u_C);
      } else if (!link.created_this_tick && bound > 0.0 && std::abs(link.torsion_n_m) >= kPivotOnset * bound) {
        pivot(qp, i, link.torsion_n_m > 0.0 ? 1 : -1, /*from_rest=*/true, H_C, u_C);
      } else {
        continue;
      }
      ++pivots_started;
    }
    if (pivots_started > 0) {
      sc.solver->limitNextSolve(kPivotAttemptShare);
      resolve(/*bounds_only=*/false);
      report.ok = extract();
      if (!report.ok) {  // not the torsion: the links stick, and the bounds give way below
        for (int i = 0; i < num_links; ++i)
          if (link_bounds_[static_cast<std::size_t>(i)].yaw_slip != 0 && links[i].yaw_slip == 0) stick(qp, i, H_C, u_C);
        pivots_started = 0;
        rows_restored = true;
      }
    }
  }
  bool rate_bounded = false;
  for (int i = 0; i < num_links; ++i) {
    const LinkBounds& lb = link_bounds_[static_cast<std::size_t>(i)];
    rate_bounded = rate_bounded || lb.f_min > options_.min_normal_force_n || std::isfinite(lb.f_max);
  }
  if (!report.ok && (options_.enforce_joint_limits || rate_bounded)) {
    // Measured on the CMU clips: the joint-limit bounds are what makes the QP infeasible
    // (a joint at its limit in stance, with torque limits and contacts hard), more rarely
    // the normal forces' rate bounds (release ramps, unloading rate: the remaining support
    // cannot take the load that fast, e.g. both feet of a jump). Both give way for the tick,
    // in one re-solve — physically, a joint at its stop gets its torque from the stop. (Two
    // re-solves in turn cost a tick up to one more cold solve: every tick of the four
    // clips, p99.9 3.2-4.1 ms against 2.4-2.6 ms together, the same answers in kind.)
    report.joint_limits_dropped = options_.enforce_joint_limits;
    report.ramps_dropped = rate_bounded;
    qp.x_lower.segment(nb_, nj_).setConstant(-kQpInfinity);
    qp.x_upper.segment(nb_, nj_).setConstant(kQpInfinity);
    accel_lo_.setConstant(-kQpInfinity);
    accel_hi_.setConstant(kQpInfinity);
    for (int i = 0; i < num_links; ++i) {
      LinkBounds& lb = link_bounds_[static_cast<std::size_t>(i)];
      lb.f_max = std::numeric_limits<double>::infinity();
      lb.f_min = options_.min_normal_force_n;
      qp.x_upper[nv_ + lb.row + 2] = kQpInfinity;
      qp.x_lower[nv_ + lb.row + 2] = lb.f_min;
    }
    resolve(/*bounds_only=*/!rows_restored);
    report.ok = extract();
  }
  // No answer holds every link: the rows may be dependent with inconsistent targets (two
  // touching bodies one joint apart), or the torque limits cannot hold them. Before the
  // contacts break, they give way as a rigid floor does, in three re-solves at most: the
  // rows that depend on others are freed (normal rows first, then tangents, then moments,
  // older links first), then every edge and face tips (its moments free: it holds as a
  // point at its origin), then every link is a frictionless point. The normal rows hold
  // (but dependent ones), so no body passes through the floor while the floor can push.
  for (int rung = 1; rung <= 3 && !report.ok && nc > 0; ++rung) {
    if (rung == 1) {
      if (freeDependentRows(qp, H_C, nc) == 0) continue;
    } else {
      for (int i = 0; i < num_links; ++i) freeLinkRows(qp, i, /*tangents=*/rung == 3);
    }
    report.floor_rung = rung;
    resolve(/*bounds_only=*/false);
    report.ok = extract();
    rows_restored = true;
  }
  if (!report.ok && nc > 0) {
    // Even the frictionless points cannot be held without pulling: the contacts break.
    // Solve with every link released (a QP that is always feasible: τ_J = 0 is a
    // solution); the filter then releases the links.
    report.contacts_released = true;
    for (int k = 0; k < nc; ++k) {
      qp.A.row(nb_ + k).setZero();
      qp.A(nb_ + k, nv_ + k) = 1.0;
      qp.b[nb_ + k] = 0.0;
    }
    qp.C.bottomRows(qp.nIn() - nj_).setZero();
    qp.l.tail(qp.nIn() - nj_).setConstant(-kQpInfinity);
    qp.u.tail(qp.nIn() - nj_).setConstant(kQpInfinity);
    qp.x_lower.tail(cap).setConstant(-kQpInfinity);
    qp.x_upper.tail(cap).setConstant(kQpInfinity);
    num_links_ = 0;
    report.floor_rung = 0;
    resolve(/*bounds_only=*/false);
    vdot = sc.x.head(nv_);
    tau_C.setZero();
    tau_J = b_J;
    tau_J.noalias() += A.bottomRows(nj_) * vdot;
    if (!sc.x.allFinite()) report.info.status = QpSolveStatus::kNotFinite;
    report.violated = check(A, b, H_C.topRows(0), u_C.head(0), vdot, tau_C.head(0), tau_J);
    report.ok = acceptable();
  }
  return report;
}

void ContactQp::pivot(DenseQp& qp, int i, int sign, bool from_rest,
                      const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                      const Eigen::Ref<const Eigen::VectorXd>& u_C) {
  LinkBounds& lb = link_bounds_[static_cast<std::size_t>(i)];
  const int yaw = yawRow(lb);
  const int fz = nv_ + lb.row + 2, mz = nv_ + yaw;
  const double sigma = sign > 0 ? 1.0 : -1.0;
  // The yaw row becomes Coulomb's twist: m_z − σ μ r f_z = 0.
  qp.A.row(nb_ + yaw).setZero();
  qp.A(nb_ + yaw, mz) = 1.0;
  qp.A(nb_ + yaw, fz) = -sigma * lb.mu * lb.torsion_arm_m;
  qp.b[nb_ + yaw] = 0.0;
  // The torsion rows: from rest, the body turns against the twist, σ (H_yaw v̇ − u_yaw) ≤ 0;
  // already turning, the yaw is free.
  for (const int t : {lb.torsion_row, lb.torsion_row + 1}) {
    qp.C.row(t).setZero();
    qp.l[t] = -kQpInfinity;
    qp.u[t] = kQpInfinity;
  }
  if (from_rest) {
    qp.C.row(lb.torsion_row).head(nv_) = sigma * H_C.row(yaw);
    qp.u[lb.torsion_row] = sigma * u_C[yaw];
  }
  lb.yaw_slip = sign > 0 ? 1 : -1;
  lb.pivot_from_rest = from_rest;
}

void ContactQp::freeRow(DenseQp& qp, int r) {
  // The row's force slot is held at zero; the row's motion is whatever the answer takes.
  qp.A.row(nb_ + r).setZero();
  qp.A(nb_ + r, nv_ + r) = 1.0;
  qp.b[nb_ + r] = 0.0;
  row_free_[static_cast<std::size_t>(r)] = 1;
}

void ContactQp::dropInequalityRows(DenseQp& qp, int first, int count) {
  for (int k = first; k < first + count; ++k) {
    qp.C.row(k).setZero();
    qp.l[k] = -kQpInfinity;
    qp.u[k] = kQpInfinity;
  }
}

void ContactQp::freeLinkRows(DenseQp& qp, int i, bool tangents) {
  LinkBounds& lb = link_bounds_[static_cast<std::size_t>(i)];
  if (lb.num_axes > 3 && !lb.rotations_free) {
    for (int slot = 3; slot < lb.num_axes; ++slot) freeRow(qp, lb.row + slot);
    dropInequalityRows(qp, lb.facet_row + options_.friction_facets, momentRows(lb));
    lb.rotations_free = true;
    lb.yaw_slip = 0;
    lb.pivot_from_rest = false;
  }
  if (tangents && !lb.tangents_free) {
    for (int slot = 0; slot < 2; ++slot) freeRow(qp, lb.row + slot);
    dropInequalityRows(qp, lb.facet_row, options_.friction_facets);
    lb.tangents_free = true;
    lb.slide.setZero();
  }
}

int ContactQp::freeDependentRows(DenseQp& qp, const Eigen::Ref<const Eigen::MatrixXd>& H_C, int nc) {
  int kept = 0, freed = 0;
  for (const int group : {0, 1, 2}) {  // normals, tangents, moments
    for (int i = 0; i < num_links_; ++i) {
      LinkBounds& lb = link_bounds_[static_cast<std::size_t>(i)];
      for (int slot = 0; slot < lb.num_axes; ++slot) {
        if ((slot == 2 ? 0 : slot < 2 ? 1 : 2) != group) continue;
        const int r = lb.row + slot;
        if (r >= nc || row_free_[static_cast<std::size_t>(r)] || appendIndependentRow(basis_, kept, H_C.row(r)))
          continue;
        ++freed;
        if (slot == 2) {  // a dependent normal: the whole link gives way
          for (int a = 0; a < lb.num_axes; ++a)
            if (!row_free_[static_cast<std::size_t>(lb.row + a)]) freeRow(qp, lb.row + a);
          dropInequalityRows(qp, lb.facet_row, options_.friction_facets + momentRows(lb));
          qp.x_lower[nv_ + lb.row + 2] = -kQpInfinity;
          qp.x_upper[nv_ + lb.row + 2] = kQpInfinity;
          lb.f_min = 0.0;
          lb.rotations_free = lb.tangents_free = true;
          lb.slide.setZero();
          lb.yaw_slip = 0;
          lb.pivot_from_rest = false;
        } else if (slot < 2 && !lb.slide.isZero()) {  // a slide's friction needs both tangents
          freeLinkRows(qp, i, /*tangents=*/true);
        } else {
          freeRow(qp, r);
          if (lb.yaw_slip != 0 && r == yawRow(lb)) lb.yaw_slip = 0;
        }
      }
    }
  }
  return freed;
}

bool ContactQp::rowFree(int r) const {
  if (r < 0 || r >= static_cast<int>(row_free_.size())) return false;
  if (row_free_[static_cast<std::size_t>(r)]) return true;
  for (int l = 0; l < num_links_; ++l) {
    const LinkBounds& lb = link_bounds_[static_cast<std::size_t>(l)];
    if (r < lb.row || r >= lb.row + lb.num_axes) continue;
    const int slot = r - lb.row;
    if (slot < 2) return !lb.slide.isZero();
    return lb.yaw_slip != 0 && r == yawRow(lb);
  }
  return false;
}

void ContactQp::slide(DenseQp& qp, int i) {
  const LinkBounds& lb = link_bounds_[static_cast<std::size_t>(i)];
  const int fz = nv_ + lb.row + 2;
  // The tangential rows become Coulomb's kinetic friction: f_t + μ ŝ f_z = 0.
  for (int d = 0; d < 2; ++d) {
    const int r = nb_ + lb.row + d;
    qp.A.row(r).setZero();
    qp.A(r, nv_ + lb.row + d) = 1.0;
    qp.A(r, fz) = lb.mu * lb.slide[d];
    qp.b[r] = 0.0;
  }
  // The friction pyramid gives way (the force lies on the cone). Nothing keeps the slide
  // from reversing within the tick (such a row has no answer where nothing pushes the body
  // at its stop): it overshoots the stop by at most one tick's friction, and the next tick
  // sticks or slides back against it.
  const int K = options_.friction_facets;
  for (int k = 0; k < K; ++k) {
    qp.C.row(lb.facet_row + k).setZero();
    qp.l[lb.facet_row + k] = -kQpInfinity;
    qp.u[lb.facet_row + k] = kQpInfinity;
  }
}

void ContactQp::stick(DenseQp& qp, int i, const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                      const Eigen::Ref<const Eigen::VectorXd>& u_C) {
  LinkBounds& lb = link_bounds_[static_cast<std::size_t>(i)];
  const int yaw = yawRow(lb);
  qp.A.row(nb_ + yaw).setZero();
  qp.A.row(nb_ + yaw).head(nv_) = H_C.row(yaw);
  qp.b[nb_ + yaw] = u_C[yaw];
  setTorsionRows(qp, lb);
  lb.yaw_slip = 0;
  lb.pivot_from_rest = false;
}

void ContactQp::setTorsionRows(DenseQp& qp, const LinkBounds& lb) const {
  // Coulomb friction at the support's points twists an edge or a face by at most μ f_z
  // times the farthest point's distance from the link origin (a necessary bound: the
  // tangential force shares the same friction): ±m_z − μ r f_z ≤ 0.
  const int fz = nv_ + lb.row + 2, mz = nv_ + yawRow(lb);
  for (const int t : {lb.torsion_row, lb.torsion_row + 1}) {
    qp.C.row(t).setZero();
    qp.C(t, mz) = t == lb.torsion_row ? 1.0 : -1.0;
    qp.C(t, fz) = -lb.mu * lb.torsion_arm_m;
    qp.l[t] = -kQpInfinity;
    qp.u[t] = 0.0;
  }
}

// ---- objective tasks of the balance layer (beyond the paper's QP) ----------------------
void ContactQp::addObjectiveTasks(DenseQp& qp, int nc) {
  if (tasks_ == nullptr || tasks_->rows <= 0) return;
  const int m = tasks_->rows, n = nv_ + nc;
  const auto T = tasks_->T.topLeftCorner(m, n);
  const auto w = tasks_->w.head(m);
  const auto r = tasks_->r.head(m);
  // H += Tᵀ diag(w) T and g −= Tᵀ diag(w) r in one product (rows with w ≤ 0 weigh 0).
  auto WT = weighted_tasks_.topLeftCorner(m, n);
  WT = w.cwiseMax(0.0).asDiagonal() * T;
  qp.H.topLeftCorner(n, n).noalias() += T.transpose() * WT;
  qp.g.head(n).noalias() -= WT.transpose() * r;
}

std::uint32_t ContactQp::check(const Eigen::Ref<const Eigen::MatrixXd>& A,
                               const Eigen::Ref<const Eigen::VectorXd>& b,
                               const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                               const Eigen::Ref<const Eigen::VectorXd>& u_C,
                               const Eigen::Ref<const Eigen::VectorXd>& vdot,
                               const Eigen::Ref<const Eigen::VectorXd>& tau_C,
                               const Eigen::Ref<const Eigen::VectorXd>& tau_J) const {
  std::uint32_t violated = kQpFamilyNone;
  const int nc = static_cast<int>(H_C.rows());
  if (!vdot.allFinite() || !tau_C.allFinite() || !tau_J.allFinite())
    return kQpFamilyEquality;

  // Eq. 12: dynamics rows (N, N m) and contact rows (m/s²).
  auto r = residual_.head(nv_);
  r = b;
  r.noalias() += A * vdot;
  r.noalias() -= H_C.transpose() * tau_C;
  r.tail(nj_) -= tau_J;
  if (r.cwiseAbs().maxCoeff() > equality_tolerance_) violated |= kQpFamilyEquality;
  for (int i = 0; i < nc; ++i)  // rowFree: a pivot's yaw, a slide's tangents (checked below), freed rows
    if (!rowFree(i) && std::abs(H_C.row(i).dot(vdot) - u_C[i]) > kAccelTolerance) violated |= kQpFamilyEquality;

  for (int i = 0; i < num_links_; ++i) {
    const LinkBounds& lb = link_bounds_[static_cast<std::size_t>(i)];
    if (lb.row + lb.num_axes > nc) break;
    const double fx = tau_C[lb.row], fy = tau_C[lb.row + 1], fz = tau_C[lb.row + 2];
    if (fz < lb.f_min - kForceTolerance || fz > lb.f_max + kForceTolerance)
      violated |= kQpFamilyUnilateral;
    if (std::hypot(fx, fy) > lb.mu * std::max(fz, 0.0) + kForceTolerance)
      violated |= kQpFamilyFriction;
    if (!lb.slide.isZero() &&
        (std::abs(fx + lb.mu * lb.slide.x() * fz) > kForceTolerance ||
         std::abs(fy + lb.mu * lb.slide.y() * fz) > kForceTolerance))
      violated |= kQpFamilyFriction;
    if (lb.num_axes >= 5 && !lb.rotations_free) {
      const int my = lb.row + (lb.num_axes == 6 ? 4 : 3);
      if (-tau_C[my] < lb.cop_min.x() * fz - kForceTolerance || -tau_C[my] > lb.cop_max.x() * fz + kForceTolerance)
        violated |= kQpFamilyCop;
      const double twist_bound = lb.mu * lb.torsion_arm_m * std::max(fz, 0.0);
      if (std::abs(tau_C[my + 1]) > twist_bound + kForceTolerance) violated |= kQpFamilyFriction;
      if (lb.yaw_slip != 0) {
        const int yaw = my + 1;
        if (std::abs(tau_C[yaw] - lb.yaw_slip * twist_bound) > kForceTolerance) violated |= kQpFamilyFriction;
        if (lb.pivot_from_rest && yaw < nc &&
            lb.yaw_slip * (H_C.row(yaw).dot(vdot) - u_C[yaw]) > kAccelTolerance)
          violated |= kQpFamilyFriction;
      }
    }
    if (lb.num_axes == 6 && !lb.rotations_free) {
      const double mx = tau_C[lb.row + 3];
      if (mx < lb.cop_min.y() * fz - kForceTolerance || mx > lb.cop_max.y() * fz + kForceTolerance)
        violated |= kQpFamilyCop;
    }
  }
  for (int j = 0; j < nj_; ++j) {
    if (options_.enforce_torque_limits && std::abs(tau_J[j]) > tau_max_[j] + kForceTolerance)
      violated |= kQpFamilyTorque;
    const double a = vdot[nb_ + j];
    if (a < accel_lo_[j] - kAccelTolerance || a > accel_hi_[j] + kAccelTolerance)
      violated |= kQpFamilyJointLimit;
  }
  return violated;
}

}  // namespace dynfilter
