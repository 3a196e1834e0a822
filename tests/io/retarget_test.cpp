// Retargeting BVH clips onto the human figure (dynfilter/io/retarget.hpp).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/io/reference_cleanup.hpp"
#include "dynfilter/io/retarget.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"
#include "io/io_test_support.hpp"
#include "support/test_support.hpp"

namespace dynfilter::io {
namespace {


std::unique_ptr<IDynamicsModel> humanFigure() {
  return test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
}

struct Clip {
  const char* name;
  const char* bvh;
};
const Clip kClips[] = {{"131_01", "131_01_start_walk_stop.bvh"},
                       {"01_01", "01_01_forward_jumps.bvh"},
                       {"10_01", "10_01_soccer_kick.bvh"}};

std::string clipPath(const Clip& c) { return test::sourcePath(std::string("data/mocap/cmu/") + c.bvh); }
std::string mappingPath(const Clip& c) {
  return test::sourcePath(std::string("data/mocap/cmu/mappings/") + c.name + ".yaml");
}

// A shipped clip read with its mapping's scale and retargeted onto the figure, with the
// BVH joint that drives each mapped link.
struct Retargeted {
  RetargetMapping mapping;
  BvhMotion bvh;
  RetargetResult result;
  std::map<std::string, int> bvh_joint_of_link;
};

Retargeted retargetClip(const Clip& c, IDynamicsModel& model) {
  Retargeted out;
  out.mapping = readRetargetMapping(mappingPath(c));
  BvhReadOptions options;
  options.length_scale = out.mapping.length_scale;
  out.bvh = readBvh(clipPath(c), options);
  out.result = retargetBvh(out.bvh, out.mapping, model);
  for (const RetargetSegment& s : out.mapping.segments)
    out.bvh_joint_of_link[s.link] = out.bvh.findJoint(s.bvh);
  return out;
}

TEST(Retarget, ShippedClipsFrameCountAndTime) {
  auto model = humanFigure();
  for (const Clip& c : kClips) {
    SCOPED_TRACE(c.name);
    const Retargeted clip = retargetClip(c, *model);
    const RetargetMapping& mapping = clip.mapping;
    const BvhMotion& bvh = clip.bvh;
    const RetargetResult& r = clip.result;
    ASSERT_EQ(static_cast<int>(r.motion.frames.size()), bvh.frameCount() - mapping.skip_frames);
    EXPECT_EQ(r.first_bvh_frame, mapping.skip_frames);
    EXPECT_DOUBLE_EQ(r.motion.frames[0].time_s, 0.0);
    EXPECT_NEAR(r.motion.frames[1].time_s, bvh.frame_time_s, 1e-15);
    EXPECT_NEAR(r.motion.frames.back().time_s,
                (bvh.frameCount() - mapping.skip_frames - 1) * bvh.frame_time_s, 1e-9);
    EXPECT_TRUE(r.unmapped_joints.empty());
    ASSERT_EQ(r.limits.size(), static_cast<std::size_t>(model->info().nj));
    for (const ReferenceFrame& f : r.motion.frames) {
      ASSERT_EQ(f.q.size(), model->info().nq);
      ASSERT_EQ(f.v.size(), model->info().nv);
      ASSERT_EQ(f.vdot.size(), model->info().nv);
      ASSERT_TRUE(f.q.allFinite() && f.v.allFinite() && f.vdot.allFinite());
      ASSERT_NEAR(f.q.segment<4>(3).norm(), 1.0, 1e-12);
    }
  }
}

// A window of a clip (dynfilter-bvh2ref --start-s/--end-s) retargets to the frames of the
// whole clip's reference in that window: the chain mode is closed-form per frame, so the base's
// orientation and horizontal position and every joint but the ankles agree; what is calibrated
// over a clip's frames is the window's own: the base's height moves by the difference of the
// ground offsets (the lowest sole point), and the ankles by each sole's levelling (its mean
// tilt over its stance frames).
TEST(Retarget, AWindowOfAClipRetargetsToTheWholeClipsFramesInIt) {
  auto model = humanFigure();
  const Retargeted whole = retargetClip(kClips[0], *model);
  // 3.9 s is frame 467.99 of the file's rounded frame time (0.0083333 s): still frame 468.
  const BvhMotion window = bvhWindow(whole.bvh, whole.mapping.skip_frames, 3.9, 6.3);
  const int first = 468, count = 756 - 468 + 1;
  ASSERT_EQ(window.frameCount(), count);
  EXPECT_EQ(window.skipped_frames, whole.bvh.skipped_frames + first);
  EXPECT_EQ((window.frames - whole.bvh.frames.middleRows(first, count)).cwiseAbs().maxCoeff(), 0.0);
  const RetargetResult part = retargetBvhWindow(whole.bvh, whole.mapping, *model, 3.9, 6.3);
  ASSERT_EQ(static_cast<int>(part.motion.frames.size()), count);
  EXPECT_EQ(part.first_bvh_frame, first);
  EXPECT_DOUBLE_EQ(part.motion.frames[0].time_s, 0.0);
  const double dz = part.ground_offset_m - whole.result.ground_offset_m;
  EXPECT_GT(std::abs(dz), 1e-3);  // the window's lowest sole point is not the clip's
  for (int k = 0; k < count; ++k) {
    const Eigen::VectorXd& a = part.motion.frames[static_cast<std::size_t>(k)].q;
    const Eigen::VectorXd& b = whole.result.motion.frames[static_cast<std::size_t>(first + k)].q;
    ASSERT_LT((a.head<2>() - b.head<2>()).cwiseAbs().maxCoeff(), 1e-12) << "frame " << k;
    ASSERT_NEAR(a[2] - b[2], dz, 1e-12) << "frame " << k;
    ASSERT_LT((a.segment<4>(3) - b.segment<4>(3)).cwiseAbs().maxCoeff(), 1e-12) << "frame " << k;
    for (int j = 0; j < model->info().nj; ++j) {
      const std::string& name = model->info().joint_names[static_cast<std::size_t>(j)];
      const double d = std::abs(a[7 + j] - b[7 + j]);
      if (name.find("ankle") == std::string::npos) {
        ASSERT_LT(d, 1e-6) << name << ", frame " << k;
      } else if (k == 0) {
        EXPECT_GT(d, 1e-3) << name;  // levelled over the window's stance frames
      }
    }
  }
  // The default window is the whole clip; empty or reversed windows are refused by name.
  EXPECT_EQ(bvhWindow(whole.bvh, 0, 0.0, std::numeric_limits<double>::infinity()).frameCount(),
            whole.bvh.frameCount());
  for (const auto& [start, end] : std::vector<std::pair<double, double>>{{9.0, 10.0}, {2.0, 1.0}, {-1.0, 1.0}}) {
    try {
      bvhWindow(whole.bvh, 0, start, end);
      ADD_FAILURE() << "window " << start << " to " << end << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("131_01_start_walk_stop.bvh"), std::string::npos) << e.what();
    }
  }
}

TEST(Retarget, WalkTravelsTwoToFourMetres) {
  auto model = humanFigure();
  const RetargetResult r = retargetBvhFile(clipPath(kClips[0]),
                                           readRetargetMapping(mappingPath(kClips[0])), *model);
  const Eigen::Vector2d d =
      (r.motion.frames.back().q.head<2>() - r.motion.frames.front().q.head<2>());
  std::printf("131_01 walk: horizontal pelvis travel %.3f m\n", d.norm());
  EXPECT_GT(d.norm(), 2.0);
  EXPECT_LT(d.norm(), 4.0);
  // Standing at the start: pelvis at a plausible height, feet on the ground.
  EXPECT_GT(r.motion.frames[0].q[2], 0.75);
  EXPECT_LT(r.motion.frames[0].q[2], 1.0);
}

// Round trip: limb-segment directions of the retargeted figure (model forward kinematics)
// against the BVH's own joint positions, converted to the figure's axes.
TEST(Retarget, RoundTripSegmentDirections) {
  auto model = humanFigure();
  const ModelInfo& info = model->info();
  // Figure segments as (proximal link, distal link): the link origins are the joint centres.
  const std::vector<std::pair<std::string, std::string>> bones = {
      {"l_thigh", "l_shank"},         {"l_shank", "l_foot"},         {"r_thigh", "r_shank"},
      {"r_shank", "r_foot"},          {"l_upper_arm", "l_forearm"},  {"l_forearm", "l_hand"},
      {"r_upper_arm", "r_forearm"},   {"r_forearm", "r_hand"}};
  for (const Clip& c : kClips) {
    SCOPED_TRACE(c.name);
    const Retargeted clip = retargetClip(c, *model);
    const BvhMotion& bvh = clip.bvh;
    const RetargetResult& r = clip.result;
    const std::map<std::string, int>& bvh_of = clip.bvh_joint_of_link;
    const Eigen::Matrix3d& R_conv = r.axis_conversion;
    std::vector<double> sum(bones.size(), 0.0), worst(bones.size(), 0.0);
    double pelvis_err_max = 0.0;
    int n = 0;
    std::vector<Eigen::Isometry3d> X;
    const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
    for (std::size_t k = 0; k < r.motion.frames.size(); k += 25, ++n) {
      const Eigen::VectorXd& q = r.motion.frames[k].q;
      model->setState(q, v0);
      bvhForwardKinematics(bvh, static_cast<int>(k) + r.first_bvh_frame, X);
      auto bvhPos = [&](const std::string& link) {
        Eigen::Vector3d p = R_conv * X[static_cast<std::size_t>(bvh_of.at(link))].translation();
        p.z() += r.ground_offset_m;
        return p;
      };
      // The base is the BVH's mid-hip point, same vertical offset.
      const Eigen::Vector3d mid = 0.5 * (bvhPos("l_thigh") + bvhPos("r_thigh"));
      pelvis_err_max = std::max(pelvis_err_max, (mid - q.head<3>()).norm());
      for (std::size_t b = 0; b < bones.size(); ++b) {
        const Eigen::Vector3d fig =
            model->bodyPose(info.findBody(bones[b].second)).translation() -
            model->bodyPose(info.findBody(bones[b].first)).translation();
        const Eigen::Vector3d cap = bvhPos(bones[b].second) - bvhPos(bones[b].first);
        const double angle = std::acos(std::clamp(fig.normalized().dot(cap.normalized()), -1.0, 1.0));
        sum[b] += angle;
        worst[b] = std::max(worst[b], angle);
      }
    }
    EXPECT_LT(pelvis_err_max, 1e-9);
    // Measured: thigh, shank, upper arm, forearm directions agree to < 3° at every sampled
    // frame of the three clips (mostly to 1e-6°); the bound below is the brief's.
    std::printf("%s round trip (%d frames): mean / worst angle between figure and BVH segment\n",
                c.name, n);
    for (std::size_t b = 0; b < bones.size(); ++b) {
      const double mean = sum[b] / n;
      std::printf("  %-12s -> %-10s %6.2f / %6.2f deg\n", bones[b].first.c_str(),
                  bones[b].second.c_str(), mean / test::kRadPerDeg, worst[b] / test::kRadPerDeg);
      EXPECT_LT(mean, 15.0 * test::kRadPerDeg) << bones[b].first;
    }
  }
}

// Feet, hands and head relative to the pelvis, figure vs BVH (proportions differ: loose
// bounds, the numbers are printed for the record).
TEST(Retarget, RoundTripEndEffectorsRelativeToPelvis) {
  auto model = humanFigure();
  const ModelInfo& info = model->info();
  const std::vector<std::string> links = {"l_foot", "r_foot", "l_hand", "r_hand", "head"};
  for (const Clip& c : kClips) {
    SCOPED_TRACE(c.name);
    const Retargeted clip = retargetClip(c, *model);
    const BvhMotion& bvh = clip.bvh;
    const RetargetResult& r = clip.result;
    const std::map<std::string, int>& bvh_of = clip.bvh_joint_of_link;
    std::vector<double> dir_sum(links.size(), 0.0), dist_sum(links.size(), 0.0);
    int n = 0;
    std::vector<Eigen::Isometry3d> X;
    for (std::size_t k = 0; k < r.motion.frames.size(); k += 25, ++n) {
      const Eigen::VectorXd& q = r.motion.frames[k].q;
      model->setState(q, Eigen::VectorXd::Zero(info.nv));
      bvhForwardKinematics(bvh, static_cast<int>(k) + r.first_bvh_frame, X);
      for (std::size_t i = 0; i < links.size(); ++i) {
        const Eigen::Vector3d fig =
            model->bodyPose(info.findBody(links[i])).translation() - q.head<3>();
        const Eigen::Vector3d mid =
            0.5 * (X[static_cast<std::size_t>(bvh_of.at("l_thigh"))].translation() +
                   X[static_cast<std::size_t>(bvh_of.at("r_thigh"))].translation());
        const Eigen::Vector3d cap =
            r.axis_conversion * (X[static_cast<std::size_t>(bvh_of.at(links[i]))].translation() - mid);
        dir_sum[i] += std::acos(std::clamp(fig.normalized().dot(cap.normalized()), -1.0, 1.0));
        dist_sum[i] += (fig - cap).norm();
      }
    }
    std::printf("%s joint centres relative to the pelvis: mean direction error / distance\n",
                c.name);
    for (std::size_t i = 0; i < links.size(); ++i) {
      std::printf("  %-7s %6.2f deg  %.3f m\n", links[i].c_str(), dir_sum[i] / n / test::kRadPerDeg,
                  dist_sum[i] / n);
      // Measured (mean over every 25th frame): feet ≤ 2.3°, head ≤ 10.6°, hands ≤ 25.7°
      // (the figure's shoulders and trunk are placed differently from the actor's, and the
      // pelvis-to-hand vector is short); distances ≤ 0.17 m.
      const bool hand = links[i].find("hand") != std::string::npos;
      const bool foot = links[i].find("foot") != std::string::npos;
      EXPECT_LT(dir_sum[i] / n, (hand ? 35.0 : foot ? 5.0 : 15.0) * test::kRadPerDeg) << links[i];
      EXPECT_LT(dist_sum[i] / n, 0.20) << links[i];
    }
  }
}

// A tiny BVH whose rest pose is the figure's q = 0 and whose channels are the figure's
// joint chains (BVH X = figure Y, BVH Y = figure Z, BVH Z = figure X).
constexpr const char* kSyntheticBvh = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Yrotation Zrotation Xrotation
  JOINT LUp
  {
    OFFSET 0.09 0 0
    CHANNELS 3 Yrotation Zrotation Xrotation
    JOINT LLeg
    {
      OFFSET 0 -0.42 0
      CHANNELS 1 Xrotation
      JOINT LFoot
      {
        OFFSET 0 -0.44 0
        CHANNELS 2 Xrotation Zrotation
        End Site
        {
          OFFSET 0 0 0.2
        }
      }
    }
  }
  JOINT RUp
  {
    OFFSET -0.09 0 0
    CHANNELS 3 Yrotation Zrotation Xrotation
    JOINT RLeg
    {
      OFFSET 0 -0.42 0
      CHANNELS 1 Xrotation
      JOINT RFoot
      {
        OFFSET 0 -0.44 0
        CHANNELS 2 Xrotation Zrotation
        End Site
        {
          OFFSET 0 0 0.2
        }
      }
    }
  }
  JOINT Chest
  {
    OFFSET 0 0.15 0
    CHANNELS 3 Yrotation Zrotation Xrotation
    JOINT Head
    {
      OFFSET 0 0.46 0
      CHANNELS 3 Yrotation Zrotation Xrotation
      End Site
      {
        OFFSET 0 0.2 0
      }
    }
    JOINT LArm
    {
      OFFSET 0.175 0.37 0
      CHANNELS 3 Xrotation Zrotation Yrotation
      JOINT LFore
      {
        OFFSET 0 -0.28 0
        CHANNELS 2 Xrotation Yrotation
        JOINT LHand
        {
          OFFSET 0 -0.27 0
          CHANNELS 2 Xrotation Zrotation
          End Site
          {
            OFFSET 0 -0.08 0
          }
        }
      }
    }
    JOINT RArm
    {
      OFFSET -0.175 0.37 0
      CHANNELS 3 Xrotation Zrotation Yrotation
      JOINT RFore
      {
        OFFSET 0 -0.28 0
        CHANNELS 2 Xrotation Yrotation
        JOINT RHand
        {
          OFFSET 0 -0.27 0
          CHANNELS 2 Xrotation Zrotation
          End Site
          {
            OFFSET 0 -0.08 0
          }
        }
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.01
)";

constexpr const char* kSyntheticMapping = R"(length_scale: 1
skip_frames: 1
up_axis: +y
bvh_forward: +z
root: {bvh: Hips, link: pelvis, position: [LUp, RUp]}
segments:
  - {link: torso, bvh: Chest, figure_bone: [0, 0, 1]}
  - {link: head, bvh: Head, figure_bone: [0, 0, 1]}
  - {link: l_thigh, bvh: LUp, hinge_twist: false}
  - {link: l_shank, bvh: LLeg}
  - {link: l_foot, bvh: LFoot, figure_bone: [1, 0, 0]}
  - {link: r_thigh, bvh: RUp, hinge_twist: false}
  - {link: r_shank, bvh: RLeg}
  - {link: r_foot, bvh: RFoot, figure_bone: [1, 0, 0]}
  - {link: l_upper_arm, bvh: LArm, hinge_twist: false}
  - {link: l_forearm, bvh: LFore}
  - {link: l_hand, bvh: LHand}
  - {link: r_upper_arm, bvh: RArm, hinge_twist: false}
  - {link: r_forearm, bvh: RFore}
  - {link: r_hand, bvh: RHand}
)";

// Figure joint angles (deg) in model order for one synthetic frame, and the BVH line.
struct SyntheticFrame {
  Eigen::Vector3d root_pos;       // BVH axes
  Eigen::Vector3d root_rot_deg;   // yaw, roll, pitch (BVH Y, Z, X)
  std::map<std::string, double> deg;
};

std::string bvhLine(const SyntheticFrame& f) {
  auto d = [&](const char* j) { return f.deg.at(j); };
  std::vector<double> v = {f.root_pos.x(), f.root_pos.y(), f.root_pos.z(), f.root_rot_deg[0],
                           f.root_rot_deg[1], f.root_rot_deg[2]};
  for (const char* s : {"l", "r"}) {
    const std::string p(s);
    for (const char* j : {"_hip_yaw", "_hip_roll", "_hip_pitch", "_knee", "_ankle_pitch",
                          "_ankle_roll"})
      v.push_back(d((p + j).c_str()));
  }
  for (const char* j : {"waist_yaw", "waist_roll", "waist_pitch", "neck_yaw", "neck_roll",
                        "neck_pitch"})
    v.push_back(d(j));
  for (const char* s : {"l", "r"}) {
    const std::string p(s);
    v.push_back(d((p + "_shoulder_pitch").c_str()));
    v.push_back(d((p + "_shoulder_roll").c_str()));
    v.push_back(d((p + "_shoulder_yaw").c_str()));
    v.push_back(-d((p + "_elbow").c_str()));  // elbow axis is the figure's −y
    v.push_back(d((p + "_forearm_yaw").c_str()));
    v.push_back(d((p + "_wrist_pitch").c_str()));
    v.push_back(d((p + "_wrist_roll").c_str()));
  }
  std::string line;
  char buf[64];
  for (double x : v) {
    std::snprintf(buf, sizeof buf, "%s%.17g", line.empty() ? "" : " ", x);
    line += buf;
  }
  return line + "\n";
}

SyntheticFrame syntheticFrame(double s) {
  SyntheticFrame f;
  f.root_pos = Eigen::Vector3d(0.3 * s, 0.9, -0.2 * s);
  f.root_rot_deg = Eigen::Vector3d(25.0 * s, -7.5 * s, 12.0 * s);
  const char* names[] = {"waist_yaw", "waist_roll", "waist_pitch", "neck_yaw", "neck_roll",
                         "neck_pitch", "l_hip_yaw", "l_hip_roll", "l_hip_pitch", "l_knee",
                         "l_ankle_pitch", "l_ankle_roll", "r_hip_yaw", "r_hip_roll",
                         "r_hip_pitch", "r_knee", "r_ankle_pitch", "r_ankle_roll",
                         "l_shoulder_pitch", "l_shoulder_roll", "l_shoulder_yaw", "l_elbow",
                         "l_forearm_yaw", "l_wrist_pitch", "l_wrist_roll", "r_shoulder_pitch",
                         "r_shoulder_roll", "r_shoulder_yaw", "r_elbow", "r_forearm_yaw",
                         "r_wrist_pitch", "r_wrist_roll"};
  const double values[] = {10, -5, 20, -30, 8, 12, 15, 10, -60, 70, 20, -10, -12, -8, -45, 35,
                           -15, 12, -50, 30, 40, 80, 45, 10, -30, 20, -25, -35, 60, -50, -15, 40};
  for (std::size_t i = 0; i < std::size(names); ++i) f.deg[names[i]] = s * values[i];
  f.deg["r_knee"] = -20.0 * s;  // hyperextension: outside [0, 150] deg
  return f;
}

TEST(Retarget, SyntheticBvhMapsToKnownAngles) {
  auto model = humanFigure();
  const ModelInfo& info = model->info();
  const std::string path = ::testing::TempDir() + "/retarget_synthetic.bvh";
  const SyntheticFrame frames[] = {syntheticFrame(0.0), syntheticFrame(1.0), syntheticFrame(0.5)};
  {
    std::ofstream out(path);
    out << kSyntheticBvh;
    for (const SyntheticFrame& f : frames) out << bvhLine(f);
  }
  for (const bool clamp : {false, true}) {
    SCOPED_TRACE(clamp ? "clamped" : "not clamped");
    RetargetMapping mapping = parseRetargetMapping(kSyntheticMapping, "synthetic.yaml");
    mapping.clamp_to_limits = clamp;
    const RetargetResult r = retargetBvhFile(path, mapping, *model);
    ASSERT_EQ(r.motion.frames.size(), 2u);
    for (std::size_t k = 0; k < 2; ++k) {
      const SyntheticFrame& f = frames[k + 1];
      const Eigen::VectorXd& q = r.motion.frames[k].q;
      for (int j = 0; j < info.nj; ++j) {
        const std::string& name = info.joint_names[static_cast<std::size_t>(j)];
        double expected = f.deg.at(name) * test::kRadPerDeg;
        if (clamp) expected = std::clamp(expected, info.q_lower[j], info.q_upper[j]);
        EXPECT_NEAR(q[info.configurationIndex(j)], expected, 1e-9) << name << " frame " << k;
      }
      const Eigen::Matrix3d R_expected =
          (Eigen::AngleAxisd(f.root_rot_deg[0] * test::kRadPerDeg, Eigen::Vector3d::UnitZ()) *
           Eigen::AngleAxisd(f.root_rot_deg[1] * test::kRadPerDeg, Eigen::Vector3d::UnitX()) *
           Eigen::AngleAxisd(f.root_rot_deg[2] * test::kRadPerDeg, Eigen::Vector3d::UnitY()))
              .toRotationMatrix();
      const Eigen::Quaterniond quat(q[3], q[4], q[5], q[6]);
      EXPECT_LT((quat.toRotationMatrix() - R_expected).norm(), 1e-9);
      EXPECT_NEAR(q[0], f.root_pos.z(), 1e-12);
      EXPECT_NEAR(q[1], f.root_pos.x(), 1e-12);
      EXPECT_NEAR(q[2], f.root_pos.y() + r.ground_offset_m, 1e-12);
    }
    // The hyperextended right knee is reported, with its excess, and kept unless clamping.
    const JointLimitReport& knee =
        r.limits[static_cast<std::size_t>(info.findJoint("r_knee"))];
    EXPECT_EQ(knee.frames_outside, 2);
    EXPECT_DOUBLE_EQ(knee.fraction_outside, 1.0);
    EXPECT_NEAR(knee.worst_excess_rad, 20.0 * test::kRadPerDeg, 1e-9);
    EXPECT_EQ(knee.worst_frame, 0);
    EXPECT_EQ(r.clamped, clamp);
    EXPECT_NE(formatLimitReport(r).find("r_knee"), std::string::npos);
    const JointLimitReport& l_knee =
        r.limits[static_cast<std::size_t>(info.findJoint("l_knee"))];
    EXPECT_EQ(l_knee.frames_outside, 0);
  }
}

// Standing still for 40 frames with the BVH's ankles rolled by 15° (left) and −10°
// (right), the left knee bent under a flexed hip (shank vertical): every frame is a stance
// frame of both feet. With flat_soles (the default) each
// sole's calibration turns by its roll and the soles stand level (ankle roll 0, every other
// joint unchanged); with flat_soles: false the rolls stay.
TEST(Retarget, SolesAreLevelledOverTheirStanceFrames) {
  auto model = humanFigure();
  const ModelInfo& info = model->info();
  const std::string path = ::testing::TempDir() + "/retarget_rolled_soles.bvh";
  SyntheticFrame f = syntheticFrame(0.0);
  f.deg["l_ankle_roll"] = 15.0;
  f.deg["r_ankle_roll"] = -10.0;
  f.deg["l_hip_pitch"] = -30.0;  // the thigh forward, the shank vertical again
  f.deg["l_knee"] = 30.0;
  {
    std::ofstream out(path);
    std::string text = kSyntheticBvh;
    text.replace(text.find("Frames: 3"), 9, "Frames: 41");
    out << text;
    for (int k = 0; k < 41; ++k) out << bvhLine(f);
  }
  for (const bool flat : {true, false}) {
    SCOPED_TRACE(flat ? "flat_soles" : "flat_soles: false");
    RetargetMapping mapping = parseRetargetMapping(
        std::string(kSyntheticMapping) + (flat ? "" : "flat_soles: false\n"), "synthetic.yaml");
    const RetargetResult r = retargetBvhFile(path, mapping, *model);
    ASSERT_EQ(r.motion.frames.size(), 40u);
    ASSERT_EQ(r.soles.size(), flat ? 2u : 0u);
    const Eigen::VectorXd& q = r.motion.frames[20].q;
    auto angle = [&](const char* joint) { return q[info.configurationIndex(info.findJoint(joint))]; };
    EXPECT_NEAR(angle("l_ankle_roll"), flat ? 0.0 : 15.0 * test::kRadPerDeg, 1e-9);
    EXPECT_NEAR(angle("r_ankle_roll"), flat ? 0.0 : -10.0 * test::kRadPerDeg, 1e-9);
    EXPECT_NEAR(angle("l_knee"), 30.0 * test::kRadPerDeg, 1e-9);
    EXPECT_NEAR(angle("l_ankle_pitch"), 0.0, 1e-9);
    for (const SoleCalibration& c : r.soles) {
      EXPECT_GE(c.stance_frames, 10) << c.link;
      EXPECT_TRUE(c.levelled) << c.link;
      EXPECT_NEAR(c.angle_rad, (c.link == "l_foot" ? 15.0 : 10.0) * test::kRadPerDeg, 1e-9) << c.link;
    }
  }
}

TEST(Retarget, DecomposeRotationRoundTrips) {
  const std::vector<std::vector<Eigen::Vector3d>> chains = {
      {Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY()},
      {Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitZ()},
      {-Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ()},
      {Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitX()},
      {-Eigen::Vector3d::UnitY()}};
  const double angles[] = {0.7, -1.2, 2.5};
  for (const auto& axes : chains) {
    Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
    for (std::size_t a = 0; a < axes.size(); ++a)
      R = R * Eigen::AngleAxisd(angles[a], axes[a]).toRotationMatrix();
    const std::vector<double> out = decomposeRotation(R, axes);
    ASSERT_EQ(out.size(), axes.size());
    for (std::size_t a = 0; a < axes.size(); ++a) EXPECT_NEAR(out[a], angles[a], 1e-12);
  }
  EXPECT_THROW(decomposeRotation(Eigen::Matrix3d::Identity(),
                                 {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitX()}),
               std::invalid_argument);
}

TEST(Retarget, MappingErrorsNameTheLine) {
  try {
    parseRetargetMapping("length_scale: 1\nsegments:\n  - {link: l_thigh, bvh: A, colour: red}\n",
                         "m.yaml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 3);
    EXPECT_NE(e.reason().find("colour"), std::string::npos);
  }
  EXPECT_THROW(parseRetargetMapping("up_axis: +y\nbvh_forward: -y\nsegments: []\n", "m.yaml"),
               InputError);
  EXPECT_THROW(parseRetargetMapping("length_scale: -1\nsegments: []\n", "m.yaml"), InputError);
  EXPECT_THROW(parseRetargetMapping("segments: [\n", "m.yaml"), InputError);
  // The clean-up's balance keys; a bad value is named.
  const RetargetMapping balanced = parseRetargetMapping(
      "segments: []\ncleanup: {balance: false, max_com_shift_m: 0.1, balance_iterations: 2}\n", "m.yaml");
  EXPECT_FALSE(balanced.cleanup.balance);
  EXPECT_EQ(balanced.cleanup.max_com_shift_m, 0.1);
  EXPECT_EQ(balanced.cleanup.balance_iterations, 2);
  EXPECT_TRUE(ReferenceCleanupOptions{}.balance);
  try {
    parseRetargetMapping("segments: []\ncleanup: {max_com_shift_m: 0}\n", "m.yaml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 2);
    EXPECT_NE(e.reason().find("max_com_shift_m"), std::string::npos) << e.reason();
  }
  // A BVH joint that the file does not have: the mapping's line.
  auto model = humanFigure();
  const RetargetMapping mapping = parseRetargetMapping(
      "root: {bvh: Hips, link: pelvis}\nsegments:\n  - {link: l_thigh, bvh: NoSuchJoint}\n",
      "m.yaml");
  try {
    retargetBvhFile(clipPath(kClips[0]), mapping, *model);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 3);
    EXPECT_NE(e.reason().find("NoSuchJoint"), std::string::npos);
  }
}


// The clean-up on the shipped clips: stance feet still and on the ground, and no frame where
// the IK jumps to another branch of its solutions (before the continuity term the walk's
// base moved 0.23 m and a knee 0.9 rad between two frames 8 ms apart, and its feet skated
// 44 / 75 mm where a stance target was out of reach).
TEST(ReferenceCleanup, ShippedClipsHaveStillFeetAndNoJumps) {
  auto model = humanFigure();
  const ModelInfo& info = model->info();
  for (const Clip& c : kClips) {
    SCOPED_TRACE(c.name);
    const Retargeted clip = retargetClip(c, *model);
    const CleanupResult r = cleanupReference(clip.result.motion, *model, clip.mapping.cleanup, proxqp::factory());
    for (const FootReport& f : r.report.feet) {
      EXPECT_GT(f.stance_runs, 0) << f.link;
      EXPECT_EQ(f.tilted_runs, 0) << f.link << ": a six-joint leg lays its sole flat";
      // Measured: at most 1.4 mm (the jump's left foot) since the clean-up low-passes its
      // answer and solves again; the issue's target is 5 mm per stance.
      EXPECT_LT(f.skate_after_m, 2e-3) << f.link;
      EXPECT_LT(f.penetration_after_m, 4e-3) << f.link;
    }
    EXPECT_EQ(r.report.joints_outside_after, 0);
    // Largest change between two frames, cleaned against retargeted: the clean-up adds none
    // of its own (the retargeting's own jumps, e.g. an arm through an Euler singularity,
    // are the retargeting's).
    auto largestStep = [&](const std::vector<ReferenceFrame>& frames, int coordinate) {
      double step = 0.0;
      for (std::size_t k = 1; k < frames.size(); ++k)
        step = std::max(step, coordinate < 0 ? (frames[k].q.head<3>() - frames[k - 1].q.head<3>()).norm()
                                              : std::fabs(frames[k].q[coordinate] - frames[k - 1].q[coordinate]));
      return step;
    };
    // The base's acceleration (second difference at the clip's rate), 90th percentile:
    // the raw retargeting's is 8-43 m/s^2; the clean-up's was 79 on the walk with 80 ms
    // stance ramps and an IK that took steps raising its objective, 48 now.
    {
      const auto& f = r.motion.frames;
      std::vector<double> acc;
      for (std::size_t k = 1; k + 1 < f.size(); ++k) {
        const double h = f[k + 1].time_s - f[k].time_s;
        acc.push_back((f[k + 1].q.head<3>() - 2.0 * f[k].q.head<3>() + f[k - 1].q.head<3>()).norm() / (h * h));
      }
      std::sort(acc.begin(), acc.end());
      EXPECT_LT(acc[acc.size() * 9 / 10], 60.0) << "base acceleration p90, m/s^2";
    }
    const auto& raw = clip.result.motion.frames;
    EXPECT_LT(largestStep(r.motion.frames, -1), largestStep(raw, -1) + 0.1);
    for (int j = 0; j < info.nj; ++j) {
      const int qi = info.configurationIndex(j);
      EXPECT_LT(largestStep(r.motion.frames, qi), largestStep(raw, qi) + 0.4) << info.joint_names[static_cast<std::size_t>(j)];
    }
  }
}

// A leg of five joints (the figure's ankle rolls welded, as on robots without one) cannot
// lay its sole flat where the capture's slanted leg puts it. Flat stance poses made the
// clean-up buy the missing roll with the body: on the walk's first 2.5 s the pelvis turned
// by up to 0.41 rad from the reference's. The pose the leg reaches with the body held keeps
// the pelvis nearer and the feet still.
TEST(ReferenceCleanup, AFiveJointLegKeepsTheTiltItReachesInsteadOfBendingTheBody) {
  urdf::UrdfLoadOptions lock;
  lock.lock_joints = {"l_ankle_roll", "r_ankle_roll"};
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath(), lock), ModelOptions{});
  Retargeted clip = retargetClip(kClips[0], *model);
  auto& frames = clip.result.motion.frames;
  frames.resize(std::min<std::size_t>(frames.size(), 300));  // 2.5 s at 120 Hz
  ReferenceCleanupOptions options = clip.mapping.cleanup;
  options.balance = false;  // the feet's stage alone (the balance stage moves the base on purpose)
  const CleanupResult r = cleanupReference(clip.result.motion, *model, options, proxqp::factory());
  double moved_m = 0.0, turned_rad = 0.0;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const Eigen::VectorXd& a = frames[k].q;
    const Eigen::VectorXd& b = r.motion.frames[k].q;
    moved_m = std::max(moved_m, (b.head<3>() - a.head<3>()).norm());
    const Eigen::Quaterniond qa(a[3], a[4], a[5], a[6]), qb(b[3], b[4], b[5], b[6]);
    turned_rad = std::max(turned_rad, qa.angularDistance(qb));
  }
  // Measured: 0.31 m and 0.20 rad (flat poses: 0.32 m and 0.41 rad). The translation is
  // the six-joint figure's too (0.2 m where a stance leg is at its reach).
  EXPECT_LT(moved_m, 0.4);
  EXPECT_LT(turned_rad, 0.3);
  int tilted = 0;
  for (const FootReport& f : r.report.feet) {
    tilted += f.tilted_runs;
    EXPECT_LT(f.tilt_max_rad, 0.35) << f.link;
    EXPECT_LT(f.skate_after_m, 5e-3) << f.link;
    EXPECT_LT(f.penetration_after_m, 4e-3) << f.link;
  }
  EXPECT_GT(tilted, 0) << "the capture's feet are narrower than the hips: some stance is not flat";
}

}  // namespace
}  // namespace dynfilter::io
