// The project's human figure: generated from de Leva (1996), loaded by every backend.
#include <cstdlib>
#include <fstream>
#include <random>
#include <set>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

nlohmann::json metadata() {
  std::ifstream in(test::sourcePath("models/human_figure.json"));
  return nlohmann::json::parse(in);
}

class HumanFigure : public testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    robot_ = urdf::loadUrdfFile(test::humanFigurePath());
    model_ = test::makeModel(GetParam(), robot_, ModelOptions{});
    meta_ = metadata();
  }
  Eigen::Vector3d centerOfMass() const {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < robot_.links.size(); ++k)
      c += robot_.links[k].inertial.mass_kg *
           (model_->bodyPose(static_cast<int>(k)) * robot_.links[k].inertial.p_LCom);
    return c / model_->info().total_mass;
  }
  urdf::RobotDescription robot_;
  std::unique_ptr<IDynamicsModel> model_;
  nlohmann::json meta_;
};

TEST_P(HumanFigure, HasTheDocumentedJointsAndMass) {
  const ModelInfo& info = model_->info();
  EXPECT_GE(info.nj, 30);
  EXPECT_EQ(info.nv, 6 + info.nj);
  EXPECT_EQ(info.joint_names, meta_["joint_names"].get<std::vector<std::string>>());
  EXPECT_NEAR(info.total_mass, meta_["mass_kg"].get<double>(), 1e-9);
  // 3-DoF hips, shoulders, waist and neck; knees and elbows; 2-DoF ankles.
  const std::set<std::string> names(info.joint_names.begin(), info.joint_names.end());
  for (const char* j : {"waist_yaw", "waist_roll", "waist_pitch", "neck_yaw", "neck_roll",
                        "neck_pitch", "l_hip_yaw", "l_hip_roll", "l_hip_pitch", "r_knee",
                        "l_ankle_pitch", "r_ankle_roll", "r_shoulder_pitch",
                        "r_shoulder_roll", "r_shoulder_yaw", "l_elbow"})
    EXPECT_TRUE(names.count(j)) << j;
}

TEST_P(HumanFigure, EveryJointHasFiniteRealisticLimits) {
  const ModelInfo& info = model_->info();
  for (int j = 0; j < info.nj; ++j) {
    SCOPED_TRACE(info.joint_names[j]);
    EXPECT_LT(info.q_lower[j], info.q_upper[j]);
    EXPECT_LE(info.q_upper[j] - info.q_lower[j], 2 * M_PI);
    EXPECT_GT(info.tau_max[j], 5.0);
    EXPECT_LT(info.tau_max[j], 400.0);
    EXPECT_GT(info.v_max[j], 1.0);
    EXPECT_LT(info.v_max[j], 40.0);
  }
  EXPECT_GT(info.tau_max[info.findJoint("l_knee")], info.tau_max[info.findJoint("l_elbow")]);
}

TEST_P(HumanFigure, StandsOnBothSolesAtTheNominalHeight) {
  const double z0 = meta_["standing_pelvis_height_m"].get<double>();
  Eigen::VectorXd q = model_->info().neutralConfiguration();
  q[2] = z0 - 0.001;  // 1 mm into the floor
  model_->setState(q, Eigen::VectorXd::Zero(model_->nv()));
  ContactList contacts;
  model_->detectContacts(contacts);
  ASSERT_EQ(contacts.size(), 8u) << "4 sole corners per foot";
  const int l_foot = model_->info().findBody("l_foot");
  const int r_foot = model_->info().findBody("r_foot");
  int left = 0, right = 0;
  for (const ContactCandidate& c : contacts) {
    left += c.body == l_foot;
    right += c.body == r_foot;
    EXPECT_NEAR(c.depth_m, 0.001, 1e-6);
    EXPECT_LT((c.n_W - Eigen::Vector3d::UnitZ()).norm(), 1e-9);
  }
  EXPECT_EQ(left, 4);
  EXPECT_EQ(right, 4);
  // Standing upright: the centre of mass is over the feet at about 55–58 % of stature.
  const Eigen::Vector3d com = centerOfMass();
  const double height = meta_["height_m"].get<double>();
  EXPECT_NEAR(com.y(), 0.0, 1e-9);
  EXPECT_GT(com.z() / height, 0.53);
  EXPECT_LT(com.z() / height, 0.60);
}

TEST_P(HumanFigure, CollisionEngineFindsTheDocumentedStandingHeight) {
  const double z = standingBaseHeight(*model_, model_->info().neutralConfiguration());
  EXPECT_NEAR(z, meta_["standing_pelvis_height_m"].get<double>(), 1e-6);
}

TEST_P(HumanFigure, RandomStatesAreValidAndInsideTheLimits) {
  std::mt19937 rng(3);
  Eigen::VectorXd q, v;
  const ModelInfo& info = model_->info();
  for (int k = 0; k < 1000; ++k) {
    randomState(info, rng, 2.0, q, v);
    ASSERT_TRUE(info.checkState(q, v).ok);
    for (int j = 0; j < info.nj; ++j) {
      EXPECT_GE(q[info.configurationIndex(j)], info.q_lower[j]);
      EXPECT_LE(q[info.configurationIndex(j)], info.q_upper[j]);
    }
    EXPECT_LE(v.cwiseAbs().maxCoeff(), 2.0);
  }
}

TEST_P(HumanFigure, SegmentMassFractionsFollowDeLeva) {
  // de Leva (1996) male: thigh 14.16 %, shank 4.33 %, foot 1.37 %, upper arm 2.71 %.
  const double m = model_->info().total_mass;
  auto segmentMass = [&](const std::string& name) {
    return robot_.links[robot_.findLink(name)].inertial.mass_kg;
  };
  EXPECT_NEAR(segmentMass("l_shank") / m, 0.0433, 0.002);
  EXPECT_NEAR(segmentMass("r_foot") / m, 0.0137, 0.002);
  EXPECT_NEAR(segmentMass("l_upper_arm") / m, 0.0271, 0.002);
  EXPECT_NEAR(segmentMass("r_thigh") / m, 0.1416, 0.003);
}

TEST(HumanFigureGenerator, ScalesWithHeightAndMass) {
  const std::string out = testing::TempDir() + "/small_figure.urdf";
  const std::string cmd = "python3 " + test::sourcePath("models/generate_human_figure.py") +
                          " --height 1.60 --mass 55 -o " + out;
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const auto small = urdf::loadUrdfFile(out);
  const auto nominal = urdf::loadUrdfFile(test::humanFigurePath());
  EXPECT_NEAR(small.totalMass(), 55.0, 1e-9);
  EXPECT_EQ(small.moving_joints.size(), nominal.moving_joints.size());
  const auto& shank_s = small.joints[small.findJoint("l_ankle_pitch")].X_PJ.translation();
  const auto& shank_n = nominal.joints[nominal.findJoint("l_ankle_pitch")].X_PJ.translation();
  EXPECT_NEAR(shank_s.norm() / shank_n.norm(), 1.60 / 1.75, 1e-6);
  EXPECT_NO_THROW(test::makeModel("dart", small, ModelOptions{}));
}

INSTANTIATE_TEST_SUITE_P(AllBackends, HumanFigure, testing::ValuesIn(test::allBackends()),
                         test::BackendName());

}  // namespace
}  // namespace dynfilter
