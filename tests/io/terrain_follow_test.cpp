// A motion made on level ground carried onto a slope (dynfilter/io/terrain_follow.hpp):
// every foot keeps its height above the ground beneath it and turns with the plane; level
// ground changes nothing.

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/core/contact.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/io/terrain_follow.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter::io {
namespace {

// A stride: the left leg forward, the right back, the figure standing on level ground and
// moving forward 5 cm between frames (poses only).
ReferenceMotion stride(IDynamicsModel& model) {
  const ModelInfo& info = model.info();
  auto set = [&](Eigen::VectorXd& q, const char* joint, double value) {
    q[info.configurationIndex(info.findJoint(joint))] = value;
  };
  Eigen::VectorXd q = info.neutralConfiguration();
  set(q, "l_hip_pitch", -0.35);
  set(q, "l_knee", 0.2);
  set(q, "l_ankle_pitch", 0.15);
  set(q, "r_hip_pitch", 0.25);
  set(q, "r_knee", 0.3);
  set(q, "r_ankle_pitch", -0.55);
  q[2] = standingBaseHeight(model, q);
  ReferenceMotion motion;
  for (int k = 0; k < 4; ++k) {
    ReferenceFrame f(info.nq, info.nv);
    f.time_s = 0.01 * k;
    f.q = q;
    f.q[0] += 0.05 * k;
    motion.frames.push_back(f);
  }
  return motion;
}

// The feet (bodies the figure stands on) and their sole centres, as the mapping finds them.
struct Sole {
  int body = -1;
  Eigen::Vector3d centre_B = Eigen::Vector3d::Zero();
};

std::vector<Sole> soles(IDynamicsModel& model) {
  ContactList contacts(256);
  standingContacts(model, model.info().neutralConfiguration(), contacts);
  std::vector<Sole> out;
  std::vector<int> count;
  for (const ContactCandidate& c : contacts) {
    std::size_t i = 0;
    while (i < out.size() && out[i].body != c.body) ++i;
    if (i == out.size()) {
      out.push_back({c.body, Eigen::Vector3d::Zero()});
      count.push_back(0);
    }
    out[i].centre_B += c.p_BC;
    ++count[i];
  }
  for (std::size_t i = 0; i < out.size(); ++i) out[i].centre_B /= count[i];
  return out;
}

TEST(TerrainFollow, LevelGroundChangesNothing) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const ReferenceMotion level = stride(*model);
  ReferenceMotion moved = level;
  const TerrainFollowReport report = followTerrain(moved, *model, GroundPlane{});
  EXPECT_EQ(report.feet, 2);
  for (std::size_t k = 0; k < level.frames.size(); ++k)
    EXPECT_LE((moved.frames[k].q - level.frames[k].q).cwiseAbs().maxCoeff(), 1e-6) << "frame " << k;
  EXPECT_LE(report.foot_position_error_max_m, 1e-6);
}

// On a 10° slope descending along x, then along y (the feet are apart in both): each sole's
// origin keeps its vertical height above the plane beneath it, z' − h(x', y') = z, and each
// foot turns by the rotation taking world up to the plane's normal.
TEST(TerrainFollow, FeetKeepTheirHeightAboveTheSlopeAndTurnWithIt) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const ModelInfo& info = model->info();
  const std::vector<Sole> feet = soles(*model);
  ASSERT_EQ(feet.size(), 2u);
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
  for (const double heading : {0.0, 0.5 * M_PI}) {
    SCOPED_TRACE("heading " + std::to_string(heading));
    const ReferenceMotion level = stride(*model);
    const Eigen::Vector3d b0 = level.frames.front().q.head<3>();
    const double slope = 10.0 * test::kRadPerDeg;
    // Through the first base position's ground point (h = 0 there), as dynfilter-offline's.
    const double along = std::cos(heading) * b0.x() + std::sin(heading) * b0.y();
    const GroundPlane plane = GroundPlane::sloped(slope, heading, std::tan(slope) * along);
    const auto h = [&](const Eigen::Vector3d& p) { return plane.heightAt(p.x(), p.y()); };
    ASSERT_NEAR(h(b0), 0.0, 1e-12);
    const Eigen::Matrix3d R_tilt =
        Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), plane.n_W).toRotationMatrix();
    ReferenceMotion moved = level;
    const TerrainFollowReport report = followTerrain(moved, *model, plane);
    EXPECT_EQ(report.feet, 2);
    EXPECT_GT(report.joint_change_rms_rad, 1e-3) << "the legs took up the slope";
    double worst_place = 0.0, worst_turn = 0.0, spread = 0.0;
    for (std::size_t k = 0; k < level.frames.size(); ++k) {
      std::vector<Eigen::Isometry3d> before, after;
      model->setState(level.frames[k].q, v0);
      for (const Sole& f : feet) before.push_back(model->bodyPose(f.body));
      model->setState(moved.frames[k].q, v0);
      for (const Sole& f : feet) after.push_back(model->bodyPose(f.body));
      for (std::size_t i = 0; i < feet.size(); ++i) {
        const Eigen::Vector3d c = before[i] * feet[i].centre_B, c_new = after[i] * feet[i].centre_B;
        Eigen::Vector3d expected = c;
        expected.z() += h(c);  // z' − h(x', y') = z, x' = x, y' = y
        worst_place = std::max(worst_place, (c_new - expected).norm());
        worst_turn = std::max(worst_turn, Eigen::AngleAxisd(after[i].linear() *
                                                            (R_tilt * before[i].linear()).transpose()).angle());
      }
      spread = std::max(spread, std::abs(h(before[0] * feet[0].centre_B) - h(before[1] * feet[1].centre_B)));
    }
    EXPECT_GT(spread, 0.02) << "the two feet stand on ground of different heights";
    EXPECT_LE(worst_place, 1e-5);
    EXPECT_LE(worst_turn, 1e-3);  // the IK's weights: feet 1e3 / m, their orientation 10 / rad
    EXPECT_LE(report.foot_position_error_max_m, 1e-5);
  }
}

TEST(TerrainFollow, AFixedBaseModelIsRejected) {
  ModelOptions fixed;
  fixed.floating_base = false;
  auto arm = test::makeModel("dart", urdf::loadUrdfFile(test::testModelPath("arm7.urdf")), fixed);
  ReferenceMotion motion;
  try {
    followTerrain(motion, *arm, GroundPlane::sloped(0.1));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("floating base"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dynfilter::io
