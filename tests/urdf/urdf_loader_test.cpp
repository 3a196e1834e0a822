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

TEST(UrdfLoader, ZeroMassOnAMovingJointIsRejectedForDynamics) {
  expectModelError(arm("revolute", "0"), 12, "link \"upper\"",
                   "zero mass on a link moved by joint \"shoulder\"", true);
}

TEST(UrdfLoader, ZeroMassOnAFixedJointIsAccepted) {
  const RobotDescription robot = loadUrdfString(arm("fixed", "0"), "arm.urdf");
  EXPECT_NO_THROW(validateForDynamics(robot, true));
}

TEST(UrdfLoader, NonPhysicalInertiaIsRejected) {
  std::string xml = arm();
  const std::string good = R"(<mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01")";
  xml.replace(xml.find(good), good.size(),
              R"(<mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.05")");
  expectModelError(xml, 12, "link \"upper\"", "triangle inequality", true);
}

TEST(UrdfLoader, UnknownElementIsRejected) {
  expectModelError(arm("revolute", "1", "  <lnk name=\"typo\"/>\n"), 15, "<robot>",
                   "unknown element <lnk>");
  std::string xml = arm();
  xml.replace(xml.find("<axis"), 5, "<axes");
  expectModelError(xml, 9, "joint \"shoulder\"", "unknown element <axes>");
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
