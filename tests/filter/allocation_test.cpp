// No heap allocation in the filter's per-tick path. This executable replaces the global
// operator new and interposes glibc's malloc family, counting allocations while a flag is
// set: operator new (std::vector, std::string, ...) and direct malloc calls separately —
// Eigen's dynamic matrices and their temporaries allocate with std::malloc, which counting
// operator new alone never saw. The model is wrapped in a forwarding decorator that pauses
// counting inside backend calls, so the count is the core's own; what the backend (DART)
// allocates inside its calls is counted separately and reported as a test property.
#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <new>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/dynamics_simulator.hpp"
#include "dynfilter/core/ground_contacts.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"
#include "dynfilter/qp_engines/qp_engines.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/allocation_counter.hpp"
#include "support/reference_motions.hpp"
#include "support/test_support.hpp"

using dynfilter::test::allocations::g_backend_allocations;
using dynfilter::test::allocations::g_core_malloc;
using dynfilter::test::allocations::g_core_new;
using dynfilter::test::allocations::g_counting;
using dynfilter::test::allocations::g_in_backend;
using dynfilter::test::allocations::resetCounts;

namespace dynfilter {
namespace {

// Forwards every call; marks the time spent inside the backend.
class BackendScope {
 public:
  BackendScope() : previous_(g_in_backend.exchange(true)) {}
  ~BackendScope() { g_in_backend.store(previous_); }

 private:
  bool previous_;
};

class MeasuredModel final : public IDynamicsModel {
 public:
  explicit MeasuredModel(IDynamicsModel& inner) : inner_(inner) {}
  const ModelInfo& info() const override { return inner_.info(); }
  std::string_view backendName() const override { return inner_.backendName(); }
  const Environment& environment() const override { return inner_.environment(); }
  void setState(const Eigen::Ref<const Eigen::VectorXd>& q,
                const Eigen::Ref<const Eigen::VectorXd>& v) override {
    BackendScope s;
    inner_.setState(q, v);
  }
  const Eigen::VectorXd& q() const override { return inner_.q(); }
  const Eigen::VectorXd& v() const override { return inner_.v(); }
  Eigen::Isometry3d bodyPose(int body) const override {
    BackendScope s;
    return inner_.bodyPose(body);
  }
  Vector6d bodyVelocity(int body) const override {
    BackendScope s;
    return inner_.bodyVelocity(body);
  }
  void pointJacobian(int body, const Eigen::Vector3d& p, Eigen::Ref<Matrix6Xd> J) const override {
    BackendScope s;
    inner_.pointJacobian(body, p, J);
  }
  Vector6d pointJacobianDotTimesV(int body, const Eigen::Vector3d& p) const override {
    BackendScope s;
    return inner_.pointJacobianDotTimesV(body, p);
  }
  void massMatrix(Eigen::Ref<Eigen::MatrixXd> A) const override {
    BackendScope s;
    inner_.massMatrix(A);
  }
  void bias(Eigen::Ref<Eigen::VectorXd> b) const override {
    BackendScope s;
    inner_.bias(b);
  }
  void forwardDynamics(const Eigen::Ref<const Eigen::VectorXd>& tau,
                       Eigen::Ref<Eigen::VectorXd> vdot) const override {
    BackendScope s;
    inner_.forwardDynamics(tau, vdot);
  }
  void detectContacts(ContactList& out) const override {
    BackendScope s;
    inner_.detectContacts(out);
  }
  void simulateStep(const Eigen::Ref<const Eigen::VectorXd>& tau, double dt) override {
    BackendScope s;
    inner_.simulateStep(tau, dt);
  }

 private:
  IDynamicsModel& inner_;
};

// The core's allocations over @p ticks: none through operator new and none through malloc
// (Eigen's heap temporaries go through malloc; until they were counted, 15–19 per tick
// went unseen: rows assigned without noalias(), products divided by a scalar, and
// column-major matrices bound to ProxQP's row-major Ref — all fixed).
void expectNoCoreAllocations(long ticks) {
  const long by_new = g_core_new.load(), by_malloc = g_core_malloc.load();
  ::testing::Test::RecordProperty("core_new_per_tick",
                                  std::to_string(static_cast<double>(by_new) / ticks));
  ::testing::Test::RecordProperty("core_malloc_per_tick",
                                  std::to_string(static_cast<double>(by_malloc) / ticks));
  EXPECT_EQ(by_new, 0) << "operator new in the core's per-tick path over " << ticks << " ticks";
  EXPECT_EQ(by_malloc, 0) << "malloc (Eigen temporaries) in the core's per-tick path over "
                          << ticks << " ticks";
}

TEST(Allocation, FilterStepAllocatesNothingInTheCore) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  auto dart = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const auto frames = test::simulateStandingSway(*dart, 0.4, 1e-3);
  MeasuredModel model(*dart);
  DynamicsFilter filter(model, FilterOptions{});
  filter.reset(frames.front());
  for (int k = 0; k < 20; ++k) filter.step(frames[static_cast<std::size_t>(k)]);  // warm up

  // Lift the reference by 3 cm for the rest: the figure falls, lands (new links, plastic
  // impact) and stands — every branch of a tick runs while counting.
  std::vector<ReferenceFrame> lifted(frames.begin() + 20, frames.end());
  for (auto& f : lifted) f.q[2] += 0.03;
  filter.reset(lifted.front());
  std::uint32_t seen = 0;
  resetCounts();
  g_counting = true;
  for (const ReferenceFrame& f : lifted) seen |= filter.step(f).status;
  g_counting = false;
  EXPECT_TRUE(seen & kStatusImpact) << "the impact branch must have run";
  EXPECT_GT(filter.output().num_contacts, 0);
  RecordProperty("backend_allocations_per_tick",
                 std::to_string(static_cast<double>(g_backend_allocations) / lifted.size()));
  expectNoCoreAllocations(static_cast<long>(lifted.size()));
}

// The QP mode on the standing figure (two face links, the 12-slot size class), with each
// QP engine. The engine is not a backend: what it allocates inside solve() counts as the
// core's.
class AllocationQp : public ::testing::TestWithParam<const char*> {};

TEST_P(AllocationQp, QpModeSteadyStateTickAllocatesNothingInTheCore) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  auto dart = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const auto frames = test::simulateStandingSway(*dart, 0.4, 1e-3);
  MeasuredModel model(*dart);
  FilterOptions options;
  options.mode = FilterMode::kQp;
  DynamicsFilter filter(model, options, qp_engines::factory(GetParam()));
  filter.reset(frames.front());
  for (int k = 0; k < 50; ++k) filter.step(frames[static_cast<std::size_t>(k)]);  // warm up
  std::uint32_t seen = 0;
  std::uint64_t iterations_before = filter.output().counters.qp_iterations;
  resetCounts();
  g_counting = true;
  // With the balance layer's look-ahead fed as on-line (a frame ahead every tick).
  std::size_t previewed = 50;
  int most_preview_samples = 0;
  for (std::size_t k = 50; k < frames.size(); ++k) {
    while (previewed < frames.size() && previewed < k + 50) filter.previewFrame(frames[previewed++]);
    seen |= filter.step(frames[k]).status;
    most_preview_samples = std::max(most_preview_samples, filter.balance()->preview_samples);
  }
  g_counting = false;
  const long ticks = static_cast<long>(frames.size()) - 50;
  ASSERT_NE(filter.balance(), nullptr);
  EXPECT_TRUE(filter.balance()->active) << "the balance tasks ran";
  EXPECT_GT(most_preview_samples, 10) << "the look-ahead ran";
  EXPECT_EQ(filter.output().num_contacts, 2);
  EXPECT_EQ(seen & (kStatusQpFallback | kStatusQpRelaxed), 0u) << "the plain QP path ran";
  EXPECT_GT(filter.output().counters.qp_iterations, iterations_before) << "the solver iterated";
  expectNoCoreAllocations(ticks);
}

INSTANTIATE_TEST_SUITE_P(Engines, AllocationQp, ::testing::Values("daqp", "proxqp"));

// The reference leash moving the reference and the balance layer's preview on every tick
// (a reference that walks off at 0.5 m/s and turns at 1 rad/s while the figure stands).
TEST(Allocation, TheLeashAllocatesNothingInTheCore) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  auto dart = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  std::vector<ReferenceFrame> frames = test::simulateStandingSway(*dart, 0.4, 1e-3);
  test::walkOffAndTurn(frames, 0.5, 1.0);
  MeasuredModel model(*dart);
  FilterOptions options;
  options.mode = FilterMode::kQp;
  options.leash.enabled = true;
  DynamicsFilter filter(model, options, qp_engines::factory("daqp"));
  filter.reset(frames.front());
  for (int k = 0; k < 50; ++k) filter.step(frames[static_cast<std::size_t>(k)]);  // warm up
  const std::uint64_t leash_before = filter.output().counters.leash_ticks;
  resetCounts();
  g_counting = true;
  std::size_t previewed = 50;
  for (std::size_t k = 50; k < frames.size(); ++k) {
    while (previewed < frames.size() && previewed < k + 50) filter.previewFrame(frames[previewed++]);
    filter.step(frames[k]);
  }
  g_counting = false;
  EXPECT_GT(filter.output().counters.leash_ticks, leash_before + 100) << "the leash moved the reference";
  EXPECT_EQ(filter.output().counters.reseeds, 0u);
  expectNoCoreAllocations(static_cast<long>(frames.size()) - 50);
}

// The QP mode's relaxation: legs too weak (5 N m) to stand on bent knees make the QP with
// the joint-limit bounds infeasible; the bounds give way in a re-solve in which DAQP keeps
// its factorisations (IQpSolver::resolveWithNewBounds). The default engine only: ProxQP
// allocates inside proxsuite when an active-set change inserts several rows at once
// (2 mallocs over these 280 ticks, in Ldlt::insert_block_at; README, "QP mode").
TEST(Allocation, QpModeRelaxedTicksAllocateNothingInTheCoreWithDaqp) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  urdf::RobotDescription weak = urdf::loadUrdfFile(test::humanFigurePath());
  for (urdf::JointDesc& joint : weak.joints)
    if (joint.name.find("hip") != std::string::npos || joint.name.find("knee") != std::string::npos ||
        joint.name.find("ankle") != std::string::npos)
      joint.effort_max = 5.0;
  auto dart = test::makeModel("dart", weak, ModelOptions{});
  auto strong = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  // The sway with bent knees: standing on them asks for far more than 5 N m.
  auto frames = test::simulateStandingSway(*strong, 0.3, 1e-3);
  const ModelInfo& info = dart->info();
  for (ReferenceFrame& f : frames)
    for (const char* side : {"l_", "r_"}) {
      f.q[info.configurationIndex(info.findJoint(std::string(side) + "knee"))] += 0.6;
      f.q[info.configurationIndex(info.findJoint(std::string(side) + "hip_pitch"))] -= 0.3;
      f.q[info.configurationIndex(info.findJoint(std::string(side) + "ankle_pitch"))] -= 0.3;
    }
  MeasuredModel model(*dart);
  FilterOptions options;
  options.mode = FilterMode::kQp;
  ASSERT_TRUE(options.qp.enforce_joint_limits) << "the chain's middle solve needs the joint-limit bounds";
  DynamicsFilter filter(model, options, qp_engines::factory("daqp"));
  filter.reset(frames.front());
  for (int k = 0; k < 20; ++k) filter.step(frames[static_cast<std::size_t>(k)]);  // warm up
  std::uint32_t seen = 0, relaxations = 0;
  resetCounts();
  g_counting = true;
  for (std::size_t k = 20; k < frames.size(); ++k) {
    seen |= filter.step(frames[k]).status;
    relaxations |= filter.output().qp_relaxation;
  }
  g_counting = false;
  EXPECT_TRUE(seen & kStatusQpRelaxed) << "status union " << seen;
  EXPECT_TRUE(relaxations & 1u) << "the joint-limit bounds were dropped (relaxation bits " << relaxations << ")";
  EXPECT_EQ(seen & kStatusQpFallback, 0u);
  expectNoCoreAllocations(static_cast<long>(frames.size()) - 20);
}

// The floor's rungs (ContactQp): two hinged boards land side by side, their face links'
// rows dependent (12 rows, 7 DoF). The impact on the independent rows, the dependent rows
// freed and re-solved, tick after tick, with DAQP.
TEST(Allocation, DependentContactRowsAllocateNothingInTheCore) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  auto dart = test::makeModel("dart", urdf::loadUrdfFile(test::testModelPath("hinged_plank.urdf")),
                              ModelOptions{});
  ReferenceFrame lying, lifted;
  test::hingedBoardsLyingAndLifted(*dart, lying, lifted);
  MeasuredModel model(*dart);
  DynamicsFilter filter(model, test::qpDefaults(1e-3), qp_engines::factory("daqp"));
  filter.reset(lifted);
  for (int k = 0; k < 20; ++k) {  // warm up
    lying.time_s = k * 1e-3;
    filter.step(lying);
  }
  std::uint32_t seen = 0, relaxations = 0;
  resetCounts();
  g_counting = true;
  for (int k = 20; k < 300; ++k) {
    lying.time_s = k * 1e-3;
    seen |= filter.step(lying).status;
    relaxations |= filter.output().qp_relaxation;
  }
  g_counting = false;
  EXPECT_TRUE(seen & kStatusImpact) << "board b landed (status union " << seen << ")";
  EXPECT_TRUE(relaxations & 8u) << "the dependent rows were freed (relaxation bits " << relaxations << ")";
  expectNoCoreAllocations(280);
}

// Contacts that slide (QpModeOptions::tangential_slip): a box lands at 1 m/s along the
// ground while its reference flies above it (out of the schedule's stance). The landing
// slides through its impact (the impact's friction-cone test solves one impact more), then
// slows on kinetic friction until it sticks. After 20 ticks in the air, the landing, the
// slide and the stop are counted.
TEST(Allocation, SlidingContactsAllocateNothingInTheCore) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  auto dart = test::makeModel("dart", urdf::loadUrdfFile(test::testModelPath("floating_box.urdf")),
                              ModelOptions{});
  MeasuredModel model(*dart);
  const ModelInfo& info = model.info();
  const double dt = 1e-3;
  const int ticks = 200, warm_up = 20;
  Eigen::VectorXd q_touch(info.nq), v_land = Eigen::VectorXd::Zero(info.nv);
  q_touch << 0, 0, 0, 1, 0, 0, 0;
  q_touch[2] = standingBaseHeight(*dart, q_touch) - 2e-4;
  v_land[0] = 1.0;
  v_land[2] = -0.2;
  std::vector<ReferenceFrame> flying;  // thrown from 0.3 m above the ground, 1 m/s up
  for (int k = 0; k <= warm_up + ticks + 60; ++k) {
    ReferenceFrame ref(info.nq, info.nv);
    const double t = k * dt;
    ref.time_s = t;
    ref.q = q_touch;
    ref.q[0] = t;
    ref.q[2] += 0.3 + t - 0.5 * kStandardGravity * t * t;
    ref.v[0] = 1.0;
    ref.v[2] = 1.0 - kStandardGravity * t;
    ref.vdot[2] = -kStandardGravity;
    flying.push_back(ref);
  }
  FilterOptions options = test::qpDefaults(dt);
  options.qp.release_transition_s = 1.0;  // the box's link outlives the slide (see QpModeSlide)
  ASSERT_TRUE(options.qp.tangential_slip);
  DynamicsFilter filter(model, options, qp_engines::factory("daqp"));
  filter.reset(flying[0]);
  int previewed = 0, slides = 0, impacts = 0;
  Eigen::VectorXd q_high = q_touch;
  q_high[2] += 0.05;
  for (int k = 0; k < warm_up; ++k) {  // in the air: the solver's and the look-ahead's first runs
    ASSERT_TRUE(filter.setMeasuredState(q_high, v_land));
    while (previewed < k + 60) filter.previewFrame(flying[static_cast<std::size_t>(previewed++)]);
    ASSERT_EQ(filter.step(flying[static_cast<std::size_t>(k)]).num_contacts, 0);
  }
  ASSERT_TRUE(filter.setMeasuredState(q_touch, v_land));
  resetCounts();
  g_counting = true;
  for (int k = warm_up; k < warm_up + ticks; ++k) {
    while (previewed < k + 60) filter.previewFrame(flying[static_cast<std::size_t>(previewed++)]);
    const FilterOutput& out = filter.step(flying[static_cast<std::size_t>(k)]);
    impacts += (out.status & kStatusImpact) ? 1 : 0;
    slides += out.num_contacts > 0 && !out.contacts[0].slide_W.isZero() ? 1 : 0;
  }
  g_counting = false;
  EXPECT_GT(slides, 100) << "the box slid";
  EXPECT_EQ(impacts, 1) << "it landed";
  EXPECT_EQ(filter.output().num_contacts, 1);
  EXPECT_TRUE(filter.output().contacts[0].slide_W.isZero()) << "and stopped";
  expectNoCoreAllocations(ticks);
}

TEST(Allocation, HullGroundContactsAllocateNothing) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  // Both backends call this in every detectContacts: a 64-vertex hull, half below a slope.
  Eigen::Matrix3Xd p_SV(3, 64);
  for (int i = 0; i < 32; ++i)
    for (int ring = 0; ring < 2; ++ring)
      p_SV.col(2 * i + ring) << 0.1 * std::cos(i * 0.2), 0.05 * std::sin(i * 0.2), ring ? 0.02 : -0.02;
  const BodyHull hull = BodyHull::make(2, Eigen::Isometry3d::Identity(), p_SV);
  const GroundPlane ground = GroundPlane::sloped(0.1);
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
  X_WB.translation().z() = 0.015;
  ContactList out;
  resetCounts();
  g_counting = true;
  for (int k = 0; k < 100; ++k) {
    out.clear();
    appendHullGroundContacts(hull, X_WB, ground, out);
  }
  g_counting = false;
  EXPECT_GT(out.size(), 0u);
  EXPECT_EQ(g_core_new.load(), 0);
  EXPECT_EQ(g_core_malloc.load(), 0);
}

TEST(Allocation, CountingWorks) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  // The counter must see an allocation, or the test above proves nothing.
  resetCounts();
  g_counting = true;
  auto* p = new std::vector<double>(100);
  g_counting = false;
  delete p;
  EXPECT_GE(g_core_new.load(), 1);
  EXPECT_EQ(g_core_malloc.load(), 0);
  // Eigen's dynamic matrices allocate through std::malloc, not operator new.
  resetCounts();
  g_counting = true;
  {
    Eigen::MatrixXd m(7, 9);
    m.setOnes();
    const Eigen::MatrixXd product = m.transpose() * m;  // a temporary too
    EXPECT_EQ(product(0, 0), 7.0);
  }
  g_counting = false;
  EXPECT_GE(g_core_malloc.load(), 2);
  EXPECT_EQ(g_core_new.load(), 0);
}

TEST(Allocation, SimulatorStepAllocatesNothingInTheCore) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  auto dart = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  MeasuredModel model(*dart);
  DynamicsSimulator sim(model, ContactOptions{}, 1e-3);
  Eigen::VectorXd q = dart->info().neutralConfiguration();
  q[2] = test::humanFigureStandingHeight() + 0.02;
  sim.reset(q, Eigen::VectorXd::Zero(dart->nv()));
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(dart->nj());
  resetCounts();
  g_counting = true;
  for (int k = 0; k < 200; ++k) sim.step(tau);
  g_counting = false;
  expectNoCoreAllocations(200);
}

}  // namespace
}  // namespace dynfilter

#include "dynfilter/realtime/realtime_filter.hpp"

namespace dynfilter {
namespace {

TEST(Allocation, RealtimeTickAndReferenceIntakeAllocateNothing) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  auto dart = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const auto frames = test::simulateStandingSway(*dart, 0.5, 1e-3);
  MeasuredModel model(*dart);
  realtime::RealtimeOptions options;
  options.use_measured_state = true;
  realtime::RealtimeFilter rt(model, FilterOptions{}, options, frames.front());
  for (int k = 0; k < 50; ++k) {  // warm up
    rt.addReference(frames[static_cast<std::size_t>(k)], 0.001 * k);
    rt.tick(0.001 * k);
  }
  ReferenceFrame resumed = frames[450];
  resumed.time_s = 0.75;
  resetCounts();
  g_counting = true;
  for (int k = 50; k < 450; ++k) {
    const ReferenceFrame& f = frames[static_cast<std::size_t>(k)];
    if (k % 8 == 0) rt.addReference(f, 0.001 * k);
    rt.addMeasuredState(f.q, f.v, 0.001 * k, 0.001 * k);
    rt.tick(0.001 * k);
  }
  // Silence past the stale timeout, then the stream again: its hand-over (placement under
  // the robot, soft start) allocates nothing either.
  for (int k = 450; k < 750; ++k) rt.tick(0.001 * k);
  EXPECT_TRUE(rt.addReference(resumed, 0.75));
  rt.tick(0.75);
  g_counting = false;
  EXPECT_TRUE(rt.command().allFinite());
  EXPECT_FALSE(rt.stale());
  expectNoCoreAllocations(701);
}

}  // namespace
}  // namespace dynfilter
