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
#include "support/reference_motions.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

constexpr double kTolerance = 1e-9;

double relative(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

// Coordinates of model `to` by name from those of model `from` (same robot, joints in
// another order): P maps v_from → v_to, and q likewise (base first).
struct Reorder {
  std::vector<int> v_from;  // v_to[i] = v_from[v_from_index[i]]
  std::vector<int> q_from;
  Reorder(const ModelInfo& from, const ModelInfo& to) {
    const int base_v = to.floating_base ? 6 : 0, base_q = to.floating_base ? 7 : 0;
    for (int i = 0; i < base_v; ++i) v_from.push_back(i);
    for (int i = 0; i < base_q; ++i) q_from.push_back(i);
    for (int j = 0; j < to.nj; ++j) {
      const int k = from.findJoint(to.joint_names[static_cast<std::size_t>(j)]);
      EXPECT_GE(k, 0) << to.joint_names[static_cast<std::size_t>(j)];
      v_from.push_back(from.velocityIndex(k));
      q_from.push_back(from.configurationIndex(k));
    }
  }
  Eigen::VectorXd v(const Eigen::VectorXd& x) const {
    Eigen::VectorXd out(static_cast<Eigen::Index>(v_from.size()));
    for (std::size_t i = 0; i < v_from.size(); ++i) out[static_cast<Eigen::Index>(i)] = x[v_from[i]];
    return out;
  }
  Eigen::VectorXd q(const Eigen::VectorXd& x) const {
    Eigen::VectorXd out(static_cast<Eigen::Index>(q_from.size()));
    for (std::size_t i = 0; i < q_from.size(); ++i) out[static_cast<Eigen::Index>(i)] = x[q_from[i]];
    return out;
  }
  Eigen::MatrixXd cols(const Eigen::MatrixXd& M) const {
    Eigen::MatrixXd out(M.rows(), static_cast<Eigen::Index>(v_from.size()));
    for (std::size_t i = 0; i < v_from.size(); ++i) out.col(static_cast<Eigen::Index>(i)) = M.col(v_from[i]);
    return out;
  }
  Eigen::MatrixXd both(const Eigen::MatrixXd& M) const {
    const Eigen::MatrixXd c = cols(M);
    Eigen::MatrixXd out(static_cast<Eigen::Index>(v_from.size()), c.cols());
    for (std::size_t i = 0; i < v_from.size(); ++i) out.row(static_cast<Eigen::Index>(i)) = c.row(v_from[i]);
    return out;
  }
};

// A, b and, at every body, J and J̇·v of a point: @p attached against @p reference at
// random states of the reference (mapped by joint name). Returns the worst relative gap.
double worstGap(IDynamicsModel& reference, IDynamicsModel& attached, int states, unsigned seed) {
  const ModelInfo& ri = reference.info();
  const ModelInfo& ai = attached.info();
  EXPECT_EQ(ri.nv, ai.nv);
  EXPECT_EQ(ri.floating_base, ai.floating_base);
  const Reorder reorder(ri, ai);
  std::mt19937 rng(seed);
  Eigen::VectorXd q, v;
  Eigen::MatrixXd A_r(ri.nv, ri.nv), A_a(ai.nv, ai.nv);
  Eigen::VectorXd b_r(ri.nv), b_a(ai.nv);
  Matrix6Xd J_r(6, ri.nv), J_a(6, ai.nv);
  const Eigen::Vector3d p_BP(0.03, -0.02, 0.05);
  double worst = 0.0;
  for (int s = 0; s < states; ++s) {
    randomState(ri, rng, 2.0, q, v);
    reference.setState(q, v);
    attached.setState(reorder.q(q), reorder.v(v));
    reference.massMatrix(A_r);
    attached.massMatrix(A_a);
    reference.bias(b_r);
    attached.bias(b_a);
    worst = std::max(worst, relative(A_a, reorder.both(A_r)));
    worst = std::max(worst, relative(b_a, reorder.v(b_r)));
    for (int body = 0; body < static_cast<int>(ai.body_names.size()); ++body) {
      const int rb = ri.findBody(ai.body_names[static_cast<std::size_t>(body)]);
      EXPECT_GE(rb, 0) << ai.body_names[static_cast<std::size_t>(body)];
      if (rb < 0) continue;
      EXPECT_LT(relative(attached.bodyPose(body).matrix(), reference.bodyPose(rb).matrix()), kTolerance)
          << ai.body_names[static_cast<std::size_t>(body)];
      reference.pointJacobian(rb, p_BP, J_r);
      attached.pointJacobian(body, p_BP, J_a);
      worst = std::max(worst, relative(J_a, reorder.cols(J_r)));
      worst = std::max(worst, relative(attached.pointJacobianDotTimesV(body, p_BP),
                                       reference.pointJacobianDotTimesV(rb, p_BP)));
    }
  }
  return worst;
}

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
  RecordProperty("worst_vs_dart", std::to_string(vs_dart));
  RecordProperty("worst_vs_ode", std::to_string(vs_ode));
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
