// A first mapping found from the structure of a BVH skeleton and a model
// (dynfilter/io/mapping_suggestion.hpp): the mini humanoid's own capture, the human figure
// with the three CMU conversions (three naming schemes, units and rest poses), and what
// the suggestion retargets.

#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <regex>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/io/mapping_suggestion.hpp"
#include "dynfilter/io/retarget.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "mini_humanoid_bvh.hpp"
#include "support/test_support.hpp"

namespace dynfilter::io {
namespace {

using testing_io::knownAngles;
using testing_io::writeMiniBvh;

// Mapped link → BVH joint of a mapping (the root under its link too).
std::map<std::string, std::string> pairsOf(const RetargetMapping& m) {
  std::map<std::string, std::string> out{{m.root_link, m.root_bvh}};
  for (const RetargetSegment& s : m.segments) out[s.link] = s.bvh;
  return out;
}

// The mini humanoid's links and the joints of its own capture they are matched to.
const std::map<std::string, std::string> kMiniPairs = {
    {"hips", "Hips"},     {"chest", "Waist"},   {"tibia_l", "LKnee"}, {"sole_l", "LAnkle"},
    {"tibia_r", "RKnee"}, {"sole_r", "RAnkle"}, {"ulna_l", "LElbow"}, {"ulna_r", "RElbow"}};

// Retargets @p bvh with @p m (the IK's pull towards q = 0 off, as in the IK mode's own
// tests) and expects the capture's joint angles back within 1e-3 rad.
void expectTheCapturesAngles(const BvhMotion& bvh, const RetargetMapping& m, IDynamicsModel& model,
                             const std::vector<std::map<std::string, double>>& truth) {
  RetargetMapping exact = m;
  exact.ik.posture_weight = 1e-4;
  exact.ik.max_iterations = 200;
  const RetargetResult r = retargetBvh(bvh, exact, model);
  const ModelInfo& info = model.info();
  for (std::size_t k = 0; k < truth.size(); ++k)
    for (const auto& [name, value] : truth[k]) {
      if (name.rfind("cubitus", 0) == 0) continue;  // no wrist target: the elbow's angle is free
      EXPECT_NEAR(r.motion.frames[k].q[info.configurationIndex(info.findJoint(name))], value, 1e-3)
          << name << " frame " << k;
    }
}

// The mini humanoid's capture suggested onto @p model is refused with @p reason.
void expectModelRefused(IDynamicsModel& model, const std::string& reason) {
  const BvhMotion bvh = readBvh(writeMiniBvh({knownAngles(0.0), knownAngles(0.1)}, "mini_refused.bvh"));
  try {
    suggestMapping(bvh, model);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(reason), std::string::npos) << e.what();
  }
}

// The mini humanoid's capture of itself: every limb is matched, the chest (no neck above
// it) keeps its rest orientation, and the suggestion retargets the capture's angles.
TEST(MappingSuggestion, TheMiniHumanoidsOwnCaptureIsMatchedByStructure) {
  auto model = test::makeMiniHumanoid();
  const std::vector<std::map<std::string, double>> truth = {knownAngles(0.2), knownAngles(1.0),
                                                            knownAngles(0.6)};
  const BvhMotion bvh = readBvh(writeMiniBvh(truth, "mini_suggest.bvh"));
  const MappingSuggestion s = suggestMapping(bvh, *model);
  const RetargetMapping m = parseRetargetMapping(s.yaml, "suggested.yaml");
  EXPECT_EQ(pairsOf(m), kMiniPairs) << s.yaml;
  EXPECT_EQ(m.mode, RetargetMode::kIk);
  EXPECT_EQ(m.up_axis, "+z");
  EXPECT_EQ(m.bvh_forward, "+x");
  EXPECT_EQ(m.length_scale, 1.0);
  EXPECT_EQ(m.root_position, (std::vector<std::string>{"LHip", "RHip"}));
  // The hips' pivots (where the three hip axes meet) are 6 cm below the base origin.
  EXPECT_LT((m.root_offset_xyz - Eigen::Vector3d(0, 0, -0.06)).norm(), 1e-9);
  EXPECT_FALSE(m.allow_unmapped);
  ASSERT_EQ(s.notes.size(), 1u);
  EXPECT_NE(s.notes[0].find("no neck"), std::string::npos);

  expectTheCapturesAngles(bvh, m, *model, truth);
}

// The mini humanoid's URDF rewritten by @p edit, written to a temporary file and loaded.
std::unique_ptr<IDynamicsModel> editedMiniHumanoid(const std::function<std::string(std::string)>& edit,
                                                   const char* name) {
  return test::makeModel("dart", urdf::loadUrdfFile(test::editedTestModel("mini_humanoid.urdf", edit, name)),
                         ModelOptions{});
}

// A robot whose base frame's +x points backwards (as iCub's does): everything hanging from
// the base turned half a turn about z, so that its knees bend towards +x. Its left leg
// (at −y) is still matched to the capture's left, the capture's forward becomes the
// model's −x, and the capture's angles come back although every link frame is turned at q = 0.
TEST(MappingSuggestion, ARobotFacingItsBasesMinusXKeepsItsLeftAndItsAngles) {
  auto model = editedMiniHumanoid(
      [](std::string text) {
        const std::regex from_hips(R"re((<parent link="hips"/><child link="\w+"/>)<origin xyz="(\S+) (\S+) (\S+)"/>)re");
        std::string out;
        auto it = std::sregex_iterator(text.begin(), text.end(), from_hips);
        std::size_t last = 0;
        for (; it != std::sregex_iterator(); ++it) {
          const std::smatch& mt = *it;
          out += text.substr(last, static_cast<std::size_t>(mt.position(0)) - last);
          const double x = std::stod(mt[2].str()), y = std::stod(mt[3].str());
          out += mt[1].str() + "<origin xyz=\"" + std::to_string(-x) + " " + std::to_string(-y) + " " + mt[4].str() +
                 "\" rpy=\"0 0 3.141592653589793\"/>";
          last = static_cast<std::size_t>(mt.position(0) + mt.length(0));
        }
        return out + text.substr(last);
      },
      "mini_humanoid_facing_minus_x.urdf");
  model->setState(model->info().neutralConfiguration(), Eigen::VectorXd::Zero(model->info().nv));
  ASSERT_LT(model->bodyPose(model->info().findBody("sole_l")).translation().y(), -0.05);  // its left is −y

  const std::vector<std::map<std::string, double>> truth = {knownAngles(0.2), knownAngles(1.0),
                                                            knownAngles(0.6)};
  const BvhMotion bvh = readBvh(writeMiniBvh(truth, "mini_suggest_turned.bvh"));
  const MappingSuggestion s = suggestMapping(bvh, *model);
  const RetargetMapping m = parseRetargetMapping(s.yaml, "suggested.yaml");
  EXPECT_EQ(pairsOf(m), kMiniPairs) << s.yaml;
  EXPECT_EQ(m.bvh_forward, "-x");
  bool said = false;
  for (const std::string& n : s.notes) said = said || n.find("the model faces -x") != std::string::npos;
  EXPECT_TRUE(said) << s.yaml;

  expectTheCapturesAngles(bvh, m, *model, truth);
}

// An upper body whose arms reach the floor (as a wheeled or mounted torso's do) stands on its
// hands at q = 0; its arms are not taken for legs.
TEST(MappingSuggestion, AnUpperBodyStandingOnItsHandsIsRefused) {
  auto model = editedMiniHumanoid(
      [](std::string text) {
        // No legs; long upper arms and a hand box at the end of each forearm.
        const std::regex leg(R"re(\s*<(link|joint) name="(hipz|hipx|femur|tibia|talus|sole|coxa|genu|talo)_[lr][^"]*"[\s\S]*?</\1>)re");
        text = std::regex_replace(text, leg, "");
        text = std::regex_replace(text, std::regex(R"re((name="cubitus_[lr]"[^>]*>.*?)<origin xyz="0 0 -0.25"/>)re"),
                                  "$1<origin xyz=\"0 0 -0.45\"/>");  // upper arms long enough to reach below the hips
        const std::regex ulna(R"re((<link name="ulna_[lr]">\s*<inertial>[\s\S]*?</inertial>))re");
        return std::regex_replace(
            text, ulna, "$1<collision><origin xyz=\"0 0 -0.26\"/><geometry><box size=\"0.06 0.06 0.02\"/></geometry></collision>");
      },
      "mini_upper_body.urdf");
  ASSERT_EQ(model->info().nj, 7) << "the legs were not removed";  // the spine twist and two arms of three
  expectModelRefused(*model, "hang from 0.300 m above the origin of its trunk link chest: arms, not legs");
}

// Legs without ankles (a foot rigid with its shank, as Bolt's): the foot alone is mapped
// (the shank too would be "rigidly attached to mapped link"), and the mapping retargets.
TEST(MappingSuggestion, AFootRigidWithItsShankIsMappedAlone) {
  auto model = editedMiniHumanoid(
      [](std::string text) {
        return std::regex_replace(text, std::regex(R"re(name="(talo_[lr]_[xy])" type="revolute")re"),
                                  "name=\"$1\" type=\"fixed\"");
      },
      "mini_humanoid_no_ankles.urdf");
  ASSERT_EQ(model->info().findJoint("talo_l_y"), -1) << "the ankles were not welded";
  const BvhMotion bvh = readBvh(writeMiniBvh({knownAngles(0.2), knownAngles(0.6)}, "mini_no_ankles.bvh"));
  const MappingSuggestion s = suggestMapping(bvh, *model);
  const RetargetMapping m = parseRetargetMapping(s.yaml, "suggested.yaml");
  const auto p = pairsOf(m);
  EXPECT_EQ(p.count("tibia_l") + p.count("tibia_r"), 0u) << s.yaml;
  EXPECT_EQ(p.at("sole_l"), "LAnkle");
  EXPECT_EQ(p.at("sole_r"), "RAnkle");
  int said = 0;
  for (const std::string& n : s.notes) said += n.find("no ankle") != std::string::npos;
  EXPECT_EQ(said, 2) << s.yaml;
  EXPECT_NO_THROW(retargetBvh(bvh, m, *model));
}

struct CmuCase {
  const char* file;
  const char* units;  // expected length_scale
  double length_scale;
  int skip_frames;
  std::map<std::string, std::string> pairs;
  std::vector<std::string> hips;
};

// The three CMU conversions onto the human figure: their own names, units (CMU unit,
// centimetres) and rest poses, matched by structure alone.
TEST(MappingSuggestion, ThreeConversionsOfTheCmuSkeletonOntoTheHumanFigure) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const std::vector<CmuCase> cases = {
      {"131_01_start_walk_stop.bvh", "CMU", 0.0254 / 0.45, 0,
       {{"pelvis", "Hips"}, {"torso", "Chest2"}, {"l_shank", "LeftKnee"}, {"l_foot", "LeftAnkle"},
        {"r_shank", "RightKnee"}, {"r_foot", "RightAnkle"}, {"l_elbow_link", "LeftElbow"},
        {"l_hand", "LeftWrist"}, {"r_elbow_link", "RightElbow"}, {"r_hand", "RightWrist"}},
       {"LeftHip", "RightHip"}},
      {"01_01_forward_jumps.bvh", "CMU", 0.0254 / 0.45, 1,
       {{"pelvis", "Hips"}, {"torso", "Spine1"}, {"l_shank", "LeftLeg"}, {"l_foot", "LeftFoot"},
        {"r_shank", "RightLeg"}, {"r_foot", "RightFoot"}, {"l_elbow_link", "LeftForeArm"},
        {"l_hand", "LeftHand"}, {"r_elbow_link", "RightForeArm"}, {"r_hand", "RightHand"}},
       {"LeftUpLeg", "RightUpLeg"}},
      {"10_01_soccer_kick.bvh", "cm", 0.01, 5,  // the T-pose and 4 frames blending from it, as 10_01.yaml
       {{"pelvis", "hip"}, {"torso", "chest"}, {"l_shank", "lShin"}, {"l_foot", "lFoot"},
        {"r_shank", "rShin"}, {"r_foot", "rFoot"}, {"l_elbow_link", "lForeArm"},
        {"l_hand", "lHand"}, {"r_elbow_link", "rForeArm"}, {"r_hand", "rHand"}},
       {"lThigh", "rThigh"}},
  };
  for (const CmuCase& c : cases) {
    SCOPED_TRACE(c.file);
    BvhReadOptions read;
    read.detect_t_pose = true;
    const BvhMotion bvh = readBvh(test::sourcePath(std::string("data/mocap/cmu/") + c.file), read);
    const MappingSuggestion s = suggestMapping(bvh, *model, bvh.skipped_frames);
    const RetargetMapping m = parseRetargetMapping(s.yaml, "suggested.yaml");
    EXPECT_EQ(pairsOf(m), c.pairs) << s.yaml;
    EXPECT_EQ(m.root_position, c.hips);
    EXPECT_DOUBLE_EQ(m.length_scale, c.length_scale);
    EXPECT_EQ(m.skip_frames, c.skip_frames);
    EXPECT_EQ(m.up_axis, "+y");
    EXPECT_EQ(m.bvh_forward, "+z");
    EXPECT_NE(s.yaml.find(std::string("units: ") + c.units), std::string::npos);
    EXPECT_TRUE(m.allow_unmapped);  // the neck
  }
}

// A skeleton without legs is refused with the joint it stopped at.
TEST(MappingSuggestion, ASkeletonWithoutTwoLegsIsRefusedByName) {
  auto model = test::makeMiniHumanoid();
  const std::string path = ::testing::TempDir() + "/armless.bvh";
  {
    std::ofstream out(path);
    out << "HIERARCHY\nROOT Body\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition "
           "Zrotation Yrotation Xrotation\n  JOINT Tail\n  {\n    OFFSET 0 0 -0.5\n    CHANNELS 1 "
           "Zrotation\n    End Site\n    {\n      OFFSET 0 0 -0.2\n    }\n  }\n}\nMOTION\nFrames: 2\n"
           "Frame Time: 0.01\n0 0 1 0 0 0 0\n0 0 1 0 0 0 0\n";
  }
  try {
    suggestMapping(readBvh(path), *model);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(e.reason().find("cannot suggest a mapping: joint \"Tail\""), std::string::npos) << e.what();
  }
}

// A model that does not stand on two legs is refused, saying what it stands on.
TEST(MappingSuggestion, AModelOnFourLegsIsRefusedWithItsFeet) {
  auto quadruped = test::makeModel("dart", urdf::loadUrdfFile(test::testModelPath("quadruped.urdf")), ModelOptions{});
  expectModelRefused(*quadruped, "does not stand on a left and a right leg: 4 legs end in a body it stands on");
}

}  // namespace
}  // namespace dynfilter::io
