// Contact candidates from each backend's collision engine.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

class Contacts : public testing::TestWithParam<std::string> {
 protected:
  std::unique_ptr<IDynamicsModel> box(const Environment& env) {
    ModelOptions options;
    options.environment = env;
    return test::makeModel(GetParam(), urdf::loadUrdfFile(test::testModelPath("floating_box.urdf")),
                           options);
  }
};

TEST_P(Contacts, BoxSunkIntoLevelGroundTouchesAtItsFourBottomCorners) {
  auto model = box(Environment{});
  Eigen::VectorXd q(7), v = Eigen::VectorXd::Zero(6);
  q << 0.4, -0.3, 0.025 - 0.004, 1, 0, 0, 0;  // 4 mm deep
  model->setState(q, v);
  ContactList contacts;
  model->detectContacts(contacts);
  ASSERT_EQ(contacts.size(), 4u);
  for (const ContactCandidate& c : contacts) {
    EXPECT_EQ(c.body, 0);
    EXPECT_EQ(c.object, kGroundObject);
    EXPECT_NEAR(c.depth_m, 0.004, 1e-6);
    EXPECT_LT((c.n_W - Eigen::Vector3d::UnitZ()).norm(), 1e-9);
    // The point is on the body: a bottom corner of the 0.2 x 0.1 x 0.05 box.
    EXPECT_NEAR(std::abs(c.p_BC.x()), 0.1, 1e-6);
    EXPECT_NEAR(std::abs(c.p_BC.y()), 0.05, 1e-6);
    EXPECT_NEAR(c.p_BC.z(), -0.025, 1e-6);
    EXPECT_LT((model->bodyPose(0) * c.p_BC - c.p_WC).norm(), 1e-12);
  }
}

TEST_P(Contacts, BoxAboveTheGroundHasNoContact) {
  auto model = box(Environment{});
  Eigen::VectorXd q(7);
  q << 0, 0, 0.03, 1, 0, 0, 0;
  model->setState(q, Eigen::VectorXd::Zero(6));
  ContactList contacts;
  model->detectContacts(contacts);
  EXPECT_TRUE(contacts.empty());
}

TEST_P(Contacts, NoStaleContactAfterLiftingOff) {
  // Engines may keep contact manifolds between queries; a lifted box must not touch.
  auto model = box(Environment{});
  Eigen::VectorXd q(7);
  ContactList contacts;
  q << 0, 0, 0.024, 1, 0, 0, 0;
  model->setState(q, Eigen::VectorXd::Zero(6));
  model->detectContacts(contacts);
  ASSERT_EQ(contacts.size(), 4u);
  q[2] = 0.027;  // 2 mm above the ground
  model->setState(q, Eigen::VectorXd::Zero(6));
  model->detectContacts(contacts);
  EXPECT_TRUE(contacts.empty());
}

TEST_P(Contacts, SlopedGroundNormalAndDepth) {
  Environment env;
  const double slope = 10.0 * M_PI / 180.0;
  env.ground = GroundPlane::sloped(slope, M_PI / 4, 0.2);
  auto model = box(env);
  // Align the box with the slope and sink it 3 mm along the normal.
  const Eigen::Quaterniond R =
      Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), env.ground.n_W);
  const Eigen::Vector3d on_surface(0.5, 0.2, 0.0);
  const Eigen::Vector3d p =
      on_surface - env.ground.n_W * env.ground.signedDistance(on_surface) +
      env.ground.n_W * (0.025 - 0.003);
  Eigen::VectorXd q(7);
  q << p, R.w(), R.x(), R.y(), R.z();
  model->setState(q, Eigen::VectorXd::Zero(6));
  ContactList contacts;
  model->detectContacts(contacts);
  ASSERT_EQ(contacts.size(), 4u);
  for (const ContactCandidate& c : contacts) {
    EXPECT_LT((c.n_W - env.ground.n_W).norm(), 1e-6);
    EXPECT_NEAR(c.depth_m, 0.003, 1e-6);
    EXPECT_NEAR(env.ground.signedDistance(c.p_WC), -0.003, 1e-6);
  }
}

TEST_P(Contacts, BoxObstacleIsReportedWithItsIndex) {
  Environment env;
  env.has_ground = false;
  EnvironmentBox step;
  step.name = "step";
  step.size_m = Eigen::Vector3d(1.0, 1.0, 0.2);
  step.X_WO.translation() = Eigen::Vector3d(2.0, 0.0, 0.1);
  env.boxes = {EnvironmentBox{}, step};
  env.boxes[0].X_WO.translation() = Eigen::Vector3d(-5, 0, 0);
  auto model = box(env);
  Eigen::VectorXd q(7);
  q << 2.0, 0.0, 0.2 + 0.025 - 0.002, 1, 0, 0, 0;
  model->setState(q, Eigen::VectorXd::Zero(6));
  ContactList contacts;
  model->detectContacts(contacts);
  ASSERT_EQ(contacts.size(), 4u);
  for (const ContactCandidate& c : contacts) {
    EXPECT_EQ(c.object, 1);
    EXPECT_NEAR(c.depth_m, 0.002, 1e-6);
  }
}

TEST_P(Contacts, ContactListCountsOverflowInsteadOfGrowing) {
  auto model = box(Environment{});
  Eigen::VectorXd q(7);
  q << 0, 0, 0.02, 1, 0, 0, 0;
  model->setState(q, Eigen::VectorXd::Zero(6));
  ContactList small(2);
  model->detectContacts(small);
  EXPECT_EQ(small.size(), 2u);
  EXPECT_EQ(small.capacity(), 2u);
  EXPECT_GE(small.overflow(), 1u);  // the truncation is reported, not hidden
}

TEST_P(Contacts, MeshSolesStandAtTheirHullsBottomVertices) {
  // The biped's soles are a box STL and an OBJ frustum (package://): standing 0.1 mm deep
  // on level ground, each touches at the four bottom vertices of its convex hull.
  const urdf::RobotDescription robot =
      urdf::loadUrdfFile(test::testModelPath("mesh_sole_biped.urdf"), {{test::testModelPath("")}, {}});
  auto model = test::makeModel(GetParam(), robot, ModelOptions{});
  Eigen::VectorXd q = model->info().neutralConfiguration();
  q[2] = standingBaseHeight(*model, q) - 1e-4;
  model->setState(q, Eigen::VectorXd::Zero(model->nv()));
  ContactList contacts;
  model->detectContacts(contacts);
  ASSERT_EQ(contacts.size(), 8u);
  for (const char* foot : {"l_foot", "r_foot"}) {
    const int body = model->info().findBody(foot);
    const urdf::CollisionShapeDesc& sole =
        robot.links[static_cast<std::size_t>(body)].collisions.at(0);
    std::vector<Eigen::Vector3d> bottom;  // hull vertices with the lowest z, in the link frame
    for (const auto& v : sole.hull.vertices_S)
      if (v.z() < -0.0099) bottom.push_back(sole.X_LS * v);
    ASSERT_EQ(bottom.size(), 4u);
    int found = 0;
    for (const ContactCandidate& c : contacts) {
      if (c.body != body) continue;
      ++found;
      EXPECT_NEAR(c.depth_m, 1e-4, 1e-7);
      EXPECT_LT((c.n_W - Eigen::Vector3d::UnitZ()).norm(), 1e-9);
      double nearest = 1.0;
      for (const auto& v : bottom) nearest = std::min(nearest, (c.p_BC - v).norm());
      EXPECT_LT(nearest, 1e-6) << foot << " contact at " << c.p_BC.transpose();
    }
    EXPECT_EQ(found, 4) << foot;
  }
}

INSTANTIATE_TEST_SUITE_P(AllBackends, Contacts, testing::ValuesIn(test::allBackends()),
                         test::BackendName());

}  // namespace
}  // namespace dynfilter
