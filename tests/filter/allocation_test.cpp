// No heap allocation in the filter's per-tick path. This executable replaces the global
// operator new to count allocations while a flag is set. The model is wrapped in a
// forwarding decorator that pauses counting inside backend calls, so the count is the
// core's own; what the backend (DART) allocates inside its calls is counted separately
// and reported as a test property.
#include <atomic>
#include <cstdlib>
#include <new>

#include <gtest/gtest.h>

#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/dynamics_simulator.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/reference_motions.hpp"
#include "support/test_support.hpp"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<bool> g_in_backend{false};
std::atomic<long> g_core_allocations{0};
std::atomic<long> g_backend_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed))
    (g_in_backend.load(std::memory_order_relaxed) ? g_backend_allocations : g_core_allocations)++;
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

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

TEST(Allocation, FilterStepAllocatesNothingInTheCore) {
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
  g_core_allocations = 0;
  g_backend_allocations = 0;
  g_counting = true;
  for (const ReferenceFrame& f : lifted) seen |= filter.step(f).status;
  g_counting = false;
  EXPECT_TRUE(seen & kStatusImpact) << "the impact branch must have run";
  EXPECT_GT(filter.output().num_contacts, 0);
  EXPECT_EQ(g_core_allocations.load(), 0) << "heap allocations in the core's per-tick path";
  RecordProperty("backend_allocations_per_tick",
                 std::to_string(static_cast<double>(g_backend_allocations) / lifted.size()));
}

TEST(Allocation, CountingWorks) {
  // The counter must see an allocation, or the test above proves nothing.
  g_core_allocations = 0;
  g_counting = true;
  auto* p = new std::vector<double>(100);
  g_counting = false;
  delete p;
  EXPECT_GE(g_core_allocations.load(), 1);
}

TEST(Allocation, SimulatorStepAllocatesNothingInTheCore) {
  auto dart = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  MeasuredModel model(*dart);
  DynamicsSimulator sim(model, ContactOptions{}, 1e-3);
  Eigen::VectorXd q = dart->info().neutralConfiguration();
  q[2] = test::humanFigureStandingHeight() + 0.02;
  sim.reset(q, Eigen::VectorXd::Zero(dart->nv()));
  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(dart->nj());
  g_core_allocations = 0;
  g_counting = true;
  for (int k = 0; k < 200; ++k) sim.step(tau);
  g_counting = false;
  EXPECT_EQ(g_core_allocations.load(), 0);
}

}  // namespace
}  // namespace dynfilter

#include "dynfilter/realtime/realtime_filter.hpp"

namespace dynfilter {
namespace {

TEST(Allocation, RealtimeTickAndReferenceIntakeAllocateNothing) {
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
  g_core_allocations = 0;
  g_counting = true;
  for (int k = 50; k < 450; ++k) {
    const ReferenceFrame& f = frames[static_cast<std::size_t>(k)];
    if (k % 8 == 0) rt.addReference(f, 0.001 * k);
    rt.addMeasuredState(f.q, f.v, 0.001 * k);
    rt.tick(0.001 * k);
  }
  g_counting = false;
  EXPECT_EQ(g_core_allocations.load(), 0);
  EXPECT_TRUE(rt.command().allFinite());
}

}  // namespace
}  // namespace dynfilter
