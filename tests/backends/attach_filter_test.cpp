// The attached filter as a controller in the user's own simulation: the figure squats on
// its own feet while the user's world steps with its own contact solver, and the
// controller's per-tick path allocates nothing.
#include <cmath>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include <dart/collision/bullet/BulletCollisionDetector.hpp>
#include <dart/constraint/ConstraintSolver.hpp>
#include <dart/constraint/ContactConstraint.hpp>
#include <dart/dynamics/BoxShape.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <dart/dynamics/WeldJoint.hpp>
#include <dart/utils/urdf/DartLoader.hpp>

#include "dynfilter/dart/attached_filter.hpp"
#include "dynfilter/ode/attached_filter.hpp"
#include "dynfilter/qp_engines/qp_engines.hpp"
#include "figure_world.hpp"
#include "support/allocation_counter.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

struct SquatResult {
  double max_base_error_m = 0.0, max_tilt_rad = 0.0, max_joint_error_rad = 0.0;
  std::uint32_t status_union = 0;
  int ticks = 0;
};

SquatResult squatOnOde(FilterMode mode, double seconds) {
  FigureWorld user(test::humanFigurePath());
  FilterOptions options;
  options.mode = mode;
  ode_backend::AttachedFilter filter(user.robot, options, qp_engines::factory(options.qp.solver.engine));
  const ModelInfo& info = filter.model().info();
  const auto motion = io::readReferenceMotion(test::sourcePath("data/squat_reference.csv"), info);
  const auto& frames = motion.frames;
  filter.placeAt(frames.front());
  SquatResult r;
  ReferenceFrame ref(info.nq, info.nv);
  Eigen::VectorXd error(info.nv), q(info.nq), v(info.nv);
  std::size_t k = 0;
  const double t_end = std::min(frames.front().time_s + seconds, frames.back().time_s);
  for (double t = frames.front().time_s; t <= t_end; t += options.dt_s, ++r.ticks) {
    while (k + 2 < frames.size() && frames[k + 1].time_s <= t) ++k;
    interpolateReference(true, frames[k], frames[k + 1], t, ref);
    const FilterOutput& out = filter.step(ref);
    r.status_union |= out.status;
    user.step(options.dt_s);
    EXPECT_TRUE(filter.model().readBodyState(q, v));
    differenceConfiguration(true, ref.q, q, error);
    r.max_base_error_m = std::max(r.max_base_error_m, error.head<3>().norm());
    r.max_tilt_rad = std::max(r.max_tilt_rad, error.segment<2>(3).norm());
    r.max_joint_error_rad = std::max(r.max_joint_error_rad, error.tail(info.nj).cwiseAbs().maxCoeff());
  }
  return r;
}

// The user's DART world: the figure from DART's own URDF loader on a ground box, Bullet
// contacts, contact CFM 1e-3 (as examples/dart_attach: see there why).
struct DartFigureWorld {
  dart::simulation::WorldPtr world = dart::simulation::World::create("user");
  dart::dynamics::SkeletonPtr robot;
  DartFigureWorld() {
    world->setTimeStep(1e-3);
    world->getConstraintSolver()->setCollisionDetector(dart::collision::BulletCollisionDetector::create());
    dart::constraint::ContactConstraint::setConstraintForceMixing(1e-3);
    dart::utils::DartLoader loader;
    robot = loader.parseSkeleton(std::filesystem::absolute(test::humanFigurePath()).string());
    world->addSkeleton(robot);
    auto ground = dart::dynamics::Skeleton::create("ground");
    dart::dynamics::WeldJoint::Properties joint;
    joint.mT_ParentBodyToJoint.translation() = Eigen::Vector3d(0, 0, -0.1);
    auto* body = ground->createJointAndBodyNodePair<dart::dynamics::WeldJoint>(nullptr, joint).second;
    body->createShapeNodeWith<dart::dynamics::CollisionAspect, dart::dynamics::DynamicsAspect>(
        std::make_shared<dart::dynamics::BoxShape>(Eigen::Vector3d(20, 20, 0.2)));
    world->addSkeleton(ground);
  }
};

SquatResult squatOnDart(FilterMode mode, double seconds) {
  DartFigureWorld user;
  auto& world = user.world;
  auto& robot = user.robot;
  FilterOptions options;
  options.mode = mode;
  dart_backend::AttachedFilter filter(robot, world, options, qp_engines::factory(options.qp.solver.engine));
  const ModelInfo& info = filter.model().info();
  const auto motion = io::readReferenceMotion(test::sourcePath("data/squat_reference.csv"), info);
  const auto& frames = motion.frames;
  filter.placeAt(frames.front());
  SquatResult r;
  ReferenceFrame ref(info.nq, info.nv);
  Eigen::VectorXd error(info.nv), q(info.nq), v(info.nv);
  std::size_t k = 0;
  const double t_end = std::min(frames.front().time_s + seconds, frames.back().time_s);
  for (double t = frames.front().time_s; t <= t_end; t += options.dt_s, ++r.ticks) {
    while (k + 2 < frames.size() && frames[k + 1].time_s <= t) ++k;
    interpolateReference(true, frames[k], frames[k + 1], t, ref);
    const FilterOutput& out = filter.step(ref);
    r.status_union |= out.status;
    world->step();
    EXPECT_TRUE(filter.model().readSkeletonState(q, v));
    differenceConfiguration(true, ref.q, q, error);
    r.max_base_error_m = std::max(r.max_base_error_m, error.head<3>().norm());
    r.max_tilt_rad = std::max(r.max_tilt_rad, error.segment<2>(3).norm());
    r.max_joint_error_rad = std::max(r.max_joint_error_rad, error.tail(info.nj).cwiseAbs().maxCoeff());
    if (r.max_base_error_m > 0.5) break;
  }
  return r;
}

class AttachedOnDart : public testing::TestWithParam<FilterMode> {};

TEST_P(AttachedOnDart, TheFigureSquatsWithTheWorldsContactSolverEveryTick) {
  const SquatResult r = squatOnDart(GetParam(), 4.0);
  RecordProperty("max_base_error_m", std::to_string(r.max_base_error_m));
  RecordProperty("max_tilt_rad", std::to_string(r.max_tilt_rad));
  RecordProperty("max_joint_error_rad", std::to_string(r.max_joint_error_rad));
  EXPECT_GE(r.ticks, 4000);
  EXPECT_LT(r.max_base_error_m, 0.01);
  EXPECT_LT(r.max_tilt_rad, 0.01);
  EXPECT_LT(r.max_joint_error_rad, 0.01);
  EXPECT_EQ(r.status_union & (kStatusReseeded | kStatusNonFinite | kStatusQpFallback), 0u)
      << r.status_union;
}

INSTANTIATE_TEST_SUITE_P(Modes, AttachedOnDart, testing::Values(FilterMode::kPaper, FilterMode::kQp),
                         [](const testing::TestParamInfo<FilterMode>& p) {
                           return std::string(toString(p.param));
                         });

class AttachedOnOde : public testing::TestWithParam<FilterMode> {};

TEST_P(AttachedOnOde, TheFigureSquatsWithTheUsersContactSolverEveryTick) {
  const SquatResult r = squatOnOde(GetParam(), 4.0);
  RecordProperty("max_base_error_m", std::to_string(r.max_base_error_m));
  RecordProperty("max_tilt_rad", std::to_string(r.max_tilt_rad));
  RecordProperty("max_joint_error_rad", std::to_string(r.max_joint_error_rad));
  EXPECT_GE(r.ticks, 4000);
  EXPECT_LT(r.max_base_error_m, 0.01);
  EXPECT_LT(r.max_tilt_rad, 0.01);
  EXPECT_LT(r.max_joint_error_rad, 0.01);
  EXPECT_EQ(r.status_union & (kStatusReseeded | kStatusNonFinite | kStatusQpFallback), 0u)
      << r.status_union;
}

INSTANTIATE_TEST_SUITE_P(Modes, AttachedOnOde, testing::Values(FilterMode::kPaper, FilterMode::kQp),
                         [](const testing::TestParamInfo<FilterMode>& p) {
                           return std::string(toString(p.param));
                         });


// Allocations inside AttachedFilter::step over @p ticks of the squat after a warm-up, with
// the user's world stepping in between (not counted: it is the user's).
template <typename Filter, typename StepWorld>
long allocationsPerTick(Filter& filter, const std::vector<ReferenceFrame>& frames, double dt,
                        StepWorld step_world, int warmup, int ticks) {
  const ModelInfo& info = filter.model().info();
  ReferenceFrame ref(info.nq, info.nv);
  std::size_t k = 0;
  long count = 0;
  for (int tick = 0; tick < warmup + ticks; ++tick) {
    const double t = frames.front().time_s + tick * dt;
    while (k + 2 < frames.size() && frames[k + 1].time_s <= t) ++k;
    interpolateReference(true, frames[k], frames[k + 1], t, ref);
    if (tick >= warmup) {
      test::allocations::resetCounts();
      test::allocations::g_counting = true;
    }
    filter.step(ref);
    test::allocations::g_counting = false;
    if (tick >= warmup) count += test::allocations::g_core_new + test::allocations::g_core_malloc;
    step_world();
  }
  return count;
}

TEST(AttachedAllocation, OdeControllerTickAllocatesNothing) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  for (const FilterMode mode : {FilterMode::kPaper, FilterMode::kQp}) {
    FigureWorld user(test::humanFigurePath());
    FilterOptions options;
    options.mode = mode;
    ode_backend::AttachedFilter filter(user.robot, options, qp_engines::factory(options.qp.solver.engine));
    const auto motion =
        io::readReferenceMotion(test::sourcePath("data/squat_reference.csv"), filter.model().info());
    filter.placeAt(motion.frames.front());
    const long count = allocationsPerTick(filter, motion.frames, options.dt_s,
                                          [&] { user.step(options.dt_s); }, 50, 500);
    EXPECT_EQ(count, 0) << toString(mode) << ": allocations in 500 ticks of AttachedFilter::step";
    EXPECT_GT(filter.filter().output().num_contacts, 0);
  }
}

// Marks the time spent inside the model (DART) as "backend".
class InDart {
 public:
  InDart() : previous_(test::allocations::g_in_backend.exchange(true)) {}
  ~InDart() { test::allocations::g_in_backend = previous_; }

 private:
  bool previous_;
};

// Forwards to the attached model, each call inside DART marked: DART 6.12 allocates in its
// own lazy updates (world Jacobians, articulated inertias) and in CollisionResult. Those are
// reported; the controller's own code and the core are counted and must allocate nothing.
class MeasuredSkeletonModel final : public dart_backend::SkeletonModel {
 public:
  explicit MeasuredSkeletonModel(std::unique_ptr<dart_backend::SkeletonModel> inner)
      : inner_(std::move(inner)) {}
  const ModelInfo& info() const override { return inner_->info(); }
  std::string_view backendName() const override { return inner_->backendName(); }
  const Environment& environment() const override { return inner_->environment(); }
  void setState(const Eigen::Ref<const Eigen::VectorXd>& q,
                const Eigen::Ref<const Eigen::VectorXd>& v) override {
    InDart d;
    inner_->setState(q, v);
  }
  const Eigen::VectorXd& q() const override { return inner_->q(); }
  const Eigen::VectorXd& v() const override { return inner_->v(); }
  Eigen::Isometry3d bodyPose(int body) const override {
    InDart d;
    return inner_->bodyPose(body);
  }
  Vector6d bodyVelocity(int body) const override {
    InDart d;
    return inner_->bodyVelocity(body);
  }
  void pointJacobian(int body, const Eigen::Vector3d& p, Eigen::Ref<Matrix6Xd> J) const override {
    InDart d;
    inner_->pointJacobian(body, p, J);
  }
  Vector6d pointJacobianDotTimesV(int body, const Eigen::Vector3d& p) const override {
    InDart d;
    return inner_->pointJacobianDotTimesV(body, p);
  }
  void massMatrix(Eigen::Ref<Eigen::MatrixXd> A) const override {
    InDart d;
    inner_->massMatrix(A);
  }
  void bias(Eigen::Ref<Eigen::VectorXd> b) const override {
    InDart d;
    inner_->bias(b);
  }
  void forwardDynamics(const Eigen::Ref<const Eigen::VectorXd>& tau,
                       Eigen::Ref<Eigen::VectorXd> vdot) const override {
    InDart d;
    inner_->forwardDynamics(tau, vdot);
  }
  void detectContacts(ContactList& out) const override {
    InDart d;
    inner_->detectContacts(out);
  }
  void simulateStep(const Eigen::Ref<const Eigen::VectorXd>& tau, double dt) override {
    InDart d;
    inner_->simulateStep(tau, dt);
  }
  bool pullSkeletonState() override {
    InDart d;
    return inner_->pullSkeletonState();
  }
  bool readSkeletonState(Eigen::Ref<Eigen::VectorXd> q, Eigen::Ref<Eigen::VectorXd> v) const override {
    InDart d;
    return inner_->readSkeletonState(q, v);
  }
  void setSkeletonForces(const Eigen::Ref<const Eigen::VectorXd>& tau) const override {
    InDart d;
    inner_->setSkeletonForces(tau);
  }
  const dart::dynamics::SkeletonPtr& skeleton() const override { return inner_->skeleton(); }
  const dart::simulation::WorldPtr& world() const override { return inner_->world(); }

 private:
  std::unique_ptr<dart_backend::SkeletonModel> inner_;
};

TEST(AttachedAllocation, DartControllerTickAllocatesNothingOutsideDart) {
  if (!test::allocations::kCounting) GTEST_SKIP() << "allocations are not counted under AddressSanitizer";
  for (const FilterMode mode : {FilterMode::kPaper, FilterMode::kQp}) {
    DartFigureWorld user;
    FilterOptions options;
    options.mode = mode;
    dart_backend::AttachedFilter filter(
        std::make_unique<MeasuredSkeletonModel>(dart_backend::attachDartModel(user.robot, user.world)),
        options, qp_engines::factory(options.qp.solver.engine));
    const auto motion =
        io::readReferenceMotion(test::sourcePath("data/squat_reference.csv"), filter.model().info());
    filter.placeAt(motion.frames.front());
    long in_dart = 0;
    const long count = allocationsPerTick(filter, motion.frames, options.dt_s,
                                          [&] {
                                            in_dart += test::allocations::g_backend_allocations;
                                            user.world->step();
                                          },
                                          50, 500);
    RecordProperty(std::string("dart_allocations_per_tick_") + toString(mode),
                   std::to_string(static_cast<double>(in_dart) / 500.0));
    EXPECT_EQ(count, 0) << toString(mode) << ": allocations in 500 ticks of AttachedFilter::step";
    EXPECT_GT(filter.filter().output().num_contacts, 0);
  }
}

}  // namespace
}  // namespace dynfilter
