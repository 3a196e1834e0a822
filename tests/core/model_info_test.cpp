#include <limits>

#include <gtest/gtest.h>

#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/model_info.hpp"

namespace dynfilter {
namespace {

ModelInfo twoJointFloating() {
  ModelInfo info;
  info.name = "test";
  info.floating_base = true;
  info.nj = 2;
  info.nq = 9;
  info.nv = 8;
  info.joint_names = {"a", "b"};
  info.body_names = {"base", "l1", "l2"};
  info.q_lower = Eigen::Vector2d(0.1, -1.0);
  info.q_upper = Eigen::Vector2d(1.0, 1.0);
  info.v_max = info.tau_max = Eigen::Vector2d(1, 1);
  return info;
}

TEST(ModelInfo, AcceptsAUnitQuaternion) {
  const ModelInfo info = twoJointFloating();
  Eigen::VectorXd q = info.neutralConfiguration();
  EXPECT_TRUE(info.checkState(q, Eigen::VectorXd::Zero(8)).ok);
  EXPECT_DOUBLE_EQ(q[3], 1.0);
  EXPECT_DOUBLE_EQ(q[7], 0.1);  // neutral clamped into [0.1, 1]
}

TEST(ModelInfo, RejectsNonUnitQuaternionWithAClearMessage) {
  const ModelInfo info = twoJointFloating();
  Eigen::VectorXd q = info.neutralConfiguration();
  q.segment<4>(3) << 1.0, 0.1, 0.0, 0.0;  // norm 1.00499
  const StateCheck check = info.checkState(q, Eigen::VectorXd::Zero(8));
  EXPECT_FALSE(check.ok);
  EXPECT_EQ(check.index, 3);
  try {
    info.requireValidState(q, Eigen::VectorXd::Zero(8));
    FAIL() << "expected InvalidStateError";
  } catch (const InvalidStateError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("quaternion"), std::string::npos) << msg;
    EXPECT_NE(msg.find("not unit norm"), std::string::npos) << msg;
    EXPECT_NE(msg.find("norm 1.00499"), std::string::npos) << msg;
    EXPECT_NE(msg.find("tolerance 1e-06"), std::string::npos) << msg;
  }
}

TEST(ModelInfo, RejectsNaNAndWrongSizesNamingTheEntry) {
  const ModelInfo info = twoJointFloating();
  Eigen::VectorXd q = info.neutralConfiguration();
  Eigen::VectorXd v = Eigen::VectorXd::Zero(8);
  v[6] = std::numeric_limits<double>::quiet_NaN();
  try {
    info.requireValidState(q, v);
    FAIL();
  } catch (const InvalidStateError& e) {
    EXPECT_NE(std::string(e.what()).find("v[6] is not finite"), std::string::npos) << e.what();
  }
  EXPECT_THROW(info.requireValidState(Eigen::VectorXd::Zero(3), Eigen::VectorXd::Zero(8)),
               InvalidStateError);
}

TEST(ModelInfo, FindsJointsAndBodiesByName) {
  const ModelInfo info = twoJointFloating();
  EXPECT_EQ(info.findJoint("b"), 1);
  EXPECT_EQ(info.findJoint("zz"), -1);
  EXPECT_EQ(info.findBody("l2"), 2);
  EXPECT_EQ(info.velocityIndex(1), 7);
  EXPECT_EQ(info.configurationIndex(1), 8);
}

}  // namespace
}  // namespace dynfilter
