// The filter's QP mode (FilterMode::kQp, contact_qp.hpp) on the human figure with ProxQP:
// the contact forces it publishes are physical (push, inside the friction cone, CoP on the
// sole), the torques within their limits and Eq. 12 exact; failures of the QP never pass
// silently; the release ramp bounds the rate at which a lifted foot's load goes away.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/core/contact_qp.hpp"
#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/io/retarget.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"
#include "dynfilter/qp_engines/qp_engines.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/reference_motions.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {


std::string sci(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", x);
  return buffer;
}

std::unique_ptr<IDynamicsModel> humanFigure() {
  return test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
}

// A posture with knees slightly bent (away from the knee's stop at 0), its base at the
// height where the soles touch the ground.
ReferenceFrame standingReference(IDynamicsModel& model) {
  const ModelInfo& info = model.info();
  ReferenceFrame ref(info.nq, info.nv);
  ref.q = info.neutralConfiguration();
  for (const char* side : {"l_", "r_"}) {
    const std::string p = side;
    ref.q[info.configurationIndex(info.findJoint(p + "hip_pitch"))] = -0.1;
    ref.q[info.configurationIndex(info.findJoint(p + "knee"))] = 0.2;
    ref.q[info.configurationIndex(info.findJoint(p + "ankle_pitch"))] = -0.1;
  }
  ref.q[2] = standingBaseHeight(model, ref.q);
  return ref;
}

// The link of @p c in the filter's link set after the tick (null when it was released).
const VirtualLink* linkOf(const DynamicsFilter& filter, const ContactOutput& c) {
  const VirtualLinkSet& links = filter.links();
  for (int i = 0; i < links.size(); ++i)
    if (links[i].body == c.body && links[i].object == c.object) return &links[i];
  return nullptr;
}

// Physical contact and limits, checked on one QP-mode tick's output.
struct PhysicsCheck {
  double min_normal_n = 1e300;       // smallest normal force seen
  double max_friction_excess = -1e300;  // max ‖f_t‖ − μ f_z (N)
  double max_cop_excess_m = -1e300;  // max distance of a CoP outside its rectangle (m)
  double max_torque_excess = -1e300;  // max |τ_J| − τ_max
  double max_torsion_excess = -1e300;  // edges, faces: max |m·n| − μ r f_z (N m), r to the farthest point
  double max_torsion_ratio = 0.0;      // edges, faces: max |m·n| / (μ r f_z)
  double max_base_residual_n = 0.0;
  int contact_ticks = 0;             // ticks with at least one contact
  int cop_checked = 0;               // face/edge contacts whose CoP was checked

  void add(const DynamicsFilter& filter, const FilterOutput& out, const ModelInfo& info,
           double mu) {
    for (int i = 0; i < out.num_contacts; ++i) {
      const ContactOutput& c = out.contacts[static_cast<std::size_t>(i)];
      const Eigen::Vector3d f = c.wrench_W.head<3>();
      const double fz = c.normal_force_n;
      EXPECT_NEAR(fz, f.dot(c.n_W), 1e-9);
      const double ft = (f - f.dot(c.n_W) * c.n_W).norm();
      min_normal_n = std::min(min_normal_n, fz);
      max_friction_excess = std::max(max_friction_excess, ft - mu * fz);
      if (c.kind == ContactKind::kPoint) continue;
      const VirtualLink* link = linkOf(filter, c);
      if (link == nullptr) continue;  // released by this tick; its bounds are gone
      for (int d = 0; d < (c.kind == ContactKind::kFace ? 2 : 1); ++d) {
        max_cop_excess_m = std::max(max_cop_excess_m, link->support_min[d] - c.cop_A[d]);
        max_cop_excess_m = std::max(max_cop_excess_m, c.cop_A[d] - link->support_max[d]);
      }
      // Torsion, about the normal at the link origin (r: the support's farthest point).
      const double r = std::hypot(std::max(std::abs(link->support_min.x()), std::abs(link->support_max.x())),
                                  std::max(std::abs(link->support_min.y()), std::abs(link->support_max.y())));
      const double twist = std::abs(c.wrench_W.tail<3>().dot(c.n_W));
      max_torsion_excess = std::max(max_torsion_excess, twist - mu * r * fz);
      if (fz > 1.0) max_torsion_ratio = std::max(max_torsion_ratio, twist / (mu * r * fz));
      ++cop_checked;
    }
    if (out.num_contacts > 0) ++contact_ticks;
    for (int j = 0; j < info.nj; ++j)
      max_torque_excess = std::max(max_torque_excess, std::abs(out.tau_J[j]) - info.tau_max[j]);
    max_base_residual_n = std::max(max_base_residual_n, out.base_residual_n);
  }
};

// ---------------------------------------------------------------------------------------
// Options

TEST(QpModeOptions, QpModeWithoutASolverFactoryThrows) {
  auto model = humanFigure();
  try {
    DynamicsFilter filter(*model, test::qpDefaults(1e-3));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("QP solver"), std::string::npos) << e.what();
  }
  // The same options with a factory construct, and paper mode needs none.
  EXPECT_NO_THROW(DynamicsFilter(*model, test::qpDefaults(1e-3), qp_engines::factory(QpSolverSettings{}.engine)));
  EXPECT_NO_THROW(DynamicsFilter(*model, FilterOptions{}));
}

TEST(QpModeOptions, TaskConstraintRowsAreRejectedInQpMode) {
  auto model = humanFigure();
  FilterOptions options = test::qpDefaults(1e-3);
  options.task.as_constraint_rows = true;
  try {
    DynamicsFilter filter(*model, options, qp_engines::factory(QpSolverSettings{}.engine));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("as_constraint_rows"), std::string::npos) << e.what();
  }
  options.task.enabled = false;  // no task point: the rows do not exist, nothing to reject
  EXPECT_NO_THROW(DynamicsFilter(*model, options, qp_engines::factory(QpSolverSettings{}.engine)));
}

TEST(QpModeOptions, FactoryThatReturnsNoSolverIsRejected) {
  auto model = humanFigure();
  const QpSolverFactory null_factory = [](int, int, int, const QpSolverSettings&) {
    return std::unique_ptr<IQpSolver>();
  };
  EXPECT_THROW(DynamicsFilter(*model, test::qpDefaults(1e-3), null_factory), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------
// Standing still: the two soles carry exactly the weight

TEST(QpModeStanding, StaticStanceCarriesTheWeightWithTheCopOnTheSoles) {
  auto model = humanFigure();
  const ModelInfo& info = model->info();
  const ReferenceFrame ref = standingReference(*model);
  const double weight = info.total_mass * kStandardGravity;
  const double mu = model->environment().ground.friction;
  DynamicsFilter filter(*model, test::qpDefaults(1e-3), qp_engines::factory(QpSolverSettings{}.engine));
  filter.reset(ref);
  PhysicsCheck check;
  const int ticks = 1500;
  std::uint32_t status_union = 0;
  double weight_error = 0.0;
  for (int k = 0; k < ticks; ++k) {
    ReferenceFrame r = ref;
    r.time_s = k * 1e-3;
    const FilterOutput& out = filter.step(r);
    status_union |= out.status;
    check.add(filter, out, info, mu);
    if (k == ticks - 1) {
      ASSERT_EQ(out.num_contacts, 2);
      double sum = 0.0;
      for (int i = 0; i < 2; ++i) {
        const ContactOutput& c = out.contacts[static_cast<std::size_t>(i)];
        EXPECT_EQ(c.kind, ContactKind::kFace) << "body " << c.body;
        sum += c.normal_force_n;
        // Standing symmetrically: each sole carries a share, neither at the minimum.
        EXPECT_GT(c.normal_force_n, 0.25 * weight);
      }
      weight_error = std::abs(sum - weight) / weight;
      // At rest: v and v̇ vanish, so the base rows of Eq. 12 say Σ f_z = m g.
      EXPECT_LT(out.v.cwiseAbs().maxCoeff(), 1e-5);
      EXPECT_LT(weight_error, 1e-6) << "sum " << sum << " N, weight " << weight << " N";
      const std::vector<int> bodies{out.contacts[0].body, out.contacts[1].body};
      EXPECT_TRUE(std::count(bodies.begin(), bodies.end(), info.findBody("l_foot")) == 1 &&
                  std::count(bodies.begin(), bodies.end(), info.findBody("r_foot")) == 1);
    }
  }
  RecordProperty("weight_sum_relative_error", sci(weight_error));
  RecordProperty("max_base_residual_n", sci(check.max_base_residual_n));
  EXPECT_EQ(status_union & (kStatusQpFallback | kStatusQpRelaxed | kStatusNonFinite), 0u)
      << "status union " << status_union;
  EXPECT_GE(check.min_normal_n, test::qpDefaults(1e-3).qp.min_normal_force_n - 1e-6);
  EXPECT_LE(check.max_friction_excess, 1e-6);
  EXPECT_GT(check.cop_checked, ticks);  // two soles on (almost) every tick
  EXPECT_LE(check.max_cop_excess_m, 1e-6);
  EXPECT_LE(check.max_torsion_excess, 1e-6);
  EXPECT_LE(check.max_torque_excess, 1e-6);
  EXPECT_LE(check.max_base_residual_n, 1e-8 * weight);
  const FilterCounters& counters = filter.output().counters;
  EXPECT_EQ(counters.ticks, static_cast<std::uint64_t>(ticks));
  EXPECT_EQ(counters.ticks, counters.qp_solves + counters.qp_fallbacks);
  EXPECT_EQ(counters.qp_fallbacks, 0u);
  EXPECT_EQ(counters.qp_relaxed, 0u);
  EXPECT_EQ(counters.links_released, 0u);
}

// A cap of two outer iterations per solve: some solves stop at it. The tick says so
// (kStatusQpIterationLimit) and what it publishes still satisfies the base rows of Eq. 12
// to solver precision (a capped iterate is used only when it passes the check, else the
// fallback's Eq. 14 holds them).
TEST(QpModeStanding, AnIterationCapIsVisibleAndEq12StillHolds) {
  auto model = humanFigure();
  const ModelInfo& info = model->info();
  const double weight = info.total_mass * kStandardGravity;
  const auto frames = test::simulateStandingSway(*model, 1.0, 1e-3);
  FilterOptions options = test::qpDefaults(1e-3);
  options.qp.solver.max_iterations = 2;
  DynamicsFilter filter(*model, options, proxqp::factory());
  filter.reset(frames.front());
  int capped = 0;
  double worst_base = 0.0;
  for (const ReferenceFrame& f : frames) {
    const FilterOutput& out = filter.step(f);
    if (out.status & kStatusQpIterationLimit) {
      ++capped;
      EXPECT_EQ(out.qp_status, static_cast<int>(QpSolveStatus::kMaxIterations));
    }
    if (!(out.status & kStatusReseeded)) worst_base = std::max(worst_base, out.base_residual_n);
    ASSERT_TRUE(out.tau_J.allFinite());
  }
  RecordProperty("capped_ticks", capped);
  EXPECT_GT(capped, 0) << "one outer iteration does not always reach 1e-7";
  EXPECT_LE(worst_base, 1e-8 * weight);
  EXPECT_EQ(filter.output().counters.reseeds, 0u);
}

TEST(QpModeStanding, SwayingSquatKeepsContactsPhysical) {
  // The simulated (Eq. 14) swaying squat: consistent for the figure, so the QP has no
  // reason to relax or fall back, and it must keep every inequality on every tick.
  auto model = humanFigure();
  const ModelInfo& info = model->info();
  const auto frames = test::simulateStandingSway(*model, 1.0, 1e-3);
  const double weight = info.total_mass * kStandardGravity;
  DynamicsFilter filter(*model, test::qpDefaults(1e-3), qp_engines::factory(QpSolverSettings{}.engine));
  filter.reset(frames.front());
  PhysicsCheck check;
  std::uint32_t status_union = 0;
  for (const ReferenceFrame& f : frames) {
    const FilterOutput& out = filter.step(f);
    status_union |= out.status;
    check.add(filter, out, info, model->environment().ground.friction);
  }
  EXPECT_EQ(status_union & (kStatusQpFallback | kStatusQpRelaxed | kStatusNonFinite), 0u);
  EXPECT_EQ(check.contact_ticks, static_cast<int>(frames.size()));
  EXPECT_GE(check.min_normal_n, 1.0 - 1e-6);
  EXPECT_LE(check.max_friction_excess, 1e-6);
  EXPECT_LE(check.max_cop_excess_m, 1e-6);
  EXPECT_LE(check.max_torsion_excess, 1e-6);
  EXPECT_LE(check.max_torque_excess, 1e-6);
  EXPECT_LE(check.max_base_residual_n, 1e-8 * weight);
  const FilterCounters& counters = filter.output().counters;
  EXPECT_EQ(counters.ticks, counters.qp_solves + counters.qp_fallbacks);
}

// A standing reference that twists about the vertical, ±0.8 rad at 3 Hz (peak yaw
// acceleration 284 rad/s²): far more twist than the soles' friction can give. Each face's
// yaw moment stays within μ r f_z (Coulomb friction at its farthest support corner), and
// reaches it: the bound binds.
TEST(QpModeStanding, ATwistingReferenceKeepsEachSolesYawMomentWithinFriction) {
  auto model = humanFigure();
  const ModelInfo& info = model->info();
  const ReferenceFrame stand = standingReference(*model);
  const double dt = 1e-3, amplitude = 0.8, omega = 2.0 * 3.14159265358979323846 * 3.0;
  DynamicsFilter filter(*model, test::qpDefaults(dt), qp_engines::factory(QpSolverSettings{}.engine));
  filter.reset(stand);
  PhysicsCheck check;
  std::uint32_t status_union = 0;
  ReferenceFrame ref = stand;
  for (int k = 0; k < 1000; ++k) {
    const double t = k * dt, yaw = amplitude * std::sin(omega * t);
    ref.time_s = t;
    const Eigen::Quaterniond turn(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
    ref.q[3] = turn.w();  // the standing base is level: its orientation is the turn alone
    ref.q[4] = turn.x();
    ref.q[5] = turn.y();
    ref.q[6] = turn.z();
    ref.v.setZero();
    ref.vdot.setZero();
    ref.v[5] = amplitude * omega * std::cos(omega * t);
    ref.vdot[5] = -amplitude * omega * omega * std::sin(omega * t);
    const FilterOutput& out = filter.step(ref);
    status_union |= out.status;
    check.add(filter, out, info, model->environment().ground.friction);
  }
  RecordProperty("max_torsion_ratio", sci(check.max_torsion_ratio));
  EXPECT_EQ(status_union & (kStatusQpFallback | kStatusNonFinite), 0u) << "status union " << status_union;
  EXPECT_GT(check.contact_ticks, 900);
  EXPECT_LE(check.max_torsion_excess, 1e-6);
  EXPECT_GT(check.max_torsion_ratio, 0.99) << "the twist must reach the bound for the check to mean anything";
  EXPECT_LE(check.max_friction_excess, 1e-6);
}

// A box (0.2 × 0.1 × 0.05 m, 3 kg, I_zz 0.0125 kg m²) lying on the ground and spinning at
// 5 rad/s about the vertical: holding its face's yaw would stop it within the Baumgarte
// damping (500 rad/s², 6.25 N m of twist); friction gives at most μ r m g = 2.63 N m
// (r = 0.112 m, the farthest corner). With QpModeOptions::yaw_slip the face pivots: its
// twist is −sign(ω) μ r m g, so the box slows at the closed form μ r m g / I_zz = 211 rad/s²
// and stops after ω₀ I_zz / (μ r m g) = 23.7 ms, then holds again (the last tick's overshoot,
// at most 211 rad/s² × dt, damped out by the link's stabilisation). Without pivots no answer
// holds the face, and the solve relaxes until the contact lets go.
TEST(QpModePivot, ASpinningBoxSlowsAtFrictionsTwistThenHolds) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::testModelPath("floating_box.urdf")),
                               ModelOptions{});
  const ModelInfo& info = model->info();
  const double mu = model->environment().ground.friction;
  const double mass = 3.0, izz = 0.0125, r = std::hypot(0.1, 0.05), spin = 5.0, dt = 1e-3;
  const double decel = mu * r * mass * kStandardGravity / izz;
  ReferenceFrame rest(info.nq, info.nv);
  rest.q << 0, 0, 0, 1, 0, 0, 0;
  rest.q[2] = standingBaseHeight(*model, rest.q);
  Eigen::VectorXd v_spin = Eigen::VectorXd::Zero(info.nv);
  v_spin[5] = spin;
  for (const bool yaw_slip : {true, false}) {
    SCOPED_TRACE(yaw_slip ? "pivots" : "no pivots");
    FilterOptions options = test::qpDefaults(dt);
    options.qp.yaw_slip = yaw_slip;
    options.balance.enabled = false;
    DynamicsFilter filter(*model, options, qp_engines::factory(QpSolverSettings{}.engine));
    filter.reset(rest);
    for (int k = 0; k < 5; ++k) filter.step(rest);  // the face link forms and settles
    ASSERT_EQ(filter.links().size(), 1);
    ASSERT_EQ(filter.links()[0].kind, ContactKind::kFace);
    ASSERT_TRUE(filter.setMeasuredState(filter.output().q, v_spin));
    double omega = spin, max_decel_error = 0.0, max_twist_gap = 0.0, stopped_at_s = -1.0;
    double max_spin_after_stop = 0.0, max_twist_ratio_after_stop = 0.0;
    std::uint64_t relaxed_before = filter.output().counters.qp_relaxed;
    for (int k = 0; k < 200; ++k) {
      const FilterOutput& out = filter.step(rest);
      if (!yaw_slip) break;
      ASSERT_EQ(out.status & (kStatusQpFallback | kStatusQpRelaxed | kStatusReseeded), 0u) << "tick " << k;
      ASSERT_EQ(out.num_contacts, 1) << "tick " << k;
      const ContactOutput& c = out.contacts[0];
      const double twist = c.wrench_W.tail<3>().dot(c.n_W), bound = mu * r * c.normal_force_n;
      if (stopped_at_s < 0.0 && c.pivot != 0) {
        EXPECT_EQ(c.pivot, -1) << "tick " << k << ": the twist opposes the turn";
        max_twist_gap = std::max(max_twist_gap, std::abs(twist - c.pivot * bound));
        max_decel_error = std::max(max_decel_error, std::abs(out.vdot[5] + decel) / decel);
        EXPECT_NEAR(c.normal_force_n, mass * kStandardGravity, 1e-6 * mass * kStandardGravity) << "tick " << k;
      } else if (stopped_at_s < 0.0) {
        stopped_at_s = (k + 1) * dt;
      } else {
        max_spin_after_stop = std::max(max_spin_after_stop, std::abs(out.v[5]));
        max_twist_ratio_after_stop = std::max(max_twist_ratio_after_stop, std::abs(twist) / bound);
      }
      omega = out.v[5];
    }
    if (!yaw_slip) {
      EXPECT_GT(filter.output().counters.qp_relaxed, relaxed_before) << "holding the face has no answer";
      EXPECT_EQ(filter.output().counters.pivot_ticks, 0u);
      continue;
    }
    RecordProperty("stopped_at_s", sci(stopped_at_s));
    EXPECT_LE(max_twist_gap, 1e-6) << "a pivot's twist is friction's bound";
    EXPECT_LE(max_decel_error, 1e-6) << "the box slows at mu r m g / I_zz";
    EXPECT_NEAR(stopped_at_s, spin / decel, 2.5 * dt);
    EXPECT_LE(max_spin_after_stop, decel * dt) << "no more than the last tick's overshoot";
    EXPECT_LT(std::abs(omega), 1e-3) << "the face holds once the turn stops";
    EXPECT_LE(max_twist_ratio_after_stop, 1.0 + 1e-9);
    EXPECT_GE(filter.output().counters.pivot_ticks, 20u);
  }
}

// The same box lying on the ground and moving at v₀ = 1 m/s along x, while its reference
// flies ballistically above it (out of the reference's stance, needing no support: the
// balance layer's schedule holds no body). With QpModeOptions::tangential_slip its face
// slides: the friction is μ m g against the motion, so it slows at μ g = 7.85 m/s² (closed
// form, whatever the reference asks) and stops after v₀ / (μ g) = 127 ms, then sticks (at
// most one tick's friction past the stop). The new link's impact keeps the slide: the
// impulse that would stop it (m v₀ = 3 N s) lies outside the friction cone of the normal one
// (≈ 0). Without the option the link sticks at once: the impact stops the box.
// (The flight keeps the box out of the schedule's stance; a reference gliding on the ground
// with nothing else standing would hold it, BalanceLayer::heldStance.)
class QpModeSlide : public ::testing::TestWithParam<std::string> {};

// The box's reference at @p t: thrown from 0.3 m above its resting height @p z_rest at 1 m/s
// up, moving along x at @p v0 (a ballistic flight: it needs no support).
ReferenceFrame thrownBox(const ModelInfo& info, double z_rest, double v0, double t) {
  ReferenceFrame ref(info.nq, info.nv);
  ref.time_s = t;
  ref.q << v0 * t, 0, z_rest + 0.3 + t - 0.5 * kStandardGravity * t * t, 1, 0, 0, 0;
  ref.v.setZero();
  ref.v[0] = v0;
  ref.v[2] = 1.0 - kStandardGravity * t;
  ref.vdot.setZero();
  ref.vdot[2] = -kStandardGravity;
  return ref;
}

TEST_P(QpModeSlide, ABoxSlidingOnTheGroundSlowsAtMuGThenSticks) {
  auto model = test::makeModel(GetParam(), urdf::loadUrdfFile(test::testModelPath("floating_box.urdf")),
                               ModelOptions{});
  const ModelInfo& info = model->info();
  const double mu = model->environment().ground.friction;
  const double mass = 3.0, v0 = 1.0, dt = 1e-3, decel = mu * kStandardGravity;
  const double z_rest = [&] {
    Eigen::VectorXd q(info.nq);
    q << 0, 0, 0, 1, 0, 0, 0;
    return standingBaseHeight(*model, q);
  }();
  auto reference = [&](double t) { return thrownBox(info, z_rest, v0, t); };
  for (const bool slip : {true, false}) {
    SCOPED_TRACE(slip ? "slides" : "sticks");
    FilterOptions options = test::qpDefaults(dt);
    options.qp.tangential_slip = slip;
    // The reference lifts the box: its link's release ramp runs, here over 1 s (the QP
    // relaxes the ramp's bound, which the box's weight exceeds; the slide's rows stay).
    options.qp.release_transition_s = 1.0;
    DynamicsFilter filter(*model, options, qp_engines::factory(QpSolverSettings{}.engine));
    filter.reset(reference(0.0));
    Eigen::VectorXd q0(info.nq), v_start = Eigen::VectorXd::Zero(info.nv);
    q0 << 0, 0, z_rest, 1, 0, 0, 0;
    v_start[0] = v0;
    for (int k = 0; k <= 250; ++k) ASSERT_TRUE(filter.previewFrame(reference(k * dt)));  // its flight ahead
    ASSERT_TRUE(filter.setMeasuredState(q0, v_start));
    double max_decel_error = 0.0, max_friction_gap = 0.0, stopped_at_s = -1.0, max_speed_after_stop = 0.0;
    int sliding_ticks = 0, first_contact = -1;
    for (int k = 0; k < 200; ++k) {
      const FilterOutput& out = filter.step(reference((k + 1) * dt));
      ASSERT_EQ(out.status & (kStatusQpFallback | kStatusReseeded | kStatusNonFinite), 0u) << "tick " << k;
      if (first_contact < 0 && out.num_contacts == 0 && k < 3) continue;  // it touches down first
      if (first_contact < 0) first_contact = k;
      ASSERT_EQ(out.num_contacts, 1) << "tick " << k;
      const ContactOutput& c = out.contacts[0];
      if (!slip) {
        EXPECT_TRUE(c.slide_W.isZero()) << "tick " << k;
        if (k == first_contact) {
          EXPECT_NEAR(out.v[0], 0.0, 1e-6) << "the impact of a sticking link stops the box";
        }
        continue;
      }
      if (stopped_at_s < 0.0 && !c.slide_W.isZero()) {
        ++sliding_ticks;
        EXPECT_NEAR(c.slide_W.x(), 1.0, 1e-9) << "tick " << k;
        EXPECT_NEAR(c.normal_force_n, mass * kStandardGravity, 0.01 * mass * kStandardGravity) << "tick " << k;
        max_friction_gap = std::max(max_friction_gap, (c.wrench_W.head<3>() + mu * c.normal_force_n * c.slide_W -
                                                       c.normal_force_n * c.n_W).norm());
        const double expected = mu * c.normal_force_n / mass;  // the normal force's share of the Baumgarte term
        max_decel_error = std::max(max_decel_error, std::abs(out.vdot[0] + expected) / expected);
        if (k == first_contact) {
          EXPECT_NEAR(out.v[0], v0, 1e-9) << "the impact keeps the slide (out.v: after the impact)";
        }
      } else if (stopped_at_s < 0.0) {
        stopped_at_s = (k + 1 - first_contact) * dt;
      } else {
        max_speed_after_stop = std::max(max_speed_after_stop, std::abs(out.v[0]));
        EXPECT_TRUE(c.slide_W.isZero()) << "tick " << k << ": stopped, it sticks";
      }
    }
    if (!slip) continue;
    RecordProperty("slide_stopped_at_s", sci(stopped_at_s));
    EXPECT_GT(sliding_ticks, 100);
    EXPECT_LE(max_friction_gap, 1e-6) << "the tangential force is mu f_n against the slide";
    EXPECT_LE(max_decel_error, 1e-6) << "the box slows at mu f_n / m (mu g)";
    EXPECT_NEAR(stopped_at_s, v0 / decel, 2.5 * dt);
    EXPECT_LE(max_speed_after_stop, decel * dt) << "no more than the last tick's overshoot";
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, QpModeSlide, ::testing::ValuesIn(test::allBackends()));

// An engine that solves with a real one, except while @p fail is set: then it answers with a
// non-finite iterate, as an engine that broke down would.
class FailsOnRequest final : public IQpSolver {
 public:
  FailsOnRequest(std::unique_ptr<IQpSolver> engine, const bool& fail) : engine_(std::move(engine)), fail_(fail) {}
  QpSolveInfo solve(const DenseQp& problem, Eigen::Ref<Eigen::VectorXd> x) override {
    return fail_ ? broken(x) : engine_->solve(problem, x);
  }
  QpSolveInfo resolveWithNewBounds(const DenseQp& problem, Eigen::Ref<Eigen::VectorXd> x) override {
    return fail_ ? broken(x) : engine_->resolveWithNewBounds(problem, x);
  }
  void resetWarmStart() override { engine_->resetWarmStart(); }
  void restartFromLastSolution() override { engine_->restartFromLastSolution(); }
  const char* name() const override { return "fails-on-request"; }

 private:
  static QpSolveInfo broken(Eigen::Ref<Eigen::VectorXd> x) {
    x.setConstant(std::numeric_limits<double>::quiet_NaN());
    QpSolveInfo info;
    info.status = QpSolveStatus::kNotFinite;
    return info;
  }
  std::unique_ptr<IQpSolver> engine_;
  const bool& fail_;
};

// The box of ABoxSlidingOnTheGroundSlows... while it slides, and a QP that breaks down on one
// tick: the fallback (the paper's solve) holds the sliding link as a plain virtual link, Eq. 12
// exact and every output finite; what the failed solve left in its iterate (here NaN) does not
// reach the fallback's equation. The next tick slides on with the QP.
TEST_P(QpModeSlide, AFallbackWhileSlidingHoldsTheLinkWithoutTheFailedSolvesIterate) {
  auto model = test::makeModel(GetParam(), urdf::loadUrdfFile(test::testModelPath("floating_box.urdf")),
                               ModelOptions{});
  const ModelInfo& info = model->info();
  const double mass = 3.0, v0 = 1.0, dt = 1e-3;
  Eigen::VectorXd q0(info.nq), v_start = Eigen::VectorXd::Zero(info.nv);
  q0 << 0, 0, 0, 1, 0, 0, 0;
  q0[2] = standingBaseHeight(*model, q0);
  v_start[0] = v0;
  auto reference = [&](double t) { return thrownBox(info, q0[2], v0, t); };
  FilterOptions options = test::qpDefaults(dt);
  options.qp.tangential_slip = true;
  options.qp.release_transition_s = 1.0;
  bool fail = false;
  const QpSolverFactory engines = qp_engines::factory(QpSolverSettings{}.engine);
  DynamicsFilter filter(*model, options, [&](int n, int m_eq, int m_in, const QpSolverSettings& s) {
    return std::unique_ptr<IQpSolver>(new FailsOnRequest(engines(n, m_eq, m_in, s), fail));
  });
  filter.reset(reference(0.0));
  for (int k = 0; k <= 250; ++k) ASSERT_TRUE(filter.previewFrame(reference(k * dt)));
  ASSERT_TRUE(filter.setMeasuredState(q0, v_start));
  const int failing_tick = 40;  // the box slides until about tick 130
  for (int k = 0; k < failing_tick + 10; ++k) {
    fail = k == failing_tick;
    const FilterOutput& out = filter.step(reference((k + 1) * dt));
    ASSERT_TRUE(out.q.allFinite() && out.v.allFinite() && out.vdot.allFinite() && out.tau_J.allFinite()) << "tick " << k;
    ASSERT_EQ(out.status & (kStatusNonFinite | kStatusReseeded), 0u) << "tick " << k << ": " << out.status;
    if (k < 5) continue;  // touching down
    ASSERT_EQ(out.num_contacts, 1) << "tick " << k;
    const ContactOutput& c = out.contacts[0];
    if (k != failing_tick) {
      EXPECT_EQ(out.status & kStatusQpFallback, 0u) << "tick " << k;
      EXPECT_FALSE(c.slide_W.isZero()) << "tick " << k << ": the box slides";
      continue;
    }
    EXPECT_NE(out.status & kStatusQpFallback, 0u);
    EXPECT_LE(out.eq12_residual, 1e-9 * mass * kStandardGravity) << "Eq. 12 holds on every row";
    EXPECT_LE(out.base_residual_n, 1e-9 * mass * kStandardGravity);
  }
  EXPECT_EQ(filter.output().counters.qp_fallbacks, 1u);
}

// The box resting on the ground with its reference, which is then thrown up (3 m/s) while
// the box, which nothing can lift, stays: the schedule lifts the box, its link unloads over the release ramp and goes, and the
// box, which nothing can lift, settles under gravity. A released pair the reference lifts
// re-engages as soon as it moves into the ground, not 5 mm deep; the link it makes there, on a
// body the reference has never had in stance, carries the box (m g) instead of ramping down
// from 0 N and letting go again.
TEST_P(QpModeSlide, ABoxTheReferenceLiftsIsCaughtWhereItRestsNotFiveMillimetresDeep) {
  auto model = test::makeModel(GetParam(), urdf::loadUrdfFile(test::testModelPath("floating_box.urdf")),
                               ModelOptions{});
  const ModelInfo& info = model->info();
  const double mass = 3.0, dt = 1e-3;
  const double z_rest = [&] {
    Eigen::VectorXd q(info.nq);
    q << 0, 0, 0, 1, 0, 0, 0;
    return standingBaseHeight(*model, q);
  }();
  const double rest_s = 0.05;  // in the reference's stance first: the link carries the box
  auto reference = [&](double t) {
    ReferenceFrame ref(info.nq, info.nv);
    ref.time_s = t;
    const double s = std::max(0.0, t - rest_s);  // then thrown up at 3 m/s
    ref.q << 0, 0, z_rest + 3.0 * s - 0.5 * kStandardGravity * s * s, 1, 0, 0, 0;
    ref.v.setZero();
    ref.vdot.setZero();
    if (t > rest_s) {
      ref.v[2] = 3.0 - kStandardGravity * s;
      ref.vdot[2] = -kStandardGravity;
    }
    return ref;
  };
  FilterOptions options = test::qpDefaults(dt);
  DynamicsFilter filter(*model, options, qp_engines::factory(QpSolverSettings{}.engine));
  filter.reset(reference(0.0));
  for (int k = 0; k <= 500; ++k) ASSERT_TRUE(filter.previewFrame(reference(k * dt)));
  Eigen::VectorXd q0(info.nq);
  q0 << 0, 0, z_rest - 1e-4, 1, 0, 0, 0;  // resting, 0.1 mm in: its face link forms
  ASSERT_TRUE(filter.setMeasuredState(q0, Eigen::VectorXd::Zero(info.nv)));
  double max_depth = 0.0, max_force_error = 0.0;
  std::uint64_t released = 0;
  int held_ticks = 0;
  for (int k = 0; k < 300; ++k) {
    const FilterOutput& out = filter.step(reference((k + 1) * dt));
    ASSERT_EQ(out.status & (kStatusQpFallback | kStatusReseeded | kStatusNonFinite), 0u) << "tick " << k;
    max_depth = std::max(max_depth, out.max_penetration_m);
    released = out.counters.links_released;
    if (k < 150) continue;  // the first link's ramp (release_transition_s) is over by 0.1 s
    if (out.num_contacts == 1) ++held_ticks;
    if (out.num_contacts == 1)
      max_force_error = std::max(max_force_error, std::abs(out.contacts[0].normal_force_n - mass * kStandardGravity));
  }
  RecordProperty("max_depth_m", sci(max_depth));
  EXPECT_GE(released, 1u) << "the reference's lift let the first link go";
  EXPECT_LE(max_depth, 1e-3) << "caught as it moves into the ground (5 mm before)";
  EXPECT_EQ(held_ticks, 150) << "the new link holds";
  EXPECT_LE(max_force_error, 0.01 * mass * kStandardGravity) << "and carries the box";
}

// Coulomb at the impulse level: the box lands 0.2 mm deep with (v_x, v_z), the reference
// flying above it. The impulse that would stop it entirely is m (v_x, −v_z); within the
// friction cone (|m v_x| ≤ μ m |v_z|) the link sticks and the impact stops the box, outside
// it the link slides through the impact, which stops only the fall.
TEST_P(QpModeSlide, ALandingSticksWhereItsImpulseLiesWithinTheFrictionCone) {
  auto model = test::makeModel(GetParam(), urdf::loadUrdfFile(test::testModelPath("floating_box.urdf")),
                               ModelOptions{});
  const ModelInfo& info = model->info();
  const double mu = model->environment().ground.friction;
  Eigen::VectorXd q0(info.nq);
  q0 << 0, 0, 0, 1, 0, 0, 0;
  q0[2] = standingBaseHeight(*model, q0) - 2e-4;
  ReferenceFrame ref(info.nq, info.nv);
  ref.q = q0;
  ref.q[2] += 0.3;
  ref.vdot[2] = -kStandardGravity;  // in flight: the schedule holds no body
  struct Landing {
    double vx, vz;
  };
  for (const Landing landing : {Landing{0.5, -2.0}, Landing{1.0, -0.2}, Landing{1.5, -2.0}}) {
    const bool sticks = landing.vx <= mu * -landing.vz;
    SCOPED_TRACE("v_x " + std::to_string(landing.vx) + ", v_z " + std::to_string(landing.vz));
    DynamicsFilter filter(*model, test::qpDefaults(1e-3), qp_engines::factory(QpSolverSettings{}.engine));
    filter.reset(ref);
    for (int k = 0; k <= 100; ++k) {  // its flight ahead: falling, it needs no support
      ReferenceFrame ahead = ref;
      ahead.time_s = k * 1e-3;
      ahead.q[2] -= 0.5 * kStandardGravity * ahead.time_s * ahead.time_s;
      ahead.v[2] = -kStandardGravity * ahead.time_s;
      ASSERT_TRUE(filter.previewFrame(ahead));
    }
    Eigen::VectorXd v = Eigen::VectorXd::Zero(info.nv);
    v[0] = landing.vx;
    v[2] = landing.vz;
    ASSERT_TRUE(filter.setMeasuredState(q0, v));
    const FilterOutput& out = filter.step(ref);
    ASSERT_EQ(out.status & kStatusImpact, kStatusImpact);
    ASSERT_EQ(out.num_contacts, 1);
    EXPECT_NEAR(out.v[2], 0.0, 1e-9) << "the impact stops the fall";
    if (sticks) {
      EXPECT_TRUE(out.contacts[0].slide_W.isZero());
      EXPECT_NEAR(out.v[0], 0.0, 1e-9) << "the impact stops the box";
    } else {
      EXPECT_NEAR(out.contacts[0].slide_W.x(), 1.0, 1e-9);
      EXPECT_NEAR(out.v[0], landing.vx, 1e-9) << "the impact keeps the slide";
    }
  }
}

// ---------------------------------------------------------------------------------------
// A retargeted CMU clip: paper mode pulls on the ground, QP mode never does

struct ClipRun {
  PhysicsCheck check;
  std::uint32_t status_union = 0;
  double min_normal_n = 1e300;
  int pulling_ticks = 0;
  FilterCounters counters;
  int ticks = 0;
};

ClipRun filterClip(IDynamicsModel& model, const std::vector<ReferenceFrame>& frames, int substeps,
                   const FilterOptions& options) {
  DynamicsFilter filter(model, options, qp_engines::factory(QpSolverSettings{}.engine));
  filter.reset(frames.front());
  ReferenceFrame ref(model.nq(), model.nv());
  const double dt = options.dt_s;
  const double mu = model.environment().ground.friction;
  ClipRun run;
  for (std::size_t segment = 0; segment + 1 < frames.size(); ++segment) {
    for (int s = 0; s < substeps; ++s) {
      const double t = frames[segment].time_s + s * dt;
      interpolateReference(true, frames[segment], frames[segment + 1], t, ref);
      const FilterOutput& out = filter.step(ref);
      ++run.ticks;
      run.status_union |= out.status;
      run.check.add(filter, out, model.info(), mu);
      for (int i = 0; i < out.num_contacts; ++i) {
        const double fz = out.contacts[static_cast<std::size_t>(i)].normal_force_n;
        run.min_normal_n = std::min(run.min_normal_n, fz);
        if (fz < 0.0) {
          ++run.pulling_ticks;
          break;
        }
      }
    }
  }
  run.counters = filter.output().counters;
  return run;
}

std::vector<ReferenceFrame> retargetedClipStart(IDynamicsModel& model, const std::string& name,
                                                const std::string& bvh_file, double seconds) {
  // As tests/io/retarget_test.cpp reads a shipped clip: the mapping's scale, then retarget.
  const io::RetargetMapping mapping =
      io::readRetargetMapping(test::sourcePath("data/mocap/cmu/mappings/" + name + ".yaml"));
  io::BvhReadOptions read_options;
  read_options.length_scale = mapping.length_scale;
  const io::BvhMotion bvh = io::readBvh(test::sourcePath("data/mocap/cmu/" + bvh_file), read_options);
  std::vector<ReferenceFrame> frames = io::retargetBvh(bvh, mapping, model).motion.frames;
  std::size_t n = 0;
  while (n < frames.size() && frames[n].time_s <= seconds + 1e-9) ++n;
  frames.resize(n);
  return frames;
}

TEST(QpModeClip, KickInQpModeKeepsEveryContactPhysicalWherePaperModePulls) {
  auto model = humanFigure();
  const ModelInfo& info = model->info();
  const auto frames = retargetedClipStart(*model, "10_01", "10_01_soccer_kick.bvh", 2.5);
  ASSERT_GE(frames.size(), 200u);
  const double period = frames[1].time_s - frames[0].time_s;
  const int substeps = 4;  // 480 Hz on the 120 Hz clip, as dynfilter-offline does
  const double weight = info.total_mass * kStandardGravity;

  FilterOptions qp = test::qpDefaults(period / substeps);
  const ClipRun q = filterClip(*model, frames, substeps, qp);
  FilterOptions paper = qp;
  paper.mode = FilterMode::kPaper;
  const ClipRun p = filterClip(*model, frames, substeps, paper);

  RecordProperty("qp_min_normal_force_n", sci(q.check.min_normal_n));
  RecordProperty("paper_min_normal_force_n", sci(p.min_normal_n));
  RecordProperty("paper_pulling_ticks", p.pulling_ticks);
  RecordProperty("qp_relaxed_ticks", static_cast<int>(q.counters.qp_relaxed));
  RecordProperty("qp_max_base_residual_n", sci(q.check.max_base_residual_n));

  // What the QP mode is for: paper mode's bilateral links pull on the ground here.
  EXPECT_GT(p.pulling_ticks, 0) << "paper mode's smallest normal force " << p.min_normal_n;

  EXPECT_GT(q.check.contact_ticks, q.ticks / 2) << "the figure stands on the ground";
  EXPECT_EQ(q.status_union & (kStatusQpFallback | kStatusNonFinite), 0u)
      << "status union " << q.status_union;
  EXPECT_GE(q.check.min_normal_n, qp.qp.min_normal_force_n - 1e-6);
  EXPECT_LE(q.check.max_friction_excess, 1e-6);
  EXPECT_GT(q.check.cop_checked, 0);
  EXPECT_LE(q.check.max_cop_excess_m, 1e-6);
  EXPECT_LE(q.check.max_torsion_excess, 1e-6);
  EXPECT_LE(q.check.max_torque_excess, 1e-6);
  EXPECT_LE(q.check.max_base_residual_n, 1e-8 * weight);
  EXPECT_EQ(q.counters.ticks, static_cast<std::uint64_t>(q.ticks));
  EXPECT_EQ(q.counters.ticks, q.counters.qp_solves + q.counters.qp_fallbacks);
  EXPECT_EQ(q.counters.qp_fallbacks, 0u);
}

// Forwards to an engine; with @p cold every solve starts cold (the answers warm starts
// must reproduce), else counts the cold starts and restarts the filter asks for.
class CountingSolver final : public IQpSolver {
 public:
  CountingSolver(std::unique_ptr<IQpSolver> inner, bool cold) : inner_(std::move(inner)), cold_(cold) {}
  QpSolveInfo solve(const DenseQp& problem, Eigen::Ref<Eigen::VectorXd> x) override {
    if (cold_) inner_->resetWarmStart();
    return inner_->solve(problem, x);
  }
  QpSolveInfo resolveWithNewBounds(const DenseQp& problem, Eigen::Ref<Eigen::VectorXd> x) override {
    if (cold_) return solve(problem, x);
    return inner_->resolveWithNewBounds(problem, x);
  }
  void resetWarmStart() override {
    ++resets;
    inner_->resetWarmStart();
  }
  void restartFromLastSolution() override {
    ++restarts;
    inner_->restartFromLastSolution();
  }
  const char* name() const override { return "counting"; }
  int resets = 0, restarts = 0;

 private:
  std::unique_ptr<IQpSolver> inner_;
  bool cold_;
};

TEST(QpModeClip, AContactChangeRestartsFromTheLastWorkingSetWithTheColdAnswer) {
  // A tick whose contact set differs from the last one's (a link made, released, or
  // pivoting) starts from the last answer's working set, not cold, and gets the answer of
  // cold solves (a strictly convex QP). Working-set changes saved: BENCHMARKS.md.
  auto model = humanFigure();
  const auto frames = retargetedClipStart(*model, "01_01", "01_01_forward_jumps.bvh", 4.0);
  const int substeps = 4;
  const FilterOptions options = test::qpDefaults((frames[1].time_s - frames[0].time_s) / substeps);
  const QpSolverFactory daqp = qp_engines::factory("daqp");
  std::vector<CountingSolver*> engines;  // owned by the filter
  DynamicsFilter warm(*model, options, [&](int n, int n_eq, int n_in, const QpSolverSettings& settings) {
    auto engine = std::make_unique<CountingSolver>(daqp(n, n_eq, n_in, settings), false);
    engines.push_back(engine.get());
    return engine;
  });
  DynamicsFilter cold(*model, options, [&](int n, int n_eq, int n_in, const QpSolverSettings& settings) {
    return std::make_unique<CountingSolver>(daqp(n, n_eq, n_in, settings), true);
  });
  warm.reset(frames.front());
  cold.reset(frames.front());
  ReferenceFrame ref(model->nq(), model->nv());
  const double dt = options.dt_s;
  int contact_changes = 0;
  long warm_iterations = 0, cold_iterations = 0;
  double max_q_difference = 0.0;
  std::vector<int> last_bodies;
  for (std::size_t segment = 0; segment + 1 < frames.size(); ++segment) {
    for (int s = 0; s < substeps; ++s) {
      interpolateReference(true, frames[segment], frames[segment + 1], frames[segment].time_s + s * dt, ref);
      const FilterOutput& w = warm.step(ref);
      const FilterOutput& c = cold.step(ref);
      ASSERT_EQ(w.status, c.status) << "t " << w.time_s;
      max_q_difference = std::max(max_q_difference, (w.q - c.q).cwiseAbs().maxCoeff());
      warm_iterations += w.qp_iterations;
      cold_iterations += c.qp_iterations;
      std::vector<int> bodies;
      for (int i = 0; i < w.num_contacts; ++i) bodies.push_back(w.contacts[static_cast<std::size_t>(i)].body);
      contact_changes += bodies != last_bodies ? 1 : 0;
      last_bodies = bodies;
    }
  }
  int resets = 0, restarts = 0;
  for (const CountingSolver* engine : engines) {
    resets += engine->resets;
    restarts += engine->restarts;
  }
  RecordProperty("contact_changes", contact_changes);
  RecordProperty("restarts", restarts);
  RecordProperty("warm_working_set_changes", static_cast<int>(warm_iterations));
  RecordProperty("cold_working_set_changes", static_cast<int>(cold_iterations));
  ASSERT_GE(contact_changes, 10) << "the jumps make and release links";
  EXPECT_EQ(resets, 0) << "no tick starts cold";
  EXPECT_GE(restarts, contact_changes);
  EXPECT_LE(max_q_difference, 1e-8);
  EXPECT_LT(warm_iterations, cold_iterations / 2);
}

// ---------------------------------------------------------------------------------------
// Failures of the QP never pass silently

// Forwards to ProxQP, then lies: reports infeasibility, or "solved" with a zero x.
class FaultySolver final : public IQpSolver {
 public:
  enum class Fault { kReportInfeasible, kZeroSolution };
  FaultySolver(std::unique_ptr<IQpSolver> inner, Fault fault) : inner_(std::move(inner)), fault_(fault) {}
  QpSolveInfo solve(const DenseQp& problem, Eigen::Ref<Eigen::VectorXd> x) override {
    QpSolveInfo info = inner_->solve(problem, x);
    if (fault_ == Fault::kReportInfeasible) {
      info.status = QpSolveStatus::kPrimalInfeasible;
    } else {
      x.setZero();
      info.status = QpSolveStatus::kSolved;
      info.primal_residual = 0.0;
    }
    return info;
  }
  void resetWarmStart() override { inner_->resetWarmStart(); }
  const char* name() const override { return "faulty"; }

 private:
  std::unique_ptr<IQpSolver> inner_;
  Fault fault_;
};

QpSolverFactory faultyFactory(FaultySolver::Fault fault) {
  return [fault](int n, int n_eq, int n_in, const QpSolverSettings& settings) {
    return std::make_unique<FaultySolver>(proxqp::makeSolver(n, n_eq, n_in, settings), fault);
  };
}

// Runs the filter with @p factory and checks every tick falls back visibly, with torques
// within their limits and Eq. 12 holding for what is published.
void expectVisibleFallbackOnEveryTick(IDynamicsModel& model, const std::vector<ReferenceFrame>& frames,
                                      const QpSolverFactory& factory, std::uint32_t expected_violated,
                                      std::uint32_t* status_union_out) {
  const ModelInfo& info = model.info();
  const double weight = info.total_mass * kStandardGravity;
  DynamicsFilter filter(model, test::qpDefaults(1e-3), factory);
  filter.reset(frames.front());
  std::uint32_t status_union = 0;
  double max_base_residual = 0.0, max_eq12_residual = 0.0;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const FilterOutput& out = filter.step(frames[k]);
    status_union |= out.status;
    ASSERT_TRUE(out.status & kStatusQpFallback) << "tick " << k << " status " << out.status;
    ASSERT_EQ(out.status & kStatusNonFinite, 0u) << "tick " << k;
    if (expected_violated == 0u) {
      EXPECT_EQ(out.qp_status, static_cast<int>(QpSolveStatus::kPrimalInfeasible)) << "tick " << k;
    } else {
      EXPECT_EQ(out.qp_violated & expected_violated, expected_violated)
          << "tick " << k << " violated " << out.qp_violated;
    }
    for (int j = 0; j < info.nj; ++j)
      ASSERT_LE(std::abs(out.tau_J[j]), info.tau_max[j] + 1e-9) << "joint " << j << " tick " << k;
    max_base_residual = std::max(max_base_residual, out.base_residual_n);
    max_eq12_residual = std::max(max_eq12_residual, out.eq12_residual);
  }
  const FilterCounters& c = filter.output().counters;
  EXPECT_EQ(c.ticks, static_cast<std::uint64_t>(frames.size()));
  EXPECT_EQ(c.qp_fallbacks, c.ticks);
  EXPECT_EQ(c.qp_solves, 0u);
  EXPECT_LE(max_base_residual, 1e-8 * weight);
  EXPECT_LE(max_eq12_residual, 1e-6);
  if (status_union_out) *status_union_out = status_union;
}

class QpModeRelaxationOnEngines : public ::testing::TestWithParam<const char*> {};

// Two boards hinged together: board b, raised, comes down beside board a and both lie
// flat. Their two face links' 12 rows constrain a body of 7 DoF: dependent rows, whose
// targets disagree once the links have their own errors, so that no answer holds every
// row (DAQP stops before its first iteration). The impact is taken on the independent
// rows, and the QP frees the dependent ones; the boards lie on the floor. (Before, the
// impact was skipped and the contacts were released outright: the boards fell through
// the floor, 0.5 m in 0.35 s.)
TEST_P(QpModeRelaxationOnEngines, TwoHingedBoardsLandAndLieOnTheFloorNotInIt) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::testModelPath("hinged_plank.urdf")),
                               ModelOptions{});
  const ModelInfo& info = model->info();
  ReferenceFrame lying, lifted;
  test::hingedBoardsLyingAndLifted(*model, lying, lifted);
  ASSERT_NEAR(lying.q[2], 0.025, 1e-6);
  DynamicsFilter filter(*model, test::qpDefaults(1e-3), qp_engines::factory(GetParam()));
  filter.reset(lifted);
  PhysicsCheck check;
  std::uint32_t relaxations = 0;
  double max_penetration = 0.0, lowest_base = lying.q[2];
  for (int k = 0; k < 500; ++k) {
    lying.time_s = k * 1e-3;
    const FilterOutput& out = filter.step(lying);
    ASSERT_EQ(out.status & (kStatusQpFallback | kStatusNonFinite | kStatusReseeded), 0u) << "tick " << k;
    relaxations |= out.qp_relaxation;
    check.add(filter, out, info, model->environment().ground.friction);
    max_penetration = std::max(max_penetration, out.max_penetration_m);
    lowest_base = std::min(lowest_base, out.q[2]);
  }
  const FilterOutput& last = filter.output();
  EXPECT_NEAR(last.q[info.configurationIndex(info.findJoint("hinge"))], 0.0, 0.005) << "board b lies flat";
  double carried = 0.0;
  for (int i = 0; i < last.num_contacts; ++i) carried += last.contacts[static_cast<std::size_t>(i)].normal_force_n;
  EXPECT_NEAR(carried, info.total_mass * kStandardGravity, 0.02 * info.total_mass * kStandardGravity);
  EXPECT_EQ(relaxations & 4u, 0u) << "no tick released every contact (relaxation bits " << relaxations << ")";
  EXPECT_LE(max_penetration, 0.002);
  EXPECT_LE(check.max_cop_excess_m, 1e-6);
  EXPECT_GE(lowest_base, lying.q[2] - 0.002);
  EXPECT_GE(check.min_normal_n, 0.0);
  EXPECT_LE(check.max_friction_excess, 1e-6);
  EXPECT_LE(check.max_torque_excess, 1e-6);
  EXPECT_LE(check.max_base_residual_n, 1e-8 * info.total_mass * kStandardGravity);
  if (std::string(GetParam()) == "daqp") {
    EXPECT_TRUE(relaxations & 8u) << "the dependent rows were freed: " << relaxations;
  }
}

INSTANTIATE_TEST_SUITE_P(Engines, QpModeRelaxationOnEngines, ::testing::Values("daqp", "proxqp"));

TEST(QpModeFallback, ReportedInfeasibilityFallsBackVisiblyAndEq12Holds) {
  auto model = humanFigure();
  const auto frames = test::simulateStandingSway(*model, 0.15, 1e-3);  // < max_degraded_ticks
  expectVisibleFallbackOnEveryTick(*model, frames, faultyFactory(FaultySolver::Fault::kReportInfeasible),
                                   0u, nullptr);
}

TEST(QpModeFallback, WeakFigureFallbackClampsTorquesAndReSolvesEq14) {
  // Efforts of 5 N m cannot hold a squat: the paper solve's torques exceed them, so the
  // fallback clamps (kStatusTorqueClamped) and re-solves Eq. 14 with the clamped torques.
  const std::string path = testing::TempDir() + "/qp_weak_figure.urdf";
  std::string text;
  {
    std::FILE* in = std::fopen(test::humanFigurePath().c_str(), "rb");
    ASSERT_NE(in, nullptr);
    char buffer[4096];
    std::size_t n;
    while ((n = std::fread(buffer, 1, sizeof buffer, in)) > 0) text.append(buffer, n);
    std::fclose(in);
  }
  for (std::size_t at = text.find("effort=\""); at != std::string::npos;
       at = text.find("effort=\"", at + 1)) {
    const std::size_t end = text.find('"', at + 8);
    text.replace(at + 8, end - (at + 8), "5");
  }
  {
    std::FILE* out = std::fopen(path.c_str(), "wb");
    ASSERT_NE(out, nullptr);
    std::fwrite(text.data(), 1, text.size(), out);
    std::fclose(out);
  }
  auto model = test::makeModel("dart", urdf::loadUrdfFile(path), ModelOptions{});
  ASSERT_DOUBLE_EQ(model->info().tau_max.maxCoeff(), 5.0);
  ReferenceFrame hold = standingReference(*model);
  std::vector<ReferenceFrame> frames(100, hold);
  for (std::size_t k = 0; k < frames.size(); ++k) frames[k].time_s = 1e-3 * k;
  std::uint32_t status_union = 0;
  expectVisibleFallbackOnEveryTick(*model, frames, faultyFactory(FaultySolver::Fault::kReportInfeasible),
                                   0u, &status_union);
  EXPECT_TRUE(status_union & kStatusTorqueClamped) << status_union;
}

TEST(QpModeFallback, SolvedWithAWrongAnswerIsCaughtByTheCheck) {
  // "Solved" with x = 0: v̇ = 0, τ_C = 0 cannot satisfy the base rows under gravity
  // (b_b ≠ 0), so check() flags the equality family and no relaxation can rescue it.
  auto model = humanFigure();
  const auto frames = test::simulateStandingSway(*model, 0.15, 1e-3);  // < max_degraded_ticks
  expectVisibleFallbackOnEveryTick(*model, frames, faultyFactory(FaultySolver::Fault::kZeroSolution),
                                   kQpFamilyEquality, nullptr);
}

// ---------------------------------------------------------------------------------------
// Release ramp: a foot the reference lifts hands its load over at the ramp's rate
//
// The ramp is an upper bound on the lifted link's normal force (normalForceUpperBound): it
// forces the load off a foot the QP would otherwise keep loading. It does not stop the QP
// from unloading a foot faster by itself: with the default joint gains and a reference
// that flexes the leg, the QP drops the sole to min_normal_force_n within a tick of the
// lift's start and the link leaves by the release_ticks rule before the clearance is
// reached. So the reference here is poses only (v = v̇ = 0) with weak joint feedback: the
// lift itself asks for little, the sole stays loaded until the reference is
// liftoff_clearance_m up, and the ramp is what unloads it.

// The figure shifts its pelvis over the right sole (hip and ankle rolls as a
// parallelogram; the soles stay where they stood), then flexes the left leg so that the
// left sole rises @p lift_m over @p lift_s (quintic), and holds. Poses only.
std::vector<ReferenceFrame> liftLeftFootReference(IDynamicsModel& model, double dt, double lift_m,
                                                  double lift_s) {
  const ModelInfo& info = model.info();
  const ReferenceFrame stand = standingReference(model);
  const int r_foot = info.findBody("r_foot"), l_foot = info.findBody("l_foot");
  auto index = [&info](const std::string& joint) {
    return info.configurationIndex(info.findJoint(joint));
  };
  const Eigen::VectorXd zero_v = Eigen::VectorXd::Zero(info.nv);
  model.setState(stand.q, zero_v);
  const Eigen::Vector3d r_foot0 = model.bodyPose(r_foot).translation();
  const Eigen::Vector3d l_foot0 = model.bodyPose(l_foot).translation();

  // Pose at leg roll @p roll and left-leg flex @p flex, the base placed so that the right
  // sole is where it stood.
  auto pose = [&](double roll, double flex) {
    Eigen::VectorXd q = stand.q;
    for (const char* side : {"l_", "r_"}) {
      const std::string p = side;
      q[index(p + "hip_roll")] = roll;
      q[index(p + "ankle_roll")] = -roll;
    }
    q[index("l_hip_pitch")] += -flex;
    q[index("l_knee")] += 2.0 * flex;
    q[index("l_ankle_pitch")] += -flex;
    model.setState(q, zero_v);
    q.head<3>() += r_foot0 - model.bodyPose(r_foot).translation();
    return q;
  };
  // The roll that puts the pelvis over the right sole, and the flex that lifts the left
  // sole by lift_m (both by bisection).
  auto pelvis_offset = [&](double roll) { return pose(roll, 0.0)[1] - r_foot0.y(); };
  double lo = -0.3, hi = 0.3;
  if (pelvis_offset(lo) > pelvis_offset(hi)) std::swap(lo, hi);
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    (pelvis_offset(mid) < 0.0 ? lo : hi) = mid;
  }
  const double roll_star = 0.5 * (lo + hi);
  auto sole_rise = [&](double flex) {
    model.setState(pose(roll_star, flex), zero_v);
    return model.bodyPose(l_foot).translation().z() - l_foot0.z();
  };
  double flo = 0.0, fhi = 0.8;
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (flo + fhi);
    (sole_rise(mid) < lift_m ? flo : fhi) = mid;
  }
  const double flex_star = 0.5 * (flo + fhi);
  EXPECT_NEAR(sole_rise(flex_star), lift_m, 1e-6);

  auto smooth = [](double x) {  // 0 → 1 with zero slope and curvature at both ends
    x = std::clamp(x, 0.0, 1.0);
    return x * x * x * (10.0 + x * (-15.0 + 6.0 * x));
  };
  const double settle_s = 0.3, shift_s = 1.0, hold_s = 0.3, after_s = 0.3;
  const double lift_start_s = settle_s + shift_s + hold_s;
  const int n = static_cast<int>(std::lround((lift_start_s + lift_s + after_s) / dt));
  std::vector<ReferenceFrame> frames(static_cast<std::size_t>(n), ReferenceFrame(info.nq, info.nv));
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    ReferenceFrame& f = frames[static_cast<std::size_t>(k)];
    f.time_s = t;
    f.q = pose(smooth((t - settle_s) / shift_s) * roll_star,
               smooth((t - lift_start_s) / lift_s) * flex_star);
  }
  return frames;
}

struct RampRun {
  double start_force_n = 0.0;        // the left sole's force when its ramp began
  double max_drop_rate = 0.0;        // N/s, largest tick-to-tick decrease during the ramp
  double max_bound_excess = -1e300;  // force − the linear ramp bound (≤ 0: under it)
  double max_bound_gap = 0.0;        // bound − force after the first ramp tick
  double last_force_n = 0.0;         // on the last tick before release
  int ramp_ticks = 0;                // ticks of the ramp, the release tick included
  int release_tick = -1;
  int released_early = 0;            // left sole released before any ramp started
  std::uint32_t status_union = 0;
  std::uint64_t links_released = 0;
  int links_before = 0, links_after = 0;
};

RampRun runRamp(double transition_s) {
  auto model = humanFigure();
  const ModelInfo& info = model->info();
  const double dt = 1e-3;
  const auto frames = liftLeftFootReference(*model, dt, 0.05, 0.2);
  FilterOptions options = test::qpDefaults(dt);
  options.qp.release_transition_s = transition_s;
  options.feedback.joint_kp = 4.0;  // weak: see above
  options.feedback.joint_kd = 4.0;
  DynamicsFilter filter(*model, options, qp_engines::factory(QpSolverSettings{}.engine));
  filter.reset(frames.front());
  const int l_foot = info.findBody("l_foot");
  const double f_min = options.qp.min_normal_force_n;
  RampRun run;
  int first_ramp_tick = -1;
  double previous = 0.0;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const int links_before = filter.links().size();
    const std::uint64_t released_before = filter.output().counters.links_released;
    const FilterOutput& out = filter.step(frames[k]);
    run.status_union |= out.status;
    double force = std::nan("");
    for (int i = 0; i < out.num_contacts; ++i)
      if (out.contacts[static_cast<std::size_t>(i)].body == l_foot)
        force = out.contacts[static_cast<std::size_t>(i)].normal_force_n;
    for (int i = 0; i < filter.links().size(); ++i) {
      const VirtualLink& link = filter.links()[i];
      if (link.body != l_foot || !link.releasing) continue;
      if (first_ramp_tick < 0) {  // the force of the tick before the ramp
        first_ramp_tick = static_cast<int>(k);
        run.start_force_n = link.release_start_force_n;
        previous = link.release_start_force_n;
      }
    }
    const bool released_now = out.counters.links_released > released_before;
    if (released_now && first_ramp_tick < 0) ++run.released_early;
    if (first_ramp_tick >= 0 && run.release_tick < 0 && !std::isnan(force)) {
      const int i = static_cast<int>(k) - first_ramp_tick;
      const double bound = std::max(f_min, run.start_force_n * (1.0 - i * dt / transition_s));
      run.max_bound_excess = std::max(run.max_bound_excess, force - bound);
      // On the ramp's first tick the bound is the previous tick's force, which the force
      // may already be under; from the second on the bound binds.
      if (i > 0) run.max_bound_gap = std::max(run.max_bound_gap, bound - force);
      run.max_drop_rate = std::max(run.max_drop_rate, (previous - force) / dt);
      previous = force;
      run.last_force_n = force;
      ++run.ramp_ticks;
      if (released_now) {
        run.release_tick = static_cast<int>(k);
        run.links_before = links_before;
        run.links_after = filter.links().size();
      }
    }
  }
  run.links_released = filter.output().counters.links_released;
  return run;
}

void expectRamp(const RampRun& run, double transition_s) {
  const double dt = 1e-3, f_min = QpModeOptions{}.min_normal_force_n;
  EXPECT_EQ(run.released_early, 0) << "the left sole left before its ramp";
  ASSERT_GE(run.release_tick, 0) << "the left sole's ramp never ended in a release";
  EXPECT_EQ(run.status_union & (kStatusQpFallback | kStatusQpRelaxed | kStatusNonFinite), 0u)
      << run.status_union;
  // The sole still carried a good part of the weight when the reference was 2 cm up.
  EXPECT_GT(run.start_force_n, 50.0);
  // The force stays under the linear ramp F0 (1 − t/T), rides it (the ramp is what
  // unloads the sole here), and so decreases no faster than F0/T.
  EXPECT_LE(run.max_bound_excess, 1e-6);
  EXPECT_LE(run.max_bound_gap, 1e-3);
  EXPECT_LE(run.max_drop_rate, run.start_force_n / transition_s + 1e-3 / dt);
  // Duration T, to a tick (the elapsed time is summed tick by tick).
  EXPECT_NEAR(run.ramp_ticks * dt, transition_s, 1.01 * dt);
  // The link leaves after the solve at which the bound reached f_min: its last force is
  // the minimum, so the release itself is a step of at most f_min.
  EXPECT_NEAR(run.last_force_n, f_min, 1e-3);
  EXPECT_EQ(run.links_after, run.links_before - 1);
  EXPECT_EQ(run.links_after, 1) << "the right sole stays";
  EXPECT_GE(run.links_released, 1u);
}

TEST(QpModeReleaseRamp, LiftedFootHandsItsLoadOverAtTheRampRate) {
  const RampRun fast = runRamp(0.05);
  const RampRun slow = runRamp(0.1);
  RecordProperty("fast_start_force_n", sci(fast.start_force_n));
  RecordProperty("fast_ramp_s", sci(fast.ramp_ticks * 1e-3));
  RecordProperty("fast_last_force_n", sci(fast.last_force_n));
  RecordProperty("fast_max_drop_rate", sci(fast.max_drop_rate));
  RecordProperty("fast_max_bound_gap_n", sci(fast.max_bound_gap));
  RecordProperty("slow_start_force_n", sci(slow.start_force_n));
  RecordProperty("slow_ramp_s", sci(slow.ramp_ticks * 1e-3));
  RecordProperty("slow_last_force_n", sci(slow.last_force_n));
  RecordProperty("slow_max_drop_rate", sci(slow.max_drop_rate));
  {
    SCOPED_TRACE("release_transition_s 0.05");
    expectRamp(fast, 0.05);
  }
  {
    SCOPED_TRACE("release_transition_s 0.1");
    expectRamp(slow, 0.1);
  }
  // Twice the transition: twice the duration (±1 tick each), half the rate.
  ASSERT_GT(fast.ramp_ticks, 0);
  EXPECT_NEAR(static_cast<double>(slow.ramp_ticks) / fast.ramp_ticks, 2.0, 0.05);
  EXPECT_NEAR(slow.max_drop_rate / fast.max_drop_rate, 0.5 * slow.start_force_n / fast.start_force_n,
              0.02);
}

// With the default (stiff) feedback the solver would rather drop the lifting sole at once
// (measured before the unloading-rate bound: 341 N to 1 N in one tick, then released).
// Every held sole now unloads no faster than max(weight, ramp start force) / T.
TEST(QpModeReleaseRamp, NoSoleUnloadsFasterThanTheRateBoundWithDefaultGains) {
  auto model = humanFigure();
  const ModelInfo& info = model->info();
  const double dt = 1e-3;
  const auto frames = liftLeftFootReference(*model, dt, 0.05, 0.2);
  FilterOptions options = test::qpDefaults(dt);
  DynamicsFilter filter(*model, options, qp_engines::factory(QpSolverSettings{}.engine));
  filter.reset(frames.front());
  const double weight = info.total_mass * 9.81, T = options.qp.release_transition_s;
  const int feet[2] = {info.findBody("l_foot"), info.findBody("r_foot")};
  double previous[2] = {std::nan(""), std::nan("")};
  double worst_rate_ratio = 0.0, largest_drop = 0.0;
  std::uint32_t status_union = 0;
  for (const ReferenceFrame& frame : frames) {
    const FilterOutput& out = filter.step(frame);
    status_union |= out.status;
    for (int f = 0; f < 2; ++f) {
      double force = std::nan(""), start = 0.0;
      for (int i = 0; i < out.num_contacts; ++i)
        if (out.contacts[static_cast<std::size_t>(i)].body == feet[f])
          force = out.contacts[static_cast<std::size_t>(i)].normal_force_n;
      for (int i = 0; i < filter.links().size(); ++i)
        if (filter.links()[i].body == feet[f]) start = filter.links()[i].release_start_force_n;
      if (!std::isnan(force) && !std::isnan(previous[f]) && !(out.status & kStatusImpact)) {
        const double drop = previous[f] - force;
        largest_drop = std::max(largest_drop, drop);
        worst_rate_ratio = std::max(worst_rate_ratio, drop / (std::max(weight, start) / T * dt));
      }
      previous[f] = force;  // NaN once released: the next contact starts a new series
    }
  }
  RecordProperty("largest_one_tick_drop_n", std::to_string(largest_drop));
  EXPECT_LE(worst_rate_ratio, 1.0 + 1e-6) << "largest one-tick drop " << largest_drop << " N";
  EXPECT_GT(largest_drop, 1.0) << "the sole did unload";
  EXPECT_EQ(status_union & (kStatusQpFallback | kStatusNonFinite), 0u) << status_union;
}

}  // namespace
}  // namespace dynfilter
