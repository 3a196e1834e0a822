// Retargeting to a URDF that is not the human figure (tests/models/mini_humanoid.urdf: its
// own names and proportions), the IK mode, unmapped joints, the reference clean-up and the
// structural choice of the trunk (dynfilter/io/retarget.hpp, reference_cleanup.hpp,
// dynfilter/core/kinematic_tree.hpp).

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/core/kinematic_tree.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/io/pose_ik.hpp"
#include "dynfilter/io/reference_cleanup.hpp"
#include "dynfilter/io/retarget.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"
#include "mini_humanoid_bvh.hpp"
#include "support/test_support.hpp"

namespace dynfilter::io {
namespace {

using testing_io::knownAngles;
using testing_io::miniBvhWithLimbs;
using testing_io::writeMiniBvh;


constexpr const char* kChainMapping = R"(length_scale: 1
up_axis: +z
bvh_forward: +x
root: {bvh: Hips, link: hips}
segments:
  - {link: chest, bvh: Waist, align: false}
  - {link: humerus_l, bvh: LArm, align: false}
  - {link: ulna_l, bvh: LElbow, align: false}
  - {link: humerus_r, bvh: RArm, align: false}
  - {link: ulna_r, bvh: RElbow, align: false}
  - {link: femur_l, bvh: LHip, align: false}
  - {link: tibia_l, bvh: LKnee, align: false}
  - {link: sole_l, bvh: LAnkle, align: false}
  - {link: femur_r, bvh: RHip, align: false}
  - {link: tibia_r, bvh: RKnee, align: false}
  - {link: sole_r, bvh: RAnkle, align: false}
)";

// IK: positions of the joint centres, orientations of the chest, forearms and soles.
constexpr const char* kIkMapping = R"(length_scale: 1
up_axis: +z
bvh_forward: +x
mode: ik
ik: {scale: 1, posture_weight: 0.0001, max_iterations: 200}
root: {bvh: Hips, link: hips}
segments:
  - {link: chest, bvh: Waist, align: false, position_weight: 0, orientation_weight: 1}
  - {link: humerus_l, bvh: LArm}
  - {link: ulna_l, bvh: LElbow, align: false, orientation_weight: 1}
  - {link: humerus_r, bvh: RArm}
  - {link: ulna_r, bvh: RElbow, align: false, orientation_weight: 1}
  - {link: tibia_l, bvh: LKnee}
  - {link: sole_l, bvh: LAnkle, align: false, orientation_weight: 1}
  - {link: tibia_r, bvh: RKnee}
  - {link: sole_r, bvh: RAnkle, align: false, orientation_weight: 1}
)";

void expectKnownAngles(const RetargetResult& r, const ModelInfo& info,
                       const std::vector<std::map<std::string, double>>& truth, double tol) {
  ASSERT_EQ(r.motion.frames.size(), truth.size());
  for (std::size_t k = 0; k < truth.size(); ++k)
    for (const auto& [name, value] : truth[k]) {
      const int j = info.findJoint(name);
      ASSERT_GE(j, 0) << name;
      EXPECT_NEAR(r.motion.frames[k].q[info.configurationIndex(j)], value, tol)
          << name << " frame " << k;
    }
}

TEST(RetargetAnyUrdf, ChainModeRecoversKnownAnglesOnAnotherModel) {
  auto model = test::makeMiniHumanoid();
  const std::vector<std::map<std::string, double>> truth = {knownAngles(0.0), knownAngles(1.0),
                                                            knownAngles(0.5)};
  const std::string path = writeMiniBvh(truth, "mini_chain.bvh");
  const RetargetResult r =
      retargetBvhFile(path, parseRetargetMapping(kChainMapping, "chain.yaml"), *model);
  EXPECT_TRUE(r.unmapped_joints.empty());
  expectKnownAngles(r, model->info(), truth, 1e-9);
  // Base orientation: yaw 10° per frame.
  const Eigen::Quaterniond q1(r.motion.frames[1].q[3], r.motion.frames[1].q[4],
                              r.motion.frames[1].q[5], r.motion.frames[1].q[6]);
  EXPECT_NEAR(Eigen::AngleAxisd(q1).angle(), 10.0 * test::kRadPerDeg, 1e-9);
}

TEST(RetargetAnyUrdf, IkModeRecoversKnownAnglesOnAnotherModel) {
  auto model = test::makeMiniHumanoid();
  const std::vector<std::map<std::string, double>> truth = {knownAngles(0.2), knownAngles(1.0),
                                                            knownAngles(0.6)};
  const std::string path = writeMiniBvh(truth, "mini_ik.bvh");
  const RetargetResult r = retargetBvhFile(path, parseRetargetMapping(kIkMapping, "ik.yaml"), *model);
  EXPECT_TRUE(r.unmapped_joints.empty());
  EXPECT_DOUBLE_EQ(r.ik_scale, 1.0);
  expectKnownAngles(r, model->info(), truth, 1e-3);
  ASSERT_EQ(r.targets.size(), 10u);
  for (const TargetReport& t : r.targets) {
    EXPECT_LT(t.position_max_m, 1e-4) << t.link;
    EXPECT_LT(t.orientation_max_rad, 1e-3) << t.link;
  }
  EXPECT_NE(formatTargetReport(r).find("sole_l"), std::string::npos);
}

TEST(RetargetAnyUrdf, IkModeAutoScaleIsTheLegLengthRatio) {
  auto model = test::makeMiniHumanoid();
  const std::vector<std::map<std::string, double>> truth = {knownAngles(0.0), knownAngles(0.1)};
  const std::string path = writeMiniBvh(truth, "mini_scale.bvh");
  RetargetMapping m = parseRetargetMapping(kIkMapping, "ik.yaml");
  m.ik.scale = 0.0;
  m.length_scale = 2.0;  // the capture is twice the robot's size
  const RetargetResult r = retargetBvhFile(path, m, *model);
  EXPECT_NEAR(r.ik_scale, 0.5, 1e-9);
}

TEST(RetargetAnyUrdf, IkModeStaysInsideTheLimits) {
  auto model = test::makeMiniHumanoid();
  const ModelInfo& info = model->info();
  std::vector<std::map<std::string, double>> truth = {knownAngles(0.2), knownAngles(0.4)};
  truth[1]["genu_l"] = -25.0 * test::kRadPerDeg;  // hyperextended: the knee's range is [0, 2.3]
  truth[1]["cubitus_r"] = 20.0 * test::kRadPerDeg;  // beyond the elbow's upper limit 0
  const std::string path = writeMiniBvh(truth, "mini_limits.bvh");
  const RetargetResult r = retargetBvhFile(path, parseRetargetMapping(kIkMapping, "ik.yaml"), *model);
  for (const ReferenceFrame& f : r.motion.frames)
    for (int j = 0; j < info.nj; ++j) {
      EXPECT_GE(f.q[info.configurationIndex(j)], info.q_lower[j] - 1e-12) << info.joint_names[j];
      EXPECT_LE(f.q[info.configurationIndex(j)], info.q_upper[j] + 1e-12) << info.joint_names[j];
    }
  for (const JointLimitReport& l : r.limits) EXPECT_EQ(l.frames_outside, 0) << l.joint;
  EXPECT_NEAR(r.motion.frames[1].q[info.configurationIndex(info.findJoint("genu_l"))], 0.0, 1e-12);
}

// A capture of other proportions (thighs 0.40 m for the model's 0.30, shanks 0.26 for 0.32,
// upper arms 0.31 for 0.25) gives the model the capture's joint angles: each target is
// placed from the robot's hip, knee, shoulder or elbow along the capture's bone, scaled by
// the limb's ratio (ik.scaling: limbs, the default). Each replacement below makes a length
// no later one matches. The uniform scaling about the base
// puts the same targets where the model cannot reach them with those angles.
TEST(RetargetAnyUrdf, IkModeLimbScalingGivesOtherProportionsTheCapturesAngles) {
  auto model = test::makeMiniHumanoid();
  const std::vector<std::map<std::string, double>> truth = {knownAngles(0.2), knownAngles(1.0),
                                                            knownAngles(0.6)};
  const std::string path = writeMiniBvh(
      truth, "mini_limbs.bvh", miniBvhWithLimbs({{"-0.30", "-0.40"}, {"-0.32", "-0.26"}, {"-0.25", "-0.31"}}));
  const RetargetMapping limbs = parseRetargetMapping(kIkMapping, "ik.yaml");
  ASSERT_TRUE(limbs.ik.limb_scaling);
  const RetargetResult r = retargetBvhFile(path, limbs, *model);
  expectKnownAngles(r, model->info(), truth, 1e-3);
  std::map<std::string, const TargetReport*> report;
  for (const TargetReport& t : r.targets) report[t.link] = &t;
  EXPECT_TRUE(report.at("tibia_l")->limb_scaled);
  EXPECT_EQ(report.at("tibia_l")->limb_from, "LHip");  // the hip's pivot: its three axes meet there
  EXPECT_NEAR(report.at("tibia_l")->limb_ratio, 0.30 / 0.40, 1e-9);
  EXPECT_NEAR(report.at("sole_r")->limb_ratio, 0.32 / 0.26, 1e-9);
  EXPECT_EQ(report.at("sole_r")->limb_from, "RKnee");
  EXPECT_NEAR(report.at("ulna_l")->limb_ratio, 0.25 / 0.31, 1e-9);
  EXPECT_NEAR(report.at("humerus_r")->limb_ratio, 1.0, 1e-9);  // from the chest: same shoulders
  for (const TargetReport& t : r.targets) EXPECT_LT(t.position_max_m, 1e-4) << t.link;
  EXPECT_NE(formatTargetReport(r).find("limb x 0.750 from LHip"), std::string::npos) << formatTargetReport(r);

  RetargetMapping uniform = parseRetargetMapping(kIkMapping, "ik.yaml");
  uniform.ik.limb_scaling = false;
  const RetargetResult u = retargetBvhFile(path, uniform, *model);
  const ModelInfo& info = model->info();
  const int knee = info.configurationIndex(info.findJoint("genu_l"));
  EXPECT_GT(std::fabs(u.motion.frames[1].q[knee] - truth[1].at("genu_l")), 0.1);
  for (const TargetReport& t : u.targets) EXPECT_FALSE(t.limb_scaled) << t.link;
}

// A limb whose ratio is far from the uniform scale (a capture's shank a third of the
// model's: more likely a bone that does not correspond than a body) keeps the uniform
// scaling, and the report says so; a bad `ik.scaling` is named.
TEST(RetargetAnyUrdf, IkModeLimbRatioOutOfRangeKeepsUniformScaling) {
  auto model = test::makeMiniHumanoid();
  const std::string path =
      writeMiniBvh({knownAngles(0.2), knownAngles(0.4)}, "mini_short.bvh", miniBvhWithLimbs({{"-0.32", "-0.10"}}));
  const RetargetResult r = retargetBvhFile(path, parseRetargetMapping(kIkMapping, "ik.yaml"), *model);
  for (const TargetReport& t : r.targets) {
    if (t.link == "sole_l" || t.link == "sole_r") {
      EXPECT_FALSE(t.limb_scaled) << t.link;
      EXPECT_NEAR(t.limb_ratio, 3.2, 1e-9) << t.link;
    } else if (t.link == "tibia_l" || t.link == "ulna_r") {
      EXPECT_TRUE(t.limb_scaled) << t.link;
    }
  }
  EXPECT_NE(formatTargetReport(r).find("uniform (limb x 3.200 from LKnee: out of range)"), std::string::npos)
      << formatTargetReport(r);
  std::string text = kIkMapping;
  text.replace(text.find("ik: {"), 5, "ik: {scaling: wide, ");
  try {
    parseRetargetMapping(text, "bad.yaml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 5) << e.what();
    EXPECT_NE(e.reason().find("ik.scaling: expected limbs or uniform"), std::string::npos) << e.what();
  }
}

TEST(RetargetAnyUrdf, UnmappedJointsAreAnErrorUnlessAllowed) {
  auto model = test::makeMiniHumanoid();
  const std::vector<std::map<std::string, double>> truth = {knownAngles(0.0), knownAngles(1.0)};
  const std::string path = writeMiniBvh(truth, "mini_unmapped.bvh");
  std::string text = kChainMapping;
  for (const char* arm : {"  - {link: ulna_l, bvh: LElbow, align: false}\n",
                          "  - {link: ulna_r, bvh: RElbow, align: false}\n"})
    text.erase(text.find(arm), std::string(arm).size());
  try {
    retargetBvhFile(path, parseRetargetMapping(text, "arms.yaml"), *model);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(e.reason().find("cubitus_l"), std::string::npos) << e.what();
    EXPECT_NE(e.reason().find("cubitus_r"), std::string::npos) << e.what();
    EXPECT_NE(e.reason().find("allow_unmapped"), std::string::npos) << e.what();
  }
  RetargetMapping m = parseRetargetMapping(text, "arms.yaml");
  m.allow_unmapped = true;
  const RetargetResult r = retargetBvhFile(path, m, *model);
  EXPECT_EQ(r.unmapped_joints, (std::vector<std::string>{"cubitus_l", "cubitus_r"}));
  const ModelInfo& info = model->info();
  EXPECT_EQ(r.motion.frames[1].q[info.configurationIndex(info.findJoint("cubitus_l"))], 0.0);
  EXPECT_NEAR(r.motion.frames[1].q[info.configurationIndex(info.findJoint("genu_l"))], 50.0 * test::kRadPerDeg, 1e-9);
}

TEST(RetargetAnyUrdf, ChainModeRejectsAGroupOfMoreThanThreeJoints) {
  auto model = test::makeMiniHumanoid();
  const std::string path = writeMiniBvh({knownAngles(0.0), knownAngles(1.0)}, "mini_group.bvh");
  // Without the thigh and shank, the six leg joints lie between the hips and the sole.
  std::string text = kChainMapping;
  for (const std::string link : {"  - {link: tibia_l, bvh: LKnee, align: false}\n",
                                 "  - {link: femur_l, bvh: LHip, align: false}\n"})
    text.erase(text.find(link), link.size());
  try {
    retargetBvhFile(path, parseRetargetMapping(text, "group.yaml"), *model);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(e.reason().find("mode: ik"), std::string::npos) << e.what();
  }
}

// A mapping given the wrong model says so, and a misspelt link is named with its line.
TEST(RetargetAnyUrdf, AMappingForAnotherRobotIsToldApartFromAMisspeltLink) {
  const std::string path = writeMiniBvh({knownAngles(0.0), knownAngles(1.0)}, "mini_other.bvh");
  auto human = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  try {
    retargetBvhFile(path, parseRetargetMapping(kChainMapping, "mini.yaml"), *human);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 0) << e.what();
    EXPECT_NE(e.reason().find("only 0 of its 12 links"), std::string::npos) << e.what();
    EXPECT_NE(e.reason().find("another robot"), std::string::npos) << e.what();
  }
  // Every link left out is listed when the list is short enough: no ", ..." after the last
  // (two long names make a list of 60 characters or more).
  const std::string first = "link_that_is_not_on_this_model_1", second = "link_that_is_not_on_this_model_2";
  const std::string two = "length_scale: 1\nup_axis: +z\nbvh_forward: +x\nroot: {bvh: Hips, link: " + first +
                          "}\nsegments:\n  - {link: " + second + ", bvh: Waist}\n";
  try {
    retargetBvhFile(path, parseRetargetMapping(two, "two.yaml"), *human);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(e.reason().find("(not: \"" + first + "\", \"" + second + "\"): a mapping"), std::string::npos)
        << e.what();
  }
  std::string text = kChainMapping;
  text.replace(text.find("tibia_l"), 7, "tibai_l");
  try {
    retargetBvhFile(path, parseRetargetMapping(text, "typo.yaml"), *test::makeMiniHumanoid());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 12) << e.what();
    EXPECT_NE(e.reason().find("link \"tibai_l\" not in model"), std::string::npos) << e.what();
  }
}

TEST(KinematicTree, ChoosesTheTrunkByStructure) {
  auto m = test::makeMiniHumanoid();
  EXPECT_EQ(m->info().body_names[static_cast<std::size_t>(chooseTrunkBody(*m))], "chest");
  auto human = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  EXPECT_EQ(human->info().body_names[static_cast<std::size_t>(chooseTrunkBody(*human))], "torso");
  const KinematicTree tree = kinematicTreeOf(*m);
  const ModelInfo& info = m->info();
  const std::vector<int> leg = tree.jointsBetween(info.findBody("hips"), info.findBody("sole_l"));
  std::vector<std::string> names;
  for (const int j : leg) names.push_back(info.joint_names[static_cast<std::size_t>(j)]);
  EXPECT_EQ(names, (std::vector<std::string>{"coxa_l_z", "coxa_l_x", "coxa_l_y", "genu_l",
                                             "talo_l_y", "talo_l_x"}));
}

// Joint groups by structure: on the mini humanoid (no head: its shoulders are its highest
// bodies) and on the human figure (a neck on the midline), against what their names say.
TEST(KinematicTree, GroupsJointsByStructure) {
  const auto byName = [](const std::string& n) {
    for (const char* leg : {"hip", "knee", "ankle", "toe", "coxa", "genu", "talo"})
      if (n.find(leg) != std::string::npos) return JointGroup::kLeg;
    for (const char* arm : {"shoulder", "elbow", "wrist", "arm", "cubitus"})
      if (n.find(arm) != std::string::npos) return JointGroup::kArm;
    return JointGroup::kSpine;  // waist, neck, spine_twist
  };
  auto mini = test::makeMiniHumanoid();
  auto human = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  int spine_joints = 0;
  for (IDynamicsModel* m : {mini.get(), human.get()}) {
    const std::vector<JointGroup> groups = jointGroupsOf(*m);
    ASSERT_EQ(groups.size(), static_cast<std::size_t>(m->info().nj));
    for (int j = 0; j < m->info().nj; ++j) {
      const std::string& name = m->info().joint_names[static_cast<std::size_t>(j)];
      EXPECT_EQ(toString(groups[static_cast<std::size_t>(j)]), std::string(toString(byName(name))))
          << m->info().name << " " << name;
      spine_joints += groups[static_cast<std::size_t>(j)] == JointGroup::kSpine;
    }
  }
  EXPECT_GE(spine_joints, 1 + 6) << "the mini's twist, the figure's waist and neck";
  ModelOptions welded;
  welded.floating_base = false;
  auto arm = test::makeModel("dart", urdf::loadUrdfFile(test::sourcePath("tests/models/arm7.urdf")), welded);
  for (const JointGroup g : jointGroupsOf(*arm)) EXPECT_EQ(g, JointGroup::kOther) << "fixed base";
}

// A standing reference whose feet skate 6 cm forward and sink 1.5 cm over the clip, with
// an elbow beyond its limit: the clean-up holds both stance feet still on the ground and
// brings every joint inside its limits.
// With no targets, PoseIk's answer for a joint away from its limits minimises
// w_p² (q − q_p)² + w_c² (q − q_prev)²: q = (w_p² q_p + w_c² q_prev) / (w_p² + w_c²).
TEST(PoseIk, ContinuityTermIsTheWeightedMeanOfPostureAndPrevious) {
  auto model = test::makeMiniHumanoid();
  const ModelInfo& info = model->info();
  const int j = info.findJoint("genu_l");
  const int qi = info.configurationIndex(j), vi = info.velocityIndex(j);
  ASSERT_LT(info.q_lower[j], 0.2);
  ASSERT_GT(info.q_upper[j], 0.6);
  Eigen::VectorXd q_posture = info.neutralConfiguration(), q_previous = q_posture;
  q_posture[qi] = 0.2;
  q_previous[qi] = 0.6;
  Eigen::VectorXd weights = Eigen::VectorXd::Ones(info.nv);
  weights[vi] = 0.5;
  IkOptions options;
  options.continuity_weight = 2.0;
  options.max_iterations = 200;
  Eigen::VectorXd q = q_posture;
  EXPECT_TRUE(solvePoseIk(*model, {}, q_posture, weights, options, q, &q_previous).converged);
  EXPECT_NEAR(q[qi], (0.25 * 0.2 + 4.0 * 0.6) / 4.25, 1e-6);
  // Without a previous answer the term is off.
  q = q_previous;
  solvePoseIk(*model, {}, q_posture, weights, options, q);
  EXPECT_NEAR(q[qi], 0.2, 1e-6);
}

TEST(ReferenceCleanup, StanceFeetStayStillOnTheGroundAndJointsInsideLimits) {
  auto model = test::makeMiniHumanoid();
  const ModelInfo& info = model->info();
  Eigen::VectorXd q = info.neutralConfiguration();
  q[info.configurationIndex(info.findJoint("genu_l"))] = 0.3;
  q[info.configurationIndex(info.findJoint("genu_r"))] = 0.3;
  q[info.configurationIndex(info.findJoint("coxa_l_y"))] = -0.15;
  q[info.configurationIndex(info.findJoint("coxa_r_y"))] = -0.15;
  q[info.configurationIndex(info.findJoint("talo_l_y"))] = -0.15;
  q[info.configurationIndex(info.findJoint("talo_r_y"))] = -0.15;
  const double z0 = standingBaseHeight(*model, q);
  ReferenceMotion motion;
  const int n = 101;
  for (int k = 0; k < n; ++k) {
    const double s = static_cast<double>(k) / (n - 1);
    ReferenceFrame f(info.nq, info.nv);
    f.time_s = 0.01 * k;
    f.q = q;
    f.q[0] = 0.06 * s;
    f.q[2] = z0 - 0.015 * s;
    f.q[info.configurationIndex(info.findJoint("cubitus_l"))] = 0.2;  // upper limit 0
    motion.frames.push_back(f);
  }
  estimateDerivatives(motion.frames, true, 7, true, true);
  const CleanupResult r = cleanupReference(motion, *model, ReferenceCleanupOptions{}, proxqp::factory());
  ASSERT_EQ(r.schedule.links, (std::vector<std::string>{"sole_l", "sole_r"}));
  for (const auto& row : r.schedule.stance) {
    EXPECT_EQ(row[0], 1);
    EXPECT_EQ(row[1], 1);
  }
  ASSERT_EQ(r.report.feet.size(), 2u);
  for (const FootReport& f : r.report.feet) {
    EXPECT_NEAR(f.skate_before_m, 0.06, 1e-6) << f.link;
    EXPECT_NEAR(f.penetration_before_m, 0.015, 1e-4) << f.link;
    EXPECT_LE(f.skate_after_m, 1e-3) << f.link;
    EXPECT_LE(f.penetration_after_m, 1e-4) << f.link;
  }
  // Independently of the report: the soles' corners on the ground, not moving.
  std::vector<Eigen::Vector3d> first;
  for (std::size_t k = 0; k < r.motion.frames.size(); ++k) {
    const ReferenceFrame& f = r.motion.frames[k];
    for (int j = 0; j < info.nj; ++j) {
      EXPECT_GE(f.q[info.configurationIndex(j)], info.q_lower[j] - 1e-12);
      EXPECT_LE(f.q[info.configurationIndex(j)], info.q_upper[j] + 1e-12);
    }
    model->setState(f.q, Eigen::VectorXd::Zero(info.nv));
    for (const char* sole : {"sole_l", "sole_r"}) {
      const Eigen::Isometry3d X = model->bodyPose(info.findBody(sole));
      for (const double x : {-0.06, 0.12}) {
        const Eigen::Vector3d p = X * Eigen::Vector3d(x, 0.0, -0.05);
        EXPECT_NEAR(p.z(), 0.0, 1e-4) << sole << " frame " << k;
        if (k == 0) first.push_back(p);
      }
    }
    if (k > 0) {
      std::size_t i = 0;
      for (const char* sole : {"sole_l", "sole_r"})
        for (const double x : {-0.06, 0.12}) {
          const Eigen::Vector3d p = model->bodyPose(info.findBody(sole)) * Eigen::Vector3d(x, 0.0, -0.05);
          EXPECT_LT((p - first[i++]).head<2>().norm(), 1e-3) << sole << " frame " << k;
        }
    }
  }
  EXPECT_EQ(r.report.joints_outside_before, 1);
  EXPECT_EQ(r.report.joints_outside_after, 0);
  const JointChangeReport& elbow = r.report.joints[static_cast<std::size_t>(info.findJoint("cubitus_l"))];
  EXPECT_NEAR(elbow.max_change_rad, 0.2, 1e-9);
  EXPECT_GT(r.report.rms_change_rad, 0.0);
  // The schedule file.
  const std::string path = ::testing::TempDir() + "/schedule.stance.csv";
  writeContactScheduleCsv(path, r.schedule);
  std::ifstream in(path);
  std::string header, row;
  std::getline(in, header);
  std::getline(in, row);
  EXPECT_EQ(header, "time,sole_l,sole_r");
  EXPECT_EQ(row, "0,1,1");
}

TEST(ReferenceCleanup, ScheduleSeesASwingFoot) {
  auto model = test::makeMiniHumanoid();
  const ModelInfo& info = model->info();
  const Eigen::VectorXd q0 = info.neutralConfiguration();
  const double z0 = standingBaseHeight(*model, q0);
  ReferenceMotion motion;
  const int n = 121;
  for (int k = 0; k < n; ++k) {
    ReferenceFrame f(info.nq, info.nv);
    f.time_s = 0.01 * k;
    f.q = q0;
    f.q[2] = z0;
    // The left leg swings (hip flexion and knee) between 0.4 and 0.8 s.
    const double s = (k >= 40 && k <= 80) ? std::sin(M_PI * (k - 40) / 40.0) : 0.0;
    f.q[info.configurationIndex(info.findJoint("coxa_l_y"))] = -0.8 * s;
    f.q[info.configurationIndex(info.findJoint("genu_l"))] = 1.2 * s;
    motion.frames.push_back(f);
  }
  const ContactSchedule s = findContactSchedule(motion, *model, ReferenceCleanupOptions{});
  ASSERT_EQ(s.links.size(), 2u);
  EXPECT_EQ(s.stance[20][0], 1);
  EXPECT_EQ(s.stance[60][0], 0);
  EXPECT_EQ(s.stance[110][0], 1);
  for (int k = 0; k < n; ++k) EXPECT_EQ(s.stance[static_cast<std::size_t>(k)][1], 1) << k;
}

}  // namespace
}  // namespace dynfilter::io
