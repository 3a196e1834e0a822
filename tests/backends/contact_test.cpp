// Contact candidates from each backend's collision engine.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/core/lie_group.hpp"
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

TEST_P(Contacts, ABaseOriginBelowTheFeetStandsBelowZero) {
  // A root link one metre below the pelvis (a footprint frame welded to it): the model
  // stands with that origin 0.27 m below the ground, where the mini humanoid's pelvis
  // stands 0.73 m above it.
  std::ifstream in(test::testModelPath("mini_humanoid.urdf"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto plain = test::makeModel(GetParam(), urdf::loadUrdfString(text, "mini_humanoid.urdf"), ModelOptions{});
  const std::string tag = "<robot name=\"mini_humanoid\">";
  text.replace(text.find(tag) + tag.size(), 0,
               "<link name=\"footprint\"/><joint name=\"footprint_to_hips\" type=\"fixed\"><parent link=\"footprint\"/>"
               "<child link=\"hips\"/><origin xyz=\"0 0 1\"/></joint>");
  auto low = test::makeModel(GetParam(), urdf::loadUrdfString(text, "footprint.urdf"), ModelOptions{});
  const double pelvis = standingBaseHeight(*plain, plain->info().neutralConfiguration());
  EXPECT_NEAR(pelvis, 0.73, 1e-6);
  EXPECT_NEAR(standingBaseHeight(*low, low->info().neutralConfiguration()), pelvis - 1.0, 1e-6);
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

// The hulls' ground contacts come from their vertices in both backends
// (core/ground_contacts.hpp): DART and ODE give the same points, pose by pose. Before, Bullet
// kept 4 points per hull and ODE up to 16 in its own choice.
TEST(HullGroundContacts, DartAndOdeGiveTheSamePointsOnLevelAndSlopedGround) {
  const urdf::RobotDescription robot =
      urdf::loadUrdfFile(test::testModelPath("mesh_sole_biped.urdf"), {{test::testModelPath("")}, {}});
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int touching_states = 0;
  for (const double slope_deg : {0.0, 10.0}) {
    ModelOptions options;
    options.environment.ground = GroundPlane::sloped(slope_deg * M_PI / 180.0, 0.3);
    auto dart = test::makeModel("dart", robot, options);
    auto ode = test::makeModel("ode", robot, options);
    const Eigen::VectorXd q0 = dart->info().neutralConfiguration();
    for (int state = 0; state < 60; ++state) {
      // Even states stand in the neutral posture, turned about z only: on level ground both
      // soles are flat. Odd states tilt the base and bend the joints.
      const bool flat = state % 2 == 0;
      Eigen::VectorXd q = q0;
      if (!flat)
        for (int j = 7; j < q.size(); ++j) q[j] += 0.1 * unit(rng);
      const double tilt_scale = flat ? 0.0 : 0.15;
      const Eigen::Vector3d tilt(tilt_scale * unit(rng), tilt_scale * unit(rng), M_PI * unit(rng));
      const Eigen::Quaterniond r(expSO3(tilt));
      q.segment<4>(3) << r.w(), r.x(), r.y(), r.z();
      q[2] = standingBaseHeight(*dart, q) - 0.004 * (0.5 + 0.5 * unit(rng));
      dart->setState(q, Eigen::VectorXd::Zero(dart->nv()));
      ode->setState(q, Eigen::VectorXd::Zero(ode->nv()));
      ContactList a, b;
      dart->detectContacts(a);
      ode->detectContacts(b);
      ASSERT_EQ(a.size(), b.size()) << "slope " << slope_deg << " state " << state;
      touching_states += a.empty() ? 0 : 1;
      if (flat && slope_deg == 0.0) {
        EXPECT_EQ(a.size(), 8u) << "state " << state;  // 4 per sole
      }
      for (const ContactCandidate& x : a) {
        double nearest = INFINITY;
        for (const ContactCandidate& y : b)
          if (y.body == x.body && y.object == x.object && std::abs(y.depth_m - x.depth_m) < 1e-12)
            nearest = std::min(nearest, (y.p_WC - x.p_WC).norm());
        EXPECT_LT(nearest, 1e-12) << "slope " << slope_deg << " state " << state;
        EXPECT_NEAR(options.environment.ground.signedDistance(x.p_WC), -x.depth_m, 1e-12);
      }
    }
  }
  EXPECT_EQ(touching_states, 120);
}

// One floating sole whose collision mesh is an elliptic prism with 24 vertices per ring and
// its mesh origin outside the hull.
urdf::RobotDescription roundedSole() {
  const std::string xml = R"(<robot name="rounded_sole">
  <link name="sole">
    <inertial><mass value="1.0"/><inertia ixx="0.002" iyy="0.005" izz="0.006" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -0.02"/>
      <geometry><mesh filename="package://dynfilter_test_meshes/meshes/rounded_sole.obj"/></geometry>
    </collision>
  </link>
</robot>)";
  return urdf::loadUrdfString(xml, "rounded_sole.urdf", {{test::testModelPath("")}, {}});
}

TEST(HullGroundContacts, ADenseRoundedSoleFlatOnTheGroundGivesTheSameEightPointsInBothEngines) {
  // Bullet kept 4 of the 24 bottom vertices, ODE 16 (its buffer), each its own choice.
  const urdf::RobotDescription robot = roundedSole();
  auto dart = test::makeModel("dart", robot, ModelOptions{});
  auto ode = test::makeModel("ode", robot, ModelOptions{});
  for (const double yaw : {0.0, 0.4, 2.0}) {
    Eigen::VectorXd q(7);
    q << 0.2, -0.1, 0.015 - 1e-4, std::cos(yaw / 2), 0, 0, std::sin(yaw / 2);
    ContactList a, b;
    dart->setState(q, Eigen::VectorXd::Zero(6));
    ode->setState(q, Eigen::VectorXd::Zero(6));
    dart->detectContacts(a);
    ode->detectContacts(b);
    ASSERT_EQ(a.size(), 8u) << "yaw " << yaw;
    ASSERT_EQ(b.size(), 8u) << "yaw " << yaw;
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_NEAR(a[i].depth_m, 1e-4, 1e-9);  // the OBJ is read in single precision
      double nearest = INFINITY;
      for (const ContactCandidate& y : b) nearest = std::min(nearest, (y.p_WC - a[i].p_WC).norm());
      EXPECT_LT(nearest, 1e-12);
    }
  }
}

TEST(HullGroundContacts, AHullWhoseMeshOriginIsOutsideItIsAValidOdeConvexAndRestsOnTheGround) {
  // ODE's convex geom wants its origin inside the hull; it printed a warning per face and
  // per plane otherwise. Each engine's simulator then drops the sole 1 cm onto the ground.
  const urdf::RobotDescription robot = roundedSole();
  testing::internal::CaptureStdout();
  auto ode = test::makeModel("ode", robot, ModelOptions{});
  const std::string printed = testing::internal::GetCapturedStdout();
  EXPECT_EQ(printed.find("WARNING"), std::string::npos) << printed;
  for (const std::string backend : {"dart", "ode"}) {
    auto model = test::makeModel(backend, robot, ModelOptions{});
    Eigen::VectorXd q(7);
    q << 0, 0, 0.025, 1, 0, 0, 0;  // the hull's bottom (link z = −0.015) 1 cm above the ground
    model->setState(q, Eigen::VectorXd::Zero(6));
    for (int i = 0; i < 500; ++i) model->simulateStep(Eigen::VectorXd::Zero(0), 1e-3);
    // At rest on its bottom face: the base 1.5 cm up, within the engines' penetration.
    EXPECT_NEAR(model->q()[2], 0.015, 2e-3) << backend;
    EXPECT_LT(model->v().norm(), 0.05) << backend;
  }
}

// The same for cylinders, which are primitives in both engines: a floating cylinder near the
// ground in random poses, upright, lying and tilted, on level ground and on a 10° slope.
TEST(HullGroundContacts, DartAndOdeGiveTheSamePointsForACylinder) {
  const urdf::RobotDescription robot = urdf::loadUrdfString(R"(<robot name="can">
  <link name="can">
    <inertial><mass value="1.0"/><inertia ixx="0.004" iyy="0.004" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0.02 0" rpy="0.1 0 0"/><geometry><cylinder radius="0.04" length="0.2"/></geometry></collision>
  </link>
</robot>)", "can.urdf");
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int touching = 0, face_like = 0;
  for (const double slope_deg : {0.0, 10.0}) {
    ModelOptions options;
    options.environment.ground = GroundPlane::sloped(slope_deg * M_PI / 180.0, 1.0);
    auto dart = test::makeModel("dart", robot, options);
    auto ode = test::makeModel("ode", robot, options);
    for (int state = 0; state < 60; ++state) {
      // Every third state upright (about the world's z; the shape is rolled by 0.1 rad in
      // its link), every sixth lying on its side, the rest at random.
      Eigen::Matrix3d R = expSO3(Eigen::Vector3d(M_PI * unit(rng), M_PI * unit(rng), M_PI * unit(rng)));
      if (state % 3 == 0) R = expSO3(Eigen::Vector3d(0, 0, M_PI * unit(rng))) * expSO3(Eigen::Vector3d(-0.1, 0, 0));
      if (state % 6 == 3) R = expSO3(Eigen::Vector3d(M_PI / 2 - 0.1, 0, 0));
      const Eigen::Quaterniond r(R);
      Eigen::VectorXd q(7);
      q << 0.1, -0.2, 0.0, r.w(), r.x(), r.y(), r.z();
      q[2] = standingBaseHeight(*dart, q) - 0.003 * (0.5 + 0.5 * unit(rng));
      dart->setState(q, Eigen::VectorXd::Zero(6));
      ode->setState(q, Eigen::VectorXd::Zero(6));
      ContactList a, b;
      dart->detectContacts(a);
      ode->detectContacts(b);
      ASSERT_EQ(a.size(), b.size()) << "slope " << slope_deg << " state " << state;
      touching += a.empty() ? 0 : 1;
      face_like += a.size() >= 4 ? 1 : 0;
      for (const ContactCandidate& x : a) {
        double nearest = INFINITY;
        for (const ContactCandidate& y : b)
          if (std::abs(y.depth_m - x.depth_m) < 1e-12) nearest = std::min(nearest, (y.p_WC - x.p_WC).norm());
        EXPECT_LT(nearest, 1e-12) << "slope " << slope_deg << " state " << state;
        EXPECT_NEAR(options.environment.ground.signedDistance(x.p_WC), -x.depth_m, 1e-12);
        EXPECT_LE(x.depth_m, 0.003 + 1e-9);
      }
    }
  }
  EXPECT_EQ(touching, 120);
  EXPECT_GE(face_like, 20);  // the upright and lying ones on level ground
}

INSTANTIATE_TEST_SUITE_P(AllBackends, Contacts, testing::ValuesIn(test::allBackends()),
                         test::BackendName());

}  // namespace
}  // namespace dynfilter
