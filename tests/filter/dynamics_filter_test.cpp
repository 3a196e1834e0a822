// Properties of the filter's output on the human figure (paper mode).
#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/reference_motions.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

constexpr double kDt = 1e-3;

class FilterOnHumanFigure : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
    sway_ = new std::vector<ReferenceFrame>(test::simulateStandingSway(*model, 2.0, kDt));
  }
  static void TearDownTestSuite() {
    delete sway_;
    sway_ = nullptr;
  }

  struct RunSummary {
    double max_base_residual_n = 0.0;
    double max_penetration_m = 0.0;
    double max_joint_error = 0.0;
    double max_base_position_error = 0.0;
    double max_abs_q_difference = 0.0;  // |q_filter − q_ref| componentwise
    int frames = 0;
    std::uint32_t status_union = 0;
  };

  static RunSummary run(IDynamicsModel& model, const std::vector<ReferenceFrame>& frames,
                        const FilterOptions& options = FilterOptions{}) {
    DynamicsFilter filter(model, options);
    filter.reset(frames.front());
    RunSummary s;
    for (const ReferenceFrame& ref : frames) {
      const FilterOutput& out = filter.step(ref);
      EXPECT_TRUE(out.q.allFinite() && out.v.allFinite() && out.vdot.allFinite() &&
                  out.tau_J.allFinite());
      s.max_base_residual_n = std::max(s.max_base_residual_n, out.base_residual_n);
      s.max_penetration_m = std::max(s.max_penetration_m, out.max_penetration_m);
      s.max_joint_error =
          std::max(s.max_joint_error, out.tracking_error.tail(model.nj()).cwiseAbs().maxCoeff());
      s.max_base_position_error =
          std::max(s.max_base_position_error, out.tracking_error.head<3>().norm());
      Eigen::VectorXd diff(model.nv());
      differenceConfiguration(true, ref.q, out.q, diff);
      s.max_abs_q_difference = std::max(s.max_abs_q_difference, diff.cwiseAbs().maxCoeff());
      s.status_union |= out.status;
      ++s.frames;
    }
    return s;
  }

  static std::vector<ReferenceFrame> shifted(double dz) {
    std::vector<ReferenceFrame> frames = *sway_;
    for (auto& f : frames) f.q[2] += dz;
    return frames;
  }

  static std::vector<ReferenceFrame>* sway_;
};
std::vector<ReferenceFrame>* FilterOnHumanFigure::sway_ = nullptr;

TEST_F(FilterOnHumanFigure, AConsistentReferencePassesThroughNearlyUnchanged) {
  // Reference simulated (Eq. 14) at the filter's own tick, 0.2 ms, for 1 s: the filter
  // must give it back.
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const double dt = 2e-4;
  const auto frames = test::simulateStandingSway(*model, 1.0, dt, 0.15, 0.5, 1);
  FilterOptions options;
  options.dt_s = dt;
  const RunSummary s = run(*model, frames, options);
  RecordProperty("max_abs_q_difference", std::to_string(s.max_abs_q_difference));
  EXPECT_LT(s.max_abs_q_difference, 1e-5) << "rad or m, over 1 s";
  EXPECT_LT(s.max_base_residual_n, 1e-8 * 70.0 * 9.81);
  EXPECT_EQ(s.status_union & (kStatusNonFinite | kStatusReseeded | kStatusRankDeficient), 0u);
}

TEST_F(FilterOnHumanFigure, AConsistentReferenceAtACoarserTickStaysClose) {
  // The same kind of reference, simulated 5× finer than the 1 kHz filter tick: only the
  // filter's own integration error separates them.
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const RunSummary s = run(*model, *sway_);
  RecordProperty("max_abs_q_difference", std::to_string(s.max_abs_q_difference));
  EXPECT_LT(s.max_abs_q_difference, 1e-2) << "rad or m, over 2 s at 1 kHz";
  EXPECT_LT(s.max_base_residual_n, 1e-8 * 70.0 * 9.81);
}

TEST_F(FilterOnHumanFigure, LiftedReferenceStillStandsOnTheGround) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const RunSummary s = run(*model, shifted(0.03));
  EXPECT_LT(s.max_base_residual_n, 1e-8 * 70.0 * 9.81);
  EXPECT_LT(s.max_penetration_m, 1e-3);
  EXPECT_LT(s.max_base_position_error, 0.06);  // it cannot float: ~3 cm below the reference
  EXPECT_LT(s.max_joint_error, 0.1);
  EXPECT_TRUE(s.status_union & kStatusImpact) << "the figure drops onto the floor";
}

TEST_F(FilterOnHumanFigure, SinkingReferenceDoesNotPenetrate) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const RunSummary s = run(*model, shifted(-0.02));
  EXPECT_LT(s.max_base_residual_n, 1e-8 * 70.0 * 9.81);
  EXPECT_LT(s.max_penetration_m, 1e-3);
  EXPECT_LT(s.max_base_position_error, 0.04);
  EXPECT_LT(s.max_joint_error, 0.1);
}

TEST_F(FilterOnHumanFigure, DoubledBodyMassIsStillConsistent) {
  // The model weighs 140 kg; the reference was made with the 70 kg figure.
  const std::string heavy = testing::TempDir() + "/heavy_figure.urdf";
  ASSERT_EQ(std::system(("python3 " + test::sourcePath("models/generate_human_figure.py") +
                         " --mass 140 -o " + heavy).c_str()), 0);
  auto model = test::makeModel("dart", urdf::loadUrdfFile(heavy), ModelOptions{});
  const RunSummary s = run(*model, *sway_);
  EXPECT_LT(s.max_base_residual_n, 1e-8 * 140.0 * 9.81);
  EXPECT_LT(s.max_penetration_m, 1e-3);
  EXPECT_LT(s.max_base_position_error, 0.05);
  EXPECT_LT(s.max_joint_error, 0.1);
}

TEST_F(FilterOnHumanFigure, SwitchingTheReferenceMidwayDoesNotBlowUp) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  auto other = test::simulateStandingSway(*model, 1.0, kDt, 0.3, 1.0);  // deeper, faster
  std::vector<ReferenceFrame> frames(sway_->begin(), sway_->begin() + 700);
  for (std::size_t k = 300; k < other.size(); ++k) {
    other[k].time_s = frames.back().time_s + kDt;
    frames.push_back(other[k]);
  }
  const RunSummary s = run(*model, frames);
  EXPECT_LT(s.max_base_residual_n, 1e-8 * 70.0 * 9.81);
  EXPECT_LT(s.max_joint_error, 0.3);
  EXPECT_LT(s.max_base_position_error, 0.1);
  EXPECT_EQ(s.status_union & (kStatusNonFinite | kStatusReseeded), 0u);
}

TEST_F(FilterOnHumanFigure, InvalidReferenceFramesAreFlaggedAndHeld) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  DynamicsFilter filter(*model, FilterOptions{});
  filter.reset(sway_->front());
  for (int k = 0; k < 50; ++k) filter.step((*sway_)[static_cast<std::size_t>(k)]);
  ReferenceFrame bad = (*sway_)[50];
  bad.q[10] = std::nan("");
  const FilterOutput& out = filter.step(bad);
  EXPECT_TRUE(out.status & kStatusReferenceInvalid);
  EXPECT_TRUE(out.q.allFinite() && out.tau_J.allFinite());
  ReferenceFrame wrong_size = (*sway_)[51];
  wrong_size.v.resize(3);
  EXPECT_TRUE(filter.step(wrong_size).status & kStatusReferenceInvalid);
  EXPECT_FALSE(filter.step((*sway_)[52]).status & kStatusReferenceInvalid);
}

// task.body not configured (the default): the trunk is chosen from the model's structure.
TEST(Filter, ChoosesTheTaskBodyFromTheModel) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  FilterOptions options;
  ASSERT_TRUE(options.task.body.empty());
  const DynamicsFilter filter(*model, options);
  EXPECT_EQ(filter.taskBody(), model->info().findBody("torso"));
  options.task.body = "head";
  EXPECT_EQ(DynamicsFilter(*model, options).taskBody(), model->info().findBody("head"));
}

TEST(Filter, RejectsAnUnknownTaskBody) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  FilterOptions options;
  options.task.body = "tail";
  try {
    DynamicsFilter filter(*model, options);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("\"tail\""), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dynfilter

namespace dynfilter {
namespace {

TEST(FilterTaskRows, Eq16KeepsTheChestOnItsReferenceAndEq12Holds) {
  // Reference: the standing sway with the whole figure 1 cm to the side. Feet stay where
  // they are; with P as Eq. 16 rows the chest follows its reference acceleration exactly,
  // so the chest error decays instead of being traded off.
  // The run starts 0.5 s into the squat: with straight knees the chest cannot rise, the
  // task rows are then dependent and dropped tick by tick (tested elsewhere).
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  auto frames = test::simulateStandingSway(*model, 1.5, 1e-3);
  frames.erase(frames.begin(), frames.begin() + 500);
  FilterOptions options;
  options.task.as_constraint_rows = true;
  DynamicsFilter filter(*model, options);
  filter.reset(frames.front());
  double first_error = 0.0, last_error = 0.0, max_residual = 0.0;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    ReferenceFrame ref = frames[k];
    ref.q[1] += 0.01;
    const FilterOutput& out = filter.step(ref);
    if (k == 5) first_error = out.task_error.head<3>().norm();
    last_error = out.task_error.head<3>().norm();
    max_residual = std::max(max_residual, out.base_residual_n);
  }
  EXPECT_GT(first_error, 0.005);
  EXPECT_LT(last_error, 0.2 * first_error);
  EXPECT_LT(max_residual, 1e-8 * 70.0 * 9.81);
}

}  // namespace
}  // namespace dynfilter

namespace dynfilter {
namespace {

TEST(FilterTaskRows, DependentTaskRowsAreDroppedAndEq12StillHolds) {
  // Straight knees at the start of the sway: the chest's vertical row depends on the
  // contact rows. The tick flags it, solves Eq. 12 without the task rows, stays exact.
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const auto frames = test::simulateStandingSway(*model, 0.05, 1e-3);
  FilterOptions options;
  options.task.as_constraint_rows = true;
  DynamicsFilter filter(*model, options);
  filter.reset(frames.front());
  std::uint32_t seen = 0;
  for (const auto& f : frames) {
    const FilterOutput& out = filter.step(f);
    seen |= out.status;
    EXPECT_LT(out.base_residual_n, 1e-8 * 70.0 * 9.81);
    EXPECT_TRUE(out.vdot.allFinite());
    EXPECT_LT(out.vdot.cwiseAbs().maxCoeff(), 1e3);  // near-singular rows still pull hard
  }
  EXPECT_TRUE(seen & kStatusRankDeficient);
  EXPECT_FALSE(seen & kStatusReseeded);
}

}  // namespace
}  // namespace dynfilter

namespace dynfilter {
namespace {

TEST(Filter, FixedBaseWithARankDeficientTaskPointStaysFinite) {
  // The human figure welded at the pelvis: the chest point moves by the three waist
  // joints only, so J_P has rank 3. The filter must still produce finite torques that
  // hold the posture against gravity (the legs hang: their torques are small).
  ModelOptions options;
  options.floating_base = false;
  options.environment.has_ground = false;
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), options);
  const ModelInfo& info = model->info();
  ReferenceFrame ref(info.nq, info.nv);
  ref.q = info.neutralConfiguration();
  ref.q[info.findJoint("l_shoulder_pitch")] = -1.0;  // an arm held forward needs torque
  DynamicsFilter filter(*model, FilterOptions{});
  filter.reset(ref);
  for (int k = 0; k < 200; ++k) {
    const FilterOutput& out = filter.step(ref);
    ASSERT_EQ(out.status & kStatusNonFinite, 0u) << "tick " << k;
    ASSERT_TRUE(out.tau_J.allFinite());
  }
  EXPECT_GT(std::abs(filter.output().tau_J[info.findJoint("l_shoulder_pitch")]), 1.0);
  EXPECT_LT((filter.q() - ref.q).cwiseAbs().maxCoeff(), 1e-3);
}

}  // namespace
}  // namespace dynfilter
