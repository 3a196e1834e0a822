#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "dynfilter/core/errors.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter::urdf {
namespace {

// A two-link arm; {JOINT_TYPE}, {CHILD_MASS} and {EXTRA} are replaced per test.
const char* kTemplate = R"(<?xml version="1.0"?>
<robot name="arm">
  <link name="base">
    <inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="shoulder" type="{JOINT_TYPE}">
    <parent link="base"/>
    <child link="upper"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="2"/>
  </joint>
  <link name="upper">
    <inertial><mass value="{CHILD_MASS}"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
{EXTRA}</robot>
)";

std::string arm(const std::string& joint_type = "revolute", const std::string& mass = "1",
                const std::string& extra = "") {
  std::string s = kTemplate;
  auto replace = [&s](const std::string& key, const std::string& value) {
    s.replace(s.find(key), key.size(), value);
  };
  replace("{JOINT_TYPE}", joint_type);
  replace("{CHILD_MASS}", mass);
  replace("{EXTRA}", extra);
  return s;
}

// Expects a ModelError whose message names the source, the line, the element and the reason.
void expectModelError(const std::string& xml, int line, const std::string& element,
                      const std::string& reason, bool dynamics_check = false) {
  try {
    const RobotDescription robot = loadUrdfString(xml, "arm.urdf");
    if (dynamics_check) validateForDynamics(robot, true);
    FAIL() << "expected a ModelError";
  } catch (const ModelError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(e.file(), "arm.urdf");
    EXPECT_EQ(e.line(), line) << msg;
    EXPECT_NE(msg.find(element), std::string::npos) << msg;
    EXPECT_NE(msg.find(reason), std::string::npos) << msg;
    EXPECT_EQ(msg.rfind("arm.urdf:" + std::to_string(line) + ": ", 0), 0u) << msg;
  }
}

TEST(UrdfLoader, ParsesAValidModelInFileOrder) {
  const RobotDescription robot = loadUrdfString(arm(), "arm.urdf");
  EXPECT_EQ(robot.name, "arm");
  ASSERT_EQ(robot.links.size(), 2u);
  EXPECT_EQ(robot.links[1].name, "upper");
  EXPECT_EQ(robot.links[1].line, 12);
  ASSERT_EQ(robot.moving_joints.size(), 1u);
  const JointDesc& j = robot.joints[0];
  EXPECT_EQ(j.type, JointType::kRevolute);
  EXPECT_EQ(j.coordinate, 0);
  EXPECT_DOUBLE_EQ(j.lower, -1.0);
  EXPECT_DOUBLE_EQ(j.effort_max, 10.0);
  EXPECT_EQ(robot.root_link, 0);
  EXPECT_NO_THROW(validateForDynamics(robot, true));
}

TEST(UrdfLoader, MissingFileNamesThePath) {
  try {
    loadUrdfFile("/nonexistent/dir/robot.urdf");
    FAIL();
  } catch (const ModelError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("/nonexistent/dir/robot.urdf"), std::string::npos) << msg;
    EXPECT_NE(msg.find("cannot open"), std::string::npos) << msg;
    EXPECT_NE(msg.find("No such file"), std::string::npos) << msg;
  }
}

TEST(UrdfLoader, BadXmlNamesTheLine) {
  std::string xml = arm();
  xml.replace(xml.find("</link>\n  <joint"), 7, "</lnk>");  // closes <link> of line 3 wrongly
  expectModelError(xml, 3, "XML", "malformed XML");
}

TEST(UrdfLoader, UnknownJointTypeNamesTheJointAndType) {
  expectModelError(arm("ball"), 6, "joint \"shoulder\"", "unknown joint type \"ball\"");
}

TEST(UrdfLoader, FloatingJointIsUnsupportedNotUnknown) {
  expectModelError(arm("floating"), 6, "joint \"shoulder\"", "unsupported joint type");
}

// A `floating` joint from a root that stands for the world (no mass, no collision, no other
// joint) to the robot's base: the world link and the joint are dropped, the base is the root,
// and the description is the one without them (the warning says so).
TEST(UrdfLoader, AFloatingJointFromAMasslessWorldMakesItsChildTheBase) {
  std::string xml = arm();
  xml.replace(xml.find("  <link name=\"base\">"), 0,
              "  <link name=\"world\"/>\n  <joint name=\"root\" type=\"floating\"><parent link=\"world\"/>"
              "<child link=\"base\"/><origin xyz=\"0 0 1\"/></joint>\n");
  const RobotDescription with_world = loadUrdfString(xml, "arm.urdf");
  const RobotDescription plain = loadUrdfString(arm(), "arm.urdf");
  ASSERT_EQ(with_world.links.size(), plain.links.size());
  ASSERT_EQ(with_world.joints.size(), plain.joints.size());
  EXPECT_EQ(with_world.links[static_cast<std::size_t>(with_world.root_link)].name, "base");
  EXPECT_EQ(with_world.links[static_cast<std::size_t>(with_world.root_link)].parent_joint, -1);
  EXPECT_EQ(with_world.joints[0].name, "shoulder");
  EXPECT_EQ(with_world.moving_joints, plain.moving_joints);
  EXPECT_EQ(with_world.links[1].line, plain.links[1].line + 2);  // lines still those of the file
  bool said = false;
  for (const std::string& w : with_world.warnings)
    said = said || w.find("arm.urdf:4: joint \"root\" (floating) from link \"world\": the floating base is link \"base\"") !=
                       std::string::npos;
  EXPECT_TRUE(said);
  EXPECT_NO_THROW(validateForDynamics(with_world, true));

  // A floating joint whose parent is a body (it has mass) is not a floating base: refused.
  std::string heavy = xml;
  heavy.replace(heavy.find("<link name=\"world\"/>"), std::string("<link name=\"world\"/>").size(),
                "<link name=\"world\"><inertial><mass value=\"2\"/><inertia ixx=\"0.1\" iyy=\"0.1\" izz=\"0.1\" "
                "ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>");
  expectModelError(heavy, 4, "joint \"root\"", "floating joint is accepted only from a root link without mass");
}

TEST(UrdfLoader, AJointThatMovesNoMassIsRejectedByName) {
  // The massless leaf makes A singular: the error names the joint, its line and why.
  expectModelError(arm("revolute", "0"), 6, "joint \"shoulder\"",
                   "moves no mass or inertia about its axis: link \"upper\"", true);
  expectModelError(arm("prismatic", "0"), 6, "joint \"shoulder\"", "moves no mass", true);
}

TEST(UrdfLoader, AMasslessLinkCarryingMassIsAccepted) {
  // The shoulder's own link is massless; a massive hand welded beyond it moves.
  const std::string chain = R"(  <joint name="wrist" type="fixed">
    <parent link="upper"/><child link="hand"/><origin xyz="0 0.3 0"/>
  </joint>
  <link name="hand">
    <inertial><mass value="2"/><inertia ixx="0.01" iyy="0.02" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
)";
  const RobotDescription robot = loadUrdfString(arm("revolute", "0", chain), "arm.urdf");
  EXPECT_NO_THROW(validateForDynamics(robot, true));
}

TEST(UrdfLoader, MasslessIntermediateLinksOfAThreeDofHipAreAccepted) {
  const RobotDescription robot = loadUrdfFile(test::testModelPath("mesh_sole_biped.urdf"),
                                              {{test::testModelPath("")}, {}});
  EXPECT_EQ(robot.links[static_cast<std::size_t>(robot.findLink("l_hip_yaw_link"))].inertial.mass_kg, 0.0);
  EXPECT_NO_THROW(validateForDynamics(robot, true));
  // Locking the thigh's pitch joint does not change that; dropping the thigh's and
  // everything below's mass does, and names the innermost hip joint that moves nothing.
  RobotDescription massless = robot;
  for (const char* name : {"l_thigh", "l_shin", "l_foot"})
    massless.links[static_cast<std::size_t>(massless.findLink(name))].inertial = InertialDesc{};
  try {
    validateForDynamics(massless, true);
    FAIL() << "expected a ModelError";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("joint \"l_hip_yaw\""), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("moves no mass"), std::string::npos) << e.what();
  }
}

TEST(UrdfLoader, ZeroMassOnAFixedJointIsAccepted) {
  const RobotDescription robot = loadUrdfString(arm("fixed", "0"), "arm.urdf");
  EXPECT_NO_THROW(validateForDynamics(robot, true));
}

// A single link's inertia that no body can have (the triangle inequality broken) changes
// nothing the dynamics need as long as the rigid body is positive definite: accepted, and
// said (romeo_small's shoulder, Allegro's fingers ship such values).
TEST(UrdfLoader, ALinkInertiaBreakingTheTriangleInequalityIsAcceptedWithAWarning) {
  std::string xml = arm();
  const std::string good = R"(<mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01")";
  xml.replace(xml.find(good), good.size(),
              R"(<mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.05")");
  const RobotDescription robot = loadUrdfString(xml, "arm.urdf");
  EXPECT_NO_THROW(validateForDynamics(robot, true));
  ASSERT_EQ(robot.warnings.size(), 1u);
  EXPECT_NE(robot.warnings[0].find("arm.urdf:12: link \"upper\": inertia violates the triangle inequality"),
            std::string::npos) << robot.warnings[0];
}

TEST(UrdfLoader, ARigidBodyWhoseInertiaIsNotPositiveSemiDefiniteIsRejected) {
  std::string xml = arm();
  const std::string good = R"(<mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01")";
  xml.replace(xml.find(good), good.size(),
              R"(<mass value="1"/><inertia ixx="-0.01" iyy="0.01" izz="0.01")");
  expectModelError(xml, 12, "link \"upper\"", "is not positive semi-definite", true);
}

// Quadruped and humanoid descriptions (Go1, B1, ANYmal, HyQ) start with a 1 µg root whose
// inertia is singular (1e-6 in every entry, products included) welded to the trunk: the
// body that moves is the sum, which is fine. Rejected per link before; measured on the
// example-robot-data descriptions.
TEST(UrdfLoader, ASingularDummyRootWeldedToTheTrunkIsAccepted) {
  const std::string dummy = R"(<robot name="arm">
  <link name="root">
    <inertial><mass value="1e-6"/><inertia ixx="1e-6" ixy="1e-6" ixz="1e-6" iyy="1e-6" iyz="1e-6" izz="1e-6"/></inertial>
  </link>
  <joint name="root_to_base" type="fixed"><parent link="root"/><child link="base"/></joint>
)";
  std::string xml = arm();
  xml.replace(xml.find("<robot name=\"arm\">\n"), std::string("<robot name=\"arm\">\n").size(), dummy);
  const RobotDescription robot = loadUrdfString(xml, "arm.urdf");
  EXPECT_NO_THROW(validateForDynamics(robot, true));
  ASSERT_EQ(robot.warnings.size(), 1u) << "the dummy's own inertia is listed";
  EXPECT_NE(robot.warnings[0].find("link \"root\""), std::string::npos) << robot.warnings[0];
  // A trunk that does not make the sum positive semi-definite is still rejected, naming
  // the body by its first link.
  RobotDescription bad = robot;
  InertialDesc& trunk = bad.links[static_cast<std::size_t>(bad.findLink("base"))].inertial;
  trunk = bad.links[static_cast<std::size_t>(bad.findLink("root"))].inertial;
  trunk.I_Com_L(0, 0) = -1e-6;
  try {
    validateForDynamics(bad, true);
    FAIL() << "expected a ModelError";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("link \"root\": the rigid body's inertia (with the 1 link(s) welded to it)"),
              std::string::npos) << e.what();
  }
}

// iCub's point masses: zero inertia with a product of 1e-20 from the exporter's rounding.
TEST(UrdfLoader, APointMassWithRoundingInItsInertiaIsAccepted) {
  std::string xml = arm();
  const std::string good = R"(<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>)";
  const std::size_t upper = xml.find(good, xml.find("name=\"upper\""));
  xml.replace(upper, good.size(), R"(<inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="1.35525e-20" iyz="0"/>)");
  const std::string com = R"(<inertial><mass value="1"/>)";
  xml.replace(xml.find(com, xml.find("name=\"upper\"")), com.size(),
              R"(<inertial><origin xyz="0.3 0 0"/><mass value="1"/>)");
  const RobotDescription robot = loadUrdfString(xml, "arm.urdf");
  EXPECT_NO_THROW(validateForDynamics(robot, true));
}

TEST(UrdfLoader, ElementsThatDoNotChangeTheDynamicsAreIgnoredAndListed) {
  const RobotDescription robot = loadUrdfFile(test::testModelPath("mimic_gripper.urdf"));
  const auto listed = [&](const std::string& key) {
    for (const auto& e : robot.ignored_elements)
      if (e.rfind(key, 0) == 0) return e;
    return std::string();
  };
  EXPECT_NE(listed("<robot><gazebo> x2"), "");
  EXPECT_NE(listed("<robot><transmission> x1"), "");
  EXPECT_NE(listed("<robot><sensor> x1"), "");
  EXPECT_NE(listed("<link><sensor> x1"), "");
  EXPECT_NE(listed("<link><visual> x2"), "");
  EXPECT_NE(listed("<joint><dynamics> x1"), "");
  EXPECT_NE(listed("<robot><material>").find("mimic_gripper.urdf:7)"), std::string::npos)
      << listed("<robot><material>");
  // A misspelt element is listed too (not silently dropped).
  const RobotDescription typo = loadUrdfString(arm("revolute", "1", "  <lnk name=\"typo\"/>\n"), "arm.urdf");
  ASSERT_EQ(typo.ignored_elements.size(), 1u);
  EXPECT_EQ(typo.ignored_elements[0], "<robot><lnk> x1 (first at arm.urdf:15)");
}

TEST(UrdfLoader, MimicJointsFollowTheirFirstLeaderAndCarryNoCoordinate) {
  const RobotDescription robot = loadUrdfFile(test::testModelPath("mimic_gripper.urdf"));
  ASSERT_EQ(robot.moving_joints.size(), 2u);  // wrist, left finger
  ASSERT_EQ(robot.mimic_joints.size(), 3u);
  const int leader = robot.findJoint("left_finger_joint");
  const JointDesc& right = robot.joints[static_cast<std::size_t>(robot.findJoint("right_finger_joint"))];
  EXPECT_EQ(right.mimic_leader, leader);
  EXPECT_EQ(right.coordinate, -1);
  EXPECT_DOUBLE_EQ(right.mimic_multiplier, -0.9);
  EXPECT_DOUBLE_EQ(right.mimic_offset, 0.05);
  // left_tip mimics right_finger: 1.5 (−0.9 q + 0.05) − 0.02 = −1.35 q + 0.055.
  const JointDesc& tip = robot.joints[static_cast<std::size_t>(robot.findJoint("left_tip_joint"))];
  EXPECT_EQ(tip.mimic_leader, leader);
  EXPECT_NEAR(tip.mimic_multiplier, -1.35, 1e-15);
  EXPECT_NEAR(tip.mimic_offset, 0.055, 1e-15);
}

TEST(UrdfLoader, MimicOfAnUnknownJointNamesTheLine) {
  std::string xml = arm();
  xml.replace(xml.find("<limit"), 0, "<mimic joint=\"elbow\"/>\n    ");
  expectModelError(xml, 10, "joint \"shoulder\" <mimic>", "leader joint \"elbow\" is not defined");
}

TEST(UrdfLoader, LockedJointsAreWeldedAtTheirPosition) {
  UrdfLoadOptions options;
  options.lock_joints = {"left_finger_joint=0.3", "wr*"};
  const RobotDescription robot = loadUrdfFile(test::testModelPath("mimic_gripper.urdf"), options);
  EXPECT_TRUE(robot.moving_joints.empty());
  EXPECT_TRUE(robot.mimic_joints.empty());  // followers of a locked leader are locked too
  // The follower is welded at −0.9 · 0.3 + 0.05 about its axis (y).
  const RobotDescription free = loadUrdfFile(test::testModelPath("mimic_gripper.urdf"));
  const int right = robot.findJoint("right_finger_joint");
  const Eigen::Isometry3d expected =
      free.joints[static_cast<std::size_t>(right)].X_PJ * Eigen::AngleAxisd(-0.9 * 0.3 + 0.05, Eigen::Vector3d::UnitY());
  EXPECT_TRUE(robot.joints[static_cast<std::size_t>(right)].X_PJ.isApprox(expected, 1e-14));
  EXPECT_EQ(robot.joints[static_cast<std::size_t>(right)].type, JointType::kFixed);
  // The model's names say which joints were welded (a reference's columns for them are skipped).
  EXPECT_EQ(makeModelInfo(robot, false).locked_joint_names,
            (std::vector<std::string>{"wrist", "left_finger_joint", "right_finger_joint", "left_tip_joint",
                                      "pusher_joint"}));
  EXPECT_TRUE(makeModelInfo(free, false).locked_joint_names.empty());
  options.lock_joints = {"no_such_*"};
  EXPECT_THROW(loadUrdfFile(test::testModelPath("mimic_gripper.urdf"), options), ModelError);
  options.lock_joints = {"right_finger_joint"};  // a follower without its leader
  EXPECT_THROW(loadUrdfFile(test::testModelPath("mimic_gripper.urdf"), options), ModelError);
  options.lock_joints = {"wrist=3"};  // outside [−2, 2]
  EXPECT_THROW(loadUrdfFile(test::testModelPath("mimic_gripper.urdf"), options), ModelError);
}

TEST(UrdfLoader, MeshCollisionsBecomeConvexHulls) {
  const RobotDescription robot = loadUrdfFile(test::testModelPath("mesh_sole_biped.urdf"),
                                              {{test::testModelPath("")}, {}});
  const auto& left = robot.links[static_cast<std::size_t>(robot.findLink("l_foot"))].collisions;
  ASSERT_EQ(left.size(), 1u);
  EXPECT_EQ(left[0].kind, ShapeKind::kConvexHull);
  EXPECT_EQ(left[0].hull.vertices_S.size(), 8u);  // the box STL
  EXPECT_EQ(left[0].hull.faces.size(), 6u);       // coplanar triangles merged
  const auto& right = robot.links[static_cast<std::size_t>(robot.findLink("r_foot"))].collisions;
  ASSERT_EQ(right.size(), 1u);
  EXPECT_EQ(right[0].hull.vertices_S.size(), 8u);  // the frustum OBJ without its inner vertex
  // Each hull vertex is the file's own point (assimp reads floats), not Bullet's copy of it.
  for (const Eigen::Vector3f& corner : {Eigen::Vector3f(0.1f, -0.05f, -0.01f), Eigen::Vector3f(-0.08f, 0.04f, 0.01f)}) {
    const Eigen::Vector3d exact = corner.cast<double>();
    EXPECT_EQ(std::count(right[0].hull.vertices_S.begin(), right[0].hull.vertices_S.end(), exact), 1)
        << exact.transpose();
  }
  // Every vertex is on or inside every face plane, and on at least three of them.
  for (const auto* hull : {&left[0].hull, &right[0].hull}) {
    for (const auto& v : hull->vertices_S) {
      int on = 0;
      for (const auto& p : hull->planes_S) {
        const double d = p.head<3>().dot(v) - p[3];
        EXPECT_LE(d, 1e-12);
        on += std::abs(d) < 1e-12;
      }
      EXPECT_GE(on, 3);
    }
  }
}

TEST(UrdfLoader, MeshErrorsNameTheFileAndTheLine) {
  const std::string base = test::testModelPath("");
  const std::string link = R"(  <joint name="foot_joint" type="fixed"><parent link="upper"/><child link="foot"/></joint>
  <link name="foot">
    <collision><geometry><mesh filename="{MESH}"{SCALE}/></geometry></collision>
  </link>
)";
  auto withMesh = [&](const std::string& mesh, const std::string& scale) {
    std::string extra = link;
    extra.replace(extra.find("{MESH}"), 6, mesh);
    extra.replace(extra.find("{SCALE}"), 7, scale);
    return arm("revolute", "1", extra);
  };
  auto expectMeshError = [&](const std::string& xml, const std::string& reason,
                             const UrdfLoadOptions& options) {
    try {
      loadUrdfString(xml, "arm.urdf", options, base);
      FAIL() << "expected a ModelError";
    } catch (const ModelError& e) {
      EXPECT_EQ(e.line(), 17) << e.what();
      EXPECT_NE(std::string(e.what()).find("link \"foot\" <mesh>"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
    }
  };
  expectMeshError(withMesh("meshes/missing.stl", ""), "missing.stl\" not found", {});
  expectMeshError(withMesh("package://no_such_package/sole.stl", ""),
                  "package \"no_such_package\"", {{base}, {}});
  expectMeshError(withMesh("package://dynfilter_test_meshes/meshes/box_sole.stl", " scale=\"1 0 1\""),
                  "non-zero", {{base}, {}});
  // A mirrored scale is baked into the hull (outward planes kept), never handed to DART.
  const RobotDescription mirrored = loadUrdfString(
      withMesh("package:///dynfilter_test_meshes/meshes/frustum_sole.obj", " scale=\"1 1 -1\""),
      "arm.urdf", {{base}, {}});
  const auto& flipped = mirrored.links[2].collisions[0].hull;
  for (const auto& v : flipped.vertices_S)
    for (const auto& p : flipped.planes_S) EXPECT_LE(p.head<3>().dot(v) - p[3], 1e-12);
  double top = -1.0;
  for (const auto& v : flipped.vertices_S) top = std::max(top, v.z());
  EXPECT_NEAR(top, 0.01, 1e-8);  // the wide face (z = −0.01) is now on top
  // Relative and file:// paths resolve; the scale is applied.
  const RobotDescription relative = loadUrdfString(
      withMesh("dynfilter_test_meshes/meshes/box_sole.stl", " scale=\"2 1 0.5\""), "arm.urdf", {}, base);
  const auto& hull = relative.links[2].collisions[0].hull;
  double max_x = 0.0, max_z = 0.0;
  for (const auto& v : hull.vertices_S) {
    max_x = std::max(max_x, v.x());
    max_z = std::max(max_z, v.z());
  }
  EXPECT_NEAR(max_x, 0.2, 1e-7);  // assimp reads single precision
  EXPECT_NEAR(max_z, 0.005, 1e-8);
  EXPECT_NO_THROW(loadUrdfString(
      withMesh("file://" + base + "/dynfilter_test_meshes/meshes/frustum_sole.obj", ""), "arm.urdf"));
}

TEST(UrdfLoader, PackageUrisResolveFromTheFoldersAboveTheUrdf) {
  // No --package-path, no ROS_PACKAGE_PATH: a package folder beside (or above) the URDF is
  // found, as in installed descriptions (<share>/<pkg>/robots/<robot>/urdf/robot.urdf).
  const std::string base = test::testModelPath("") + "/dynfilter_test_meshes/meshes";
  const std::string xml = arm("revolute", "1", R"(  <joint name="foot_joint" type="fixed"><parent link="upper"/><child link="foot"/></joint>
  <link name="foot">
    <collision><geometry><mesh filename="package://dynfilter_test_meshes/meshes/box_sole.stl"/></geometry></collision>
  </link>
)");
  const RobotDescription found = loadUrdfString(xml, "arm.urdf", {}, base);
  EXPECT_EQ(found.links[2].collisions[0].hull.vertices_S.size(), 8u);
  // From a folder with no such package above it, the error says where it looked.
  try {
    loadUrdfString(xml, "arm.urdf", {}, "/tmp");
    FAIL() << "expected a ModelError";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("the folders above /tmp"), std::string::npos) << e.what();
  }
}

TEST(UrdfLoader, DanglingLinkReferenceNamesTheJoint) {
  std::string xml = arm();
  xml.replace(xml.find("<child link=\"upper\"/>"), 21, "<child link=\"uper\"/>");
  expectModelError(xml, 8, "joint \"shoulder\"", "child link \"uper\" is not defined");
}

TEST(UrdfLoader, InvertedLimitsAreRejected) {
  std::string xml = arm();
  xml.replace(xml.find("lower=\"-1\" upper=\"1\""), 20, "lower=\"1\" upper=\"-1\"");
  expectModelError(xml, 6, "joint \"shoulder\"", "lower <= upper");
}

TEST(UrdfLoader, UrdfdomErrorsAreReported) {
  // Two roots: urdfdom refuses; its own message comes through.
  const std::string extra = R"(  <link name="orphan"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
)";
  try {
    loadUrdfString(arm("revolute", "1", extra), "arm.urdf");
    FAIL();
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("urdfdom"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("arm.urdf"), std::string::npos) << e.what();
  }
}

TEST(UrdfLoader, FixedJointsCarryNoCoordinate) {
  const RobotDescription robot =
      loadUrdfFile(dynfilter::test::testModelPath("double_pendulum.urdf"));
  ASSERT_EQ(robot.moving_joints.size(), 2u);
  EXPECT_EQ(robot.joints[robot.findJoint("tip_mount")].coordinate, -1);
  EXPECT_EQ(robot.joints[robot.findJoint("elbow")].type, JointType::kContinuous);
  EXPECT_TRUE(std::isinf(robot.joints[robot.findJoint("elbow")].upper));
}

}  // namespace
}  // namespace dynfilter::urdf
