// BVH motion-capture reader: the three shipped CMU clips (headers, units, T-pose), forward
// kinematics against a hand computation, every malformed case with its line, line endings.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/io/bvh.hpp"
#include "io/io_test_support.hpp"

namespace dynfilter::io {
namespace {

using testing_io::expectInputError;
using testing_io::tempPath;
using testing_io::writeFile;

// The CMU database's own length unit (its ASF files: "length 0.45", i.e. 1/0.45 inch),
// which the 3dsMax- and MotionBuilder-friendly BVH conversions keep.
constexpr double kCmuUnitM = 0.0254 / 0.45;
constexpr double kCentimetreM = 0.01;

std::string clipPath(const std::string& file) {
  return test::sourcePath("data/mocap/cmu/" + file);
}

const std::string kWalk = "131_01_start_walk_stop.bvh";
const std::string kJumps = "01_01_forward_jumps.bvh";
const std::string kKick = "10_01_soccer_kick.bvh";

// ---------------------------------------------------------------------------------------
// The shipped clips

// "Frames:" and "Frame Time:" as written in the file, read here without the library.
void headerOf(const std::string& path, int& frames, double& frame_time) {
  std::ifstream in(path, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t f = text.find("Frames:");
  const std::size_t t = text.find("Frame Time:");
  ASSERT_NE(f, std::string::npos);
  ASSERT_NE(t, std::string::npos);
  frames = std::stoi(text.substr(f + 7, 20));
  frame_time = std::stod(text.substr(t + 11, 30));
}

struct ClipFacts {
  std::string file;
  int frames;         // "Frames:"
  double frame_time;  // "Frame Time:"
  int joints;         // ROOT + JOINT blocks (the README's skeleton size)
  int end_sites;
  int channels;
};

const std::vector<ClipFacts>& clipFacts() {
  static const std::vector<ClipFacts> facts{
      {kWalk, 994, 0.0083333, 31, 7, 96},
      {kJumps, 2752, 0.0083333, 31, 7, 96},
      {kKick, 802, 0.00833333, 43, 14, 132},
  };
  return facts;
}

TEST(BvhClips, FrameCountsFrameTimesAndDurationsMatchTheHeaders) {
  for (const ClipFacts& c : clipFacts()) {
    SCOPED_TRACE(c.file);
    int header_frames = 0;
    double header_time = 0.0;
    headerOf(clipPath(c.file), header_frames, header_time);
    ASSERT_EQ(header_frames, c.frames);
    ASSERT_EQ(header_time, c.frame_time);

    const BvhMotion m = readBvh(clipPath(c.file));
    EXPECT_EQ(m.source, clipPath(c.file));
    EXPECT_EQ(m.frameCount(), c.frames);
    EXPECT_EQ(m.frame_time_s, c.frame_time);
    EXPECT_EQ(m.skipped_frames, 0);
    EXPECT_EQ(m.channelCount(), c.channels);
    EXPECT_DOUBLE_EQ(m.durationS(), (c.frames - 1) * c.frame_time);
    int joints = 0, end_sites = 0;
    for (const BvhJoint& j : m.joints) (j.end_site ? end_sites : joints)++;
    EXPECT_EQ(joints, c.joints);
    EXPECT_EQ(end_sites, c.end_sites);
    EXPECT_TRUE(m.frames.allFinite());
  }
  // 120 frames per second; 8.275 s, 22.925 s and 6.675 s from first to last frame.
  EXPECT_NEAR(readBvh(clipPath(kWalk)).durationS(), 8.275, 1e-3);
  EXPECT_NEAR(readBvh(clipPath(kJumps)).durationS(), 22.925, 1e-3);
  EXPECT_NEAR(readBvh(clipPath(kKick)).durationS(), 6.675, 1e-3);
}

TEST(BvhClips, OnlyTheRootHasPositionChannelsInEveryShippedConversion) {
  // None of the three conversions puts position channels on every joint: each has one
  // ROOT with 6 channels (Xposition Yposition Zposition Zrotation Yrotation Xrotation)
  // and 3 rotation channels on every other joint.
  for (const ClipFacts& c : clipFacts()) {
    SCOPED_TRACE(c.file);
    const BvhMotion m = readBvh(clipPath(c.file));
    ASSERT_FALSE(m.joints.empty());
    EXPECT_EQ(m.joints[0].parent, -1);
    EXPECT_TRUE(m.joints[0].hasPositionChannels());
    EXPECT_EQ(m.joints[0].channels,
              (std::vector<BvhChannel>{BvhChannel::kXposition, BvhChannel::kYposition,
                                       BvhChannel::kZposition, BvhChannel::kZrotation,
                                       BvhChannel::kYrotation, BvhChannel::kXrotation}));
    for (std::size_t j = 1; j < m.joints.size(); ++j) {
      EXPECT_GE(m.joints[j].parent, 0) << m.joints[j].name;
      EXPECT_FALSE(m.joints[j].hasPositionChannels()) << m.joints[j].name;
      EXPECT_EQ(m.joints[j].channels.size(), m.joints[j].end_site ? 0u : 3u) << m.joints[j].name;
    }
  }
}

TEST(BvhClips, RotationOrdersDifferBetweenAndWithinConversions) {
  // 131_01 lists Zrotation Yrotation Xrotation on most joints but Zrotation Xrotation
  // Yrotation on the arms; the DAZ conversion (10_01) uses Z X Y below its root.
  const BvhMotion walk = readBvh(clipPath(kWalk));
  const std::vector<BvhChannel> zyx{BvhChannel::kZrotation, BvhChannel::kYrotation,
                                    BvhChannel::kXrotation};
  const std::vector<BvhChannel> zxy{BvhChannel::kZrotation, BvhChannel::kXrotation,
                                    BvhChannel::kYrotation};
  EXPECT_EQ(walk.joints[static_cast<std::size_t>(walk.findJoint("LeftKnee"))].channels, zyx);
  EXPECT_EQ(walk.joints[static_cast<std::size_t>(walk.findJoint("LeftElbow"))].channels, zxy);
  const BvhMotion kick = readBvh(clipPath(kKick));
  EXPECT_EQ(kick.joints[static_cast<std::size_t>(kick.findJoint("lShin"))].channels, zxy);
}

// Horizontal (X, Z; Y is up) root position at frame k.
Eigen::Vector2d rootXZ(const BvhMotion& m, int k) {
  std::vector<Eigen::Isometry3d> X;
  bvhForwardKinematics(m, k, X);
  return Eigen::Vector2d(X[0].translation().x(), X[0].translation().z());
}

double medianRootHeight(const BvhMotion& m) {
  std::vector<double> y(static_cast<std::size_t>(m.frameCount()));
  for (int k = 0; k < m.frameCount(); ++k) y[static_cast<std::size_t>(k)] = m.frames(k, 1);
  std::nth_element(y.begin(), y.begin() + static_cast<std::ptrdiff_t>(y.size() / 2), y.end());
  return y[y.size() / 2];
}

TEST(BvhClips, WalkTravelsAPlausibleDistanceInCmuUnits) {
  // The README table of the shared data called 131_01's offsets "cm-scale", but with 0.01
  // the pelvis would be 0.16 m above the floor and the walk 0.23 m/s. The file keeps the
  // CMU database's unit (1/0.45 inch): with it the pelvis is at 0.91 m and the walk in the
  // middle of the clip reaches 1.28 m/s. Measured: the root travels 2.594 m horizontally
  // from the first to the last frame (stands, crouches, walks about 2.4 m along +Z, stops).
  BvhReadOptions options;
  options.length_scale = kCmuUnitM;
  const BvhMotion m = readBvh(clipPath(kWalk), options);
  const int n = m.frameCount();
  const double travelled = (rootXZ(m, n - 1) - rootXZ(m, 0)).norm();
  EXPECT_GT(travelled, 2.0);
  EXPECT_LT(travelled, 4.0);
  EXPECT_NEAR(travelled, 2.594, 0.01);

  const int window = static_cast<int>(std::lround(1.0 / m.frame_time_s));  // 1 s
  double fastest = 0.0;
  for (int k = 0; k + window < n; ++k)
    fastest = std::max(fastest, (rootXZ(m, k + window) - rootXZ(m, k)).norm());
  EXPECT_GT(fastest, 0.8) << "a walk, m/s";
  EXPECT_LT(fastest, 2.0) << "a walk, m/s";

  const double pelvis = medianRootHeight(m);
  EXPECT_GT(pelvis, 0.8);
  EXPECT_LT(pelvis, 1.05);
}

TEST(BvhClips, UnitsGiveAnAdultPelvisHeightInEveryClip) {
  // 01_01 (MotionBuilder-friendly) keeps the CMU unit like 131_01; 10_01 (DAZ-friendly)
  // is in centimetres. Measured median root heights: 1.009 m and 0.837 m.
  BvhReadOptions cmu;
  cmu.length_scale = kCmuUnitM;
  BvhReadOptions cm;
  cm.length_scale = kCentimetreM;
  EXPECT_NEAR(medianRootHeight(readBvh(clipPath(kJumps), cmu)), 1.009, 0.01);
  EXPECT_NEAR(medianRootHeight(readBvh(clipPath(kKick), cm)), 0.837, 0.01);
}

TEST(BvhClips, LengthScaleMultipliesOffsetsAndPositionChannelsOnly) {
  const BvhMotion raw = readBvh(clipPath(kKick));
  BvhReadOptions options;
  options.length_scale = kCentimetreM;
  const BvhMotion m = readBvh(clipPath(kKick), options);
  ASSERT_EQ(m.joints.size(), raw.joints.size());
  for (std::size_t j = 0; j < m.joints.size(); ++j)
    EXPECT_EQ(m.joints[j].offset, raw.joints[j].offset * kCentimetreM) << m.joints[j].name;
  EXPECT_EQ(m.frames.leftCols(3), raw.frames.leftCols(3) * kCentimetreM);
  EXPECT_EQ(m.frames.rightCols(m.channelCount() - 3), raw.frames.rightCols(raw.channelCount() - 3));
}

TEST(BvhClips, TPoseDetection) {
  BvhReadOptions detect;
  detect.detect_t_pose = true;

  // 01_01: frame 0 is the conversion's T-pose (arms straight out, 4 of 90 rotation
  // channels at ±17° or ±5°, all others 0), frame 1 the captured stance.
  const BvhMotion jumps_all = readBvh(clipPath(kJumps));
  const BvhMotion jumps = readBvh(clipPath(kJumps), detect);
  EXPECT_EQ(jumps.skipped_frames, 1);
  EXPECT_EQ(jumps.frameCount(), jumps_all.frameCount() - 1);
  EXPECT_EQ(jumps.frames, jumps_all.frames.bottomRows(jumps_all.frameCount() - 1));

  // 131_01 starts in the captured motion: nothing is skipped.
  const BvhMotion walk = readBvh(clipPath(kWalk), detect);
  EXPECT_EQ(walk.skipped_frames, 0);
  EXPECT_EQ(walk.frameCount(), 994);

  // 10_01: frame 0 is a T-pose too (root rotation 0, left/right mirror-symmetric angles,
  // hands 1.24 m apart at 1.34 m), although the README lists it for 01_01 only; the
  // DAZ-friendly conversion then blends into the captured stance over frames 1-4 (steps of
  // 23, 20, 14 and 5.5 degrees to the next frame, against a median of 0.62 over the clip),
  // which go too: frame 5 is the first of the motion, as in its hand-written mapping. The
  // jumps' frame 1 (a step of 1.1 degrees; median 1.9) is already the motion.
  const BvhMotion kick_all = readBvh(clipPath(kKick));
  const BvhMotion kick = readBvh(clipPath(kKick), detect);
  EXPECT_EQ(kick.skipped_frames, 5);
  EXPECT_EQ(kick.frameCount(), 797);
  EXPECT_EQ(kick.frames, kick_all.frames.bottomRows(kick_all.frameCount() - 5));

  // skip_first_frame drops frame 0 whatever it is, once.
  BvhReadOptions skip;
  skip.skip_first_frame = true;
  skip.detect_t_pose = true;
  const BvhMotion walk_skipped = readBvh(clipPath(kWalk), skip);
  EXPECT_EQ(walk_skipped.skipped_frames, 1);
  EXPECT_EQ(walk_skipped.frameCount(), 993);
  EXPECT_EQ(readBvh(clipPath(kJumps), skip).frameCount(), 2751);
}

// A root and one joint: frame 0 with the joint at `start` degrees (0: at rest), `blend`
// frames moving it by 20 degrees a frame, then `rest` frames moving it by `slow` degrees a
// frame; frame time 0.01 s.
std::string blendClip(int blend, int rest, double slow, double start = 0.0) {
  std::string text =
      "HIERARCHY\nROOT hip\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition "
      "Zrotation Yrotation Xrotation\n  JOINT knee\n  {\n    OFFSET 0 -40 0\n    CHANNELS 3 "
      "Zrotation Yrotation Xrotation\n    End Site\n    {\n      OFFSET 0 -40 0\n    }\n  }\n}\n"
      "MOTION\nFrames: " + std::to_string(1 + blend + rest) + "\nFrame Time: 0.01\n";
  double angle = start;
  for (int k = 0; k <= blend + rest; ++k) {
    if (k > 0) angle += k <= blend ? 20.0 : slow;
    text += "0 90 0 0 0 0 0 0 " + std::to_string(std::fmod(angle + 180.0, 360.0) - 180.0) + "\n";
  }
  return text;
}

TEST(BvhReader, TheBlendFromARestPoseIntoTheMotionIsDroppedWithIt) {
  BvhReadOptions detect;
  detect.detect_t_pose = true;
  auto read = [&](int blend, int rest, double slow, double start = 0.0) {
    const std::string path = ::testing::TempDir() + "/blend.bvh";
    std::ofstream(path) << blendClip(blend, rest, slow, start);
    return readBvh(path, detect);
  };
  // Four frames of 20 degrees, then 0.5 a frame: frame 0 and the three frames whose step
  // to the next is 20 go; frame 4, the blend's end, is the first kept.
  const BvhMotion blended = read(4, 40, 0.5);
  EXPECT_EQ(blended.skipped_frames, 4);
  EXPECT_EQ(blended.frameCount(), 41);
  EXPECT_DOUBLE_EQ(blended.frames(0, 8), 80.0);
  // A motion as fast as the blend all along: only the rest pose goes.
  EXPECT_EQ(read(4, 40, 20.0).skipped_frames, 1);
  // No step above 3x the median (1.5 degrees against 0.5): nothing beyond the rest pose.
  EXPECT_EQ(read(1, 40, 0.5).skipped_frames, 1);
  // A blend longer than kBvhBlendMaxS (0.25 s = 25 frames) stops there.
  EXPECT_EQ(read(40, 100, 0.5).skipped_frames, 26);
  // Without a rest pose in front (frame 0's joint at 30 degrees: RMS 12 over the six
  // rotation channels) nothing goes, however fast the first frames.
  EXPECT_EQ(read(4, 40, 0.5, 30.0).skipped_frames, 0);
}

// ---------------------------------------------------------------------------------------
// A hand-made file

// Line numbers of kTiny (1-based) are in the comments; indentation is two spaces a level.
const std::vector<std::string> kTiny{
    "HIERARCHY",                                                               // 1
    "ROOT root",                                                               // 2
    "{",                                                                       // 3
    "  OFFSET 10 20 30",                                                       // 4
    "  CHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation",  // 5
    "  JOINT arm",                                                             // 6
    "  {",                                                                     // 7
    "    OFFSET 1 0 0",                                                        // 8
    "    CHANNELS 3 Zrotation Xrotation Yrotation",                            // 9
    "    JOINT slider",                                                        // 10
    "    {",                                                                   // 11
    "      OFFSET 0 5 0",                                                      // 12
    "      CHANNELS 3 Zposition Xrotation Xposition",                          // 13
    "      End Site",                                                          // 14
    "      {",                                                                 // 15
    "        OFFSET 0 0 2",                                                    // 16
    "      }",                                                                 // 17
    "    }",                                                                   // 18
    "  }",                                                                     // 19
    "}",                                                                       // 20
    "MOTION",                                                                  // 21
    "Frames: 2",                                                               // 22
    "Frame Time: 0.5",                                                         // 23
    "1 2 3 90 0 0 90 90 0 4 90 3",                                             // 24
    "0 0 0 0 0 0 30 0 0 0 0 2",                                                // 25
};

std::string joined(const std::vector<std::string>& lines, const std::string& eol) {
  std::string text;
  for (const std::string& l : lines) text += l + eol;
  return text;
}

// Writes @p lines (LF) to a fresh temporary file and returns its path.
std::string writeLines(const std::vector<std::string>& lines, const std::string& name = "tiny.bvh",
                       const std::string& eol = "\n") {
  const std::string path = tempPath(name);
  writeFile(path, joined(lines, eol));
  return path;
}

void expectSameMotion(const BvhMotion& a, const BvhMotion& b) {
  ASSERT_EQ(a.joints.size(), b.joints.size());
  for (std::size_t j = 0; j < a.joints.size(); ++j) {
    EXPECT_EQ(a.joints[j].name, b.joints[j].name);
    EXPECT_EQ(a.joints[j].parent, b.joints[j].parent);
    EXPECT_EQ(a.joints[j].offset, b.joints[j].offset);
    EXPECT_EQ(a.joints[j].channels, b.joints[j].channels);
    EXPECT_EQ(a.joints[j].end_site, b.joints[j].end_site);
    EXPECT_EQ(a.joints[j].first_channel, b.joints[j].first_channel);
    EXPECT_EQ(a.joints[j].line, b.joints[j].line);
  }
  EXPECT_EQ(a.frame_time_s, b.frame_time_s);
  EXPECT_EQ(a.frames, b.frames);
  EXPECT_EQ(a.skipped_frames, b.skipped_frames);
}

TEST(BvhReader, ReadsTheHierarchyAndFramesOfASmallFile) {
  const BvhMotion m = readBvh(writeLines(kTiny));
  ASSERT_EQ(m.joints.size(), 4u);
  const BvhJoint& root = m.joints[0];
  const BvhJoint& arm = m.joints[1];
  const BvhJoint& slider = m.joints[2];
  const BvhJoint& end = m.joints[3];
  EXPECT_EQ(root.name, "root");
  EXPECT_EQ(root.parent, -1);
  EXPECT_EQ(root.line, 2);
  EXPECT_EQ(root.first_channel, 0);
  EXPECT_EQ(root.offset, Eigen::Vector3d(10, 20, 30));
  EXPECT_EQ(arm.name, "arm");
  EXPECT_EQ(arm.parent, 0);
  EXPECT_EQ(arm.line, 6);
  EXPECT_EQ(arm.first_channel, 6);
  EXPECT_EQ(arm.channels, (std::vector<BvhChannel>{BvhChannel::kZrotation, BvhChannel::kXrotation,
                                                    BvhChannel::kYrotation}));
  EXPECT_EQ(slider.parent, 1);
  EXPECT_EQ(slider.first_channel, 9);
  EXPECT_TRUE(slider.hasPositionChannels());
  EXPECT_EQ(slider.channels, (std::vector<BvhChannel>{BvhChannel::kZposition,
                                                       BvhChannel::kXrotation,
                                                       BvhChannel::kXposition}));
  EXPECT_TRUE(end.end_site);
  EXPECT_EQ(end.name, "slider_end");
  EXPECT_EQ(end.parent, 2);
  EXPECT_EQ(end.line, 14);
  EXPECT_TRUE(end.channels.empty());
  EXPECT_EQ(end.offset, Eigen::Vector3d(0, 0, 2));
  EXPECT_EQ(m.findJoint("slider"), 2);
  EXPECT_EQ(m.findJoint("nope"), -1);
  EXPECT_EQ(m.frame_time_s, 0.5);
  ASSERT_EQ(m.frames.rows(), 2);
  ASSERT_EQ(m.frames.cols(), 12);
  EXPECT_EQ(m.frames(0, 3), 90.0);
  EXPECT_EQ(m.frames(1, 11), 2.0);
  EXPECT_EQ(m.durationS(), 0.5);
}

void expectPose(const Eigen::Isometry3d& X, const Eigen::Vector3d& p, const Eigen::Matrix3d& R) {
  EXPECT_LT((X.translation() - p).cwiseAbs().maxCoeff(), 1e-12)
      << X.translation().transpose() << " vs " << p.transpose();
  EXPECT_LT((X.linear() - R).cwiseAbs().maxCoeff(), 1e-12) << X.linear() << "\nvs\n" << R;
}

TEST(BvhForwardKinematics, MatchesAHandComputation) {
  const BvhMotion m = readBvh(writeLines(kTiny));
  std::vector<Eigen::Isometry3d> X;

  // Frame 0: 1 2 3 | Y 90, X 0, Z 0 | arm Z 90, X 90, Y 0 | slider Zpos 4, X 90, Xpos 3.
  bvhForwardKinematics(m, 0, X);
  ASSERT_EQ(X.size(), 4u);
  // root: the position channels replace OFFSET 10 20 30; R = Ry(90).
  Eigen::Matrix3d R_root;
  R_root << 0, 0, 1,  //
      0, 1, 0,        //
      -1, 0, 0;
  expectPose(X[0], Eigen::Vector3d(1, 2, 3), R_root);
  // arm at root + Ry(90)·(1,0,0) = (1,2,3) + (0,0,−1); R_arm = Rz(90)·Rx(90) (listed
  // order; Rx(90)·Rz(90) would be [[0,−1,0],[0,0,−1],[1,0,0]]) = [[0,0,1],[1,0,0],[0,1,0]];
  // world Ry(90)·R_arm:
  Eigen::Matrix3d R_arm;
  R_arm << 0, 1, 0,  //
      1, 0, 0,       //
      0, 0, -1;
  expectPose(X[1], Eigen::Vector3d(1, 2, 2), R_arm);
  // slider: translation (Xposition 3, unset Y → 0 not OFFSET's 5, Zposition 4) = (3,0,4),
  // in world R_arm·(3,0,4) = (0,3,−4) from the arm; rotation R_arm·Rx(90).
  Eigen::Matrix3d R_slider;
  R_slider << 0, 0, -1,  //
      1, 0, 0,           //
      0, -1, 0;
  expectPose(X[2], Eigen::Vector3d(1, 5, -2), R_slider);
  // End Site: OFFSET (0,0,2) → R_slider·(0,0,2) = (−2,0,0); no rotation of its own.
  expectPose(X[3], Eigen::Vector3d(-1, 5, -2), R_slider);

  // Frame 1: root at the origin, arm Z 30, slider Xposition 2.
  bvhForwardKinematics(m, 1, X);
  const double c = std::sqrt(3.0) / 2.0, s = 0.5;
  Eigen::Matrix3d Rz30;
  Rz30 << c, -s, 0,  //
      s, c, 0,       //
      0, 0, 1;
  expectPose(X[0], Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity());
  expectPose(X[1], Eigen::Vector3d(1, 0, 0), Rz30);
  expectPose(X[2], Eigen::Vector3d(1 + 2 * c, 2 * s, 0), Rz30);
  expectPose(X[3], Eigen::Vector3d(1 + 2 * c, 2 * s, 2), Rz30);

  EXPECT_THROW(bvhForwardKinematics(m, 2, X), std::out_of_range);
  EXPECT_THROW(bvhForwardKinematics(m, -1, X), std::out_of_range);
}

TEST(BvhForwardKinematics, LengthScaleScalesEveryPosition) {
  BvhReadOptions half;
  half.length_scale = 0.5;
  const BvhMotion m = readBvh(writeLines(kTiny), half);
  EXPECT_EQ(m.joints[0].offset, Eigen::Vector3d(5, 10, 15));
  EXPECT_EQ(m.frames(0, 0), 0.5);
  EXPECT_EQ(m.frames(0, 3), 90.0);  // rotations stay in degrees
  EXPECT_EQ(m.frames(0, 9), 2.0);   // slider Zposition 4
  std::vector<Eigen::Isometry3d> X;
  bvhForwardKinematics(m, 0, X);
  EXPECT_LT((X[3].translation() - Eigen::Vector3d(-0.5, 2.5, -1)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_THROW(readBvh(writeLines(kTiny), BvhReadOptions{0.0, false, false}),
               std::invalid_argument);
}

TEST(BvhReader, CrlfLfMixedEndingsAndTabsReadIdentically) {
  const BvhMotion lf = readBvh(writeLines(kTiny, "lf.bvh", "\n"));
  const BvhMotion crlf = readBvh(writeLines(kTiny, "crlf.bvh", "\r\n"));
  expectSameMotion(lf, crlf);

  // Alternating endings, tabs for indentation and between values, trailing blanks and
  // blank lines at the end (as in the shipped files).
  std::string text;
  for (std::size_t i = 0; i < kTiny.size(); ++i) {
    std::string l = kTiny[i];
    for (char& ch : l)
      if (ch == ' ' && i + 1 >= 24) ch = '\t';
    if (l.find_first_not_of(' ') != std::string::npos && l[0] == ' ')
      l = std::string(l.find_first_not_of(' ') / 2, '\t') + l.substr(l.find_first_not_of(' '));
    text += l + (i % 2 ? " \r\n" : "\t\n");
  }
  text += "\r\n\n";
  const std::string path = tempPath("mixed.bvh");
  writeFile(path, text);
  expectSameMotion(lf, readBvh(path));

  // "{" on the JOINT line (line 7 left blank so that line numbers stay).
  std::vector<std::string> brace_on_joint_line = kTiny;
  brace_on_joint_line[5] = "  JOINT arm {";
  brace_on_joint_line[6] = "";
  expectSameMotion(lf, readBvh(writeLines(brace_on_joint_line, "brace.bvh", "\r\n")));
}

// ---------------------------------------------------------------------------------------
// Malformed files: each error names its line (and column where one word is at fault).

std::vector<std::string> tinyWith(std::size_t line, const std::string& text) {
  std::vector<std::string> lines = kTiny;
  lines.at(line - 1) = text;
  return lines;
}

std::vector<std::string> tinyWithout(std::size_t line) {
  std::vector<std::string> lines = kTiny;
  lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(line - 1));
  return lines;
}

std::vector<std::string> tinyInserting(std::size_t before_line, const std::string& text) {
  std::vector<std::string> lines = kTiny;
  lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(before_line - 1), text);
  return lines;
}

// Reads @p lines and expects an InputError at @p line:@p column containing @p needle.
void expectError(const std::vector<std::string>& lines, int line, int column,
                 const std::string& needle) {
  const std::string path = writeLines(lines, "bad.bvh");
  expectInputError([&] { readBvh(path); }, path, line, column, needle);
}

TEST(BvhErrors, MissingFile) {
  const std::string path = tempPath("absent.bvh");
  expectInputError([&] { readBvh(path); }, path, 0, 0, "cannot open file");
}

TEST(BvhErrors, MissingHierarchy) {
  expectError(tinyWith(1, "HIERARCHIES"), 1, 1, "missing HIERARCHY");
  expectError(tinyWithout(1), 1, 1, "missing HIERARCHY");
  expectError({}, 0, 0, "missing HIERARCHY: the file is empty");
}

TEST(BvhErrors, MissingMotion) {
  std::vector<std::string> hierarchy_only(kTiny.begin(), kTiny.begin() + 20);
  expectError(hierarchy_only, 20, 0, "missing MOTION");
  expectError(tinyWith(21, "MOTIONS"), 21, 1, "expected ROOT or MOTION, found \"MOTIONS\"");
  expectError(tinyWith(22, "Frame: 2"), 22, 1, "expected \"Frames:\"");
  expectError(tinyWith(23, "FrameTime: 0.5"), 23, 1, "expected \"Frame Time:\"");
}

TEST(BvhErrors, KeywordsAreCaseSensitive) {
  expectError(tinyWith(6, "  joint arm"), 6, 3, "unexpected \"joint\"");
  expectError(tinyWith(14, "      End site"), 14, 7, "expected \"End Site\"");
}

TEST(BvhErrors, UnknownChannelIsNamed) {
  expectError(tinyWith(9, "    CHANNELS 3 Zrotation Xrotation Wrotation"), 9, 36,
              "unknown channel \"Wrotation\"");
  expectError(tinyWith(9, "    CHANNELS 3 Zrotation Xrotation xrotation"), 9, 36,
              "unknown channel \"xrotation\"");
  expectError(tinyWith(9, "    CHANNELS 3 Zrotation Xrotation Zrotation"), 9, 36,
              "channel Zrotation listed twice");
}

TEST(BvhErrors, ChannelCountMustMatchTheNamesThatFollow) {
  expectError(tinyWith(9, "    CHANNELS 2 Zrotation Xrotation Yrotation"), 9, 5,
              "CHANNELS declares 2 channels but 3 channel names follow");
  expectError(tinyWith(9, "    CHANNELS 4 Zrotation Xrotation Yrotation"), 9, 5,
              "CHANNELS declares 4 channels but 3 channel names follow");
  expectError(tinyWith(9, "    CHANNELS three Zrotation Xrotation Yrotation"), 9, 14,
              "CHANNELS count \"three\"");
}

TEST(BvhErrors, UnbalancedBraces) {
  // The End Site's "}" missing: the hierarchy is still open when MOTION comes.
  expectError(tinyWithout(17), 20, 1, "unbalanced braces: MOTION inside ROOT \"root\"");
  // One "}" too many.
  expectError(tinyInserting(21, "}"), 21, 1, "unbalanced braces: \"}\" without a matching \"{\"");
  // JOINT without its "{".
  expectError(tinyWithout(7), 7, 5, "unbalanced braces: expected \"{\" to open JOINT \"arm\"");
  expectError(tinyInserting(8, "    {"), 8, 5, "unbalanced braces: unexpected \"{\"");
  // The file ends inside the hierarchy.
  std::vector<std::string> cut(kTiny.begin(), kTiny.begin() + 18);
  expectError(cut, 18, 0, "unbalanced braces: the file ends inside JOINT \"arm\"");
}

TEST(BvhErrors, OffsetNeedsThreeNumbers) {
  expectError(tinyWith(8, "    OFFSET 1 0"), 8, 5, "OFFSET needs 3 numbers");
  expectError(tinyWith(8, "    OFFSET 1 zero 0"), 8, 14, "OFFSET value \"zero\": not a number");
  expectError(tinyWithout(16), 16, 7, "End Site of \"slider\" (line 14) has no OFFSET");
}

TEST(BvhErrors, DuplicateJointName) {
  expectError(tinyWith(10, "    JOINT arm"), 10, 11, "joint name \"arm\" already used at line 6");
}

TEST(BvhErrors, FrameLineWithTheWrongNumberOfValues) {
  expectError(tinyWith(25, "0 0 0 0 0 0 30 0 0 0 0"), 25, 0, "expected 12, found 11");
  expectError(tinyWith(24, "1 2 3 90 0 0 90 90 0 4 90 3 7"), 24, 0, "expected 12, found 13");
  // A blank line between frames is a frame line without values.
  expectError(tinyInserting(25, ""), 25, 0, "expected 12, found 0");
}

TEST(BvhErrors, NonNumericValueNamesLineAndValueIndex) {
  expectError(tinyWith(24, "1 2 3 90 0x 0 90 90 0 4 90 3"), 24, 5, "value 5 \"0x\": not a number");
  expectError(tinyWith(25, "0 0 0 0 0 0 30 0 0 0 0 nan"), 25, 12, "not a finite number");
  expectError(tinyWith(25, "0 0 0 0 0 0 30 0 0 0 0 1e999"), 25, 12, "out of range");
}

TEST(BvhErrors, TruncatedMotionSection) {
  expectError(tinyWith(22, "Frames: 3"), 25, 0,
              "truncated motion: the file ends after 2 of the 3 frames declared by \"Frames:\" at "
              "line 22");
  // Trailing blank lines do not count as frames.
  std::vector<std::string> blank_tail = tinyWith(22, "Frames: 5");
  blank_tail.push_back("");
  blank_tail.push_back("   ");
  expectError(blank_tail, 25, 0, "after 2 of the 5 frames");
  // No frame line at all: the section ends at the Frame Time line.
  expectError(std::vector<std::string>(kTiny.begin(), kTiny.begin() + 23), 23, 0,
              "after 0 of the 2 frames");
  // More frame lines than declared.
  expectError(tinyWith(22, "Frames: 1"), 25, 0, "more frame lines than the 1 declared");
  expectError(tinyWith(22, "Frames: -1"), 22, 9, "not a non-negative integer");
}

TEST(BvhErrors, FrameTimeMustBePositive) {
  expectError(tinyWith(23, "Frame Time: 0"), 23, 13, "\"Frame Time:\" must be > 0 s, got 0");
  expectError(tinyWith(23, "Frame Time: -0.0083333"), 23, 13, "must be > 0 s");
  expectError(tinyWith(23, "Frame Time: fast"), 23, 13, "not a number");
  expectError(tinyWith(23, "Frame Time:"), 23, 1, "needs one value");
}

}  // namespace
}  // namespace dynfilter::io
