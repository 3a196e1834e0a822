// The filter attached to a user's own simulation: the attached models (a DART skeleton the
// user loaded with DART's own URDF loader; ODE bodies and joints the user built) must agree
// with the URDF-built backends on A, b, J and J̇·v, state by state; ball joints must be
// consistent with their coordinates (finite differences, energy, DART against ODE).
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <dart/collision/bullet/BulletCollisionDetector.hpp>
#include <dart/constraint/ConstraintSolver.hpp>
#include <dart/dynamics/BallJoint.hpp>
#include <dart/dynamics/BoxShape.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/RevoluteJoint.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <dart/dynamics/WeldJoint.hpp>
#include <dart/simulation/World.hpp>
#include <dart/utils/urdf/DartLoader.hpp>
#include <gtest/gtest.h>

#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/dart/skeleton_model.hpp"
#include "dynfilter/ode/body_model.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "figure_world.hpp"  // examples/ode_attach: the user's ODE figure
#include "attach_support.hpp"
#include "support/reference_motions.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

// The user's DART world: the figure from DART's own URDF loader, a ground box, Bullet.
struct DartUserWorld {
  dart::simulation::WorldPtr world = dart::simulation::World::create("user");
  dart::dynamics::SkeletonPtr robot;
  DartUserWorld() {
    world->getConstraintSolver()->setCollisionDetector(
        dart::collision::BulletCollisionDetector::create());
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

TEST(AttachDart, UserSkeletonAgreesWithTheUrdfBackendsOnTheHumanFigure) {
  DartUserWorld user;
  ASSERT_NE(user.robot, nullptr);
  auto attached = dart_backend::attachDartModel(user.robot, user.world);
  const auto robot = urdf::loadUrdfFile(test::humanFigurePath());
  auto dart = test::makeModel("dart", robot, ModelOptions{});
  auto ode = test::makeModel("ode", robot, ModelOptions{});
  EXPECT_TRUE(attached->info().floating_base);
  EXPECT_EQ(attached->info().body_names.size(), robot.links.size());
  EXPECT_NEAR(attached->info().total_mass, dart->info().total_mass, 1e-9);
  const double vs_dart = worstGap(*dart, *attached, 20, 1);
  const double vs_ode = worstGap(*ode, *attached, 20, 2);
  RecordProperty("worst_vs_dart", test::scientific(vs_dart));
  RecordProperty("worst_vs_ode", test::scientific(vs_ode));
  EXPECT_LT(vs_dart, kTolerance);
  EXPECT_LT(vs_ode, kTolerance);
}

TEST(AttachDart, ContactsComeFromTheUsersGround) {
  DartUserWorld user;
  auto attached = dart_backend::attachDartModel(user.robot, user.world);
  const auto robot = urdf::loadUrdfFile(test::humanFigurePath());
  auto dart = test::makeModel("dart", robot, ModelOptions{});
  const Reorder reorder(dart->info(), attached->info());
  Eigen::VectorXd q = dart->info().neutralConfiguration();
  q[2] = test::humanFigureStandingHeight() - 0.002;  // 2 mm into the ground
  const Eigen::VectorXd v = Eigen::VectorXd::Zero(dart->nv());
  attached->setState(reorder.q(q), reorder.v(v));
  ContactList contacts;
  attached->detectContacts(contacts);
  ASSERT_GE(contacts.size(), 8u) << "four sole corners per foot";
  for (const ContactCandidate& c : contacts) {
    const std::string& body = attached->info().body_names[static_cast<std::size_t>(c.body)];
    EXPECT_TRUE(body == "l_foot" || body == "r_foot") << body;
    EXPECT_NEAR(c.n_W.z(), 1.0, 1e-9);
    EXPECT_NEAR(c.depth_m, 0.002, 2e-4);
    EXPECT_NEAR(c.p_WC.z(), 0.0, 3e-3);
  }
}

}  // namespace
}  // namespace dynfilter
