// The filter as a 1 kHz control loop fed by a slower reference stream.
#include <fstream>
#include <regex>
#include <sstream>

#include <gtest/gtest.h>

#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/realtime/realtime_filter.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/reference_motions.hpp"
#include "support/test_support.hpp"

namespace dynfilter::realtime {
namespace {

constexpr double kSenderClock = 1000.0;  // the sender's clock is 1000 s ahead of ours

ReferenceFrame standingHold(IDynamicsModel& model) {
  ReferenceFrame hold(model.nq(), model.nv());
  hold.q = model.info().neutralConfiguration();
  hold.q[2] = test::humanFigureStandingHeight();
  return hold;
}

class Realtime : public testing::Test {
 protected:
  void SetUp() override {
    model_ = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
    frames_ = test::simulateStandingSway(*model_, 1.5, 1e-3);
  }
  std::unique_ptr<IDynamicsModel> model_;
  std::vector<ReferenceFrame> frames_;
};

TEST_F(Realtime, A60HzStreamIsTrackedAt1kHzWithCommandsWithinLimits) {
  RealtimeFilter rt(*model_, FilterOptions{}, RealtimeOptions{}, standingHold(*model_));
  const ModelInfo& info = model_->info();
  double worst_joint_error = 0.0;
  for (int tick = 0; tick < 1400; ++tick) {
    const double now = 0.001 * tick;
    if (tick % 16 == 0) {  // ~60 Hz, stamped on the sender's clock
      ReferenceFrame f = frames_[static_cast<std::size_t>(tick)];
      f.time_s += kSenderClock;
      ASSERT_TRUE(rt.addReference(f, now));
    }
    const FilterOutput& out = rt.tick(now);
    ASSERT_TRUE(rt.command().allFinite());
    for (int j = 0; j < info.nj; ++j) ASSERT_LE(std::abs(rt.command()[j]), info.tau_max[j]);
    EXPECT_FALSE(rt.status() & kStatusStaleReference) << "tick " << tick;
    if (tick > 100) {
      // The sample is the reference 50 ms behind the newest frame: compare with the
      // simulated motion at that time.
      const double t_ref = rt.lastReference().time_s - kSenderClock;
      const auto& truth = frames_[static_cast<std::size_t>(std::lround(t_ref * 1000.0))];
      worst_joint_error = std::max(
          worst_joint_error, (rt.lastReference().q - truth.q).tail(info.nj).cwiseAbs().maxCoeff());
      // Bounded: the 60 Hz samples of the simulated start-up transient (arm PD) are coarse.
      EXPECT_LT(out.tracking_error.tail(info.nj).cwiseAbs().maxCoeff(), 0.1);
    }
  }
  EXPECT_LT(worst_joint_error, 2e-3) << "linear interpolation of a 60 Hz stream";
  EXPECT_EQ(rt.counters().frames_accepted, 88u);
}

TEST_F(Realtime, AStaleReferenceHoldsThePostureAndResumes) {
  RealtimeOptions options;
  options.stale_timeout_s = 0.1;
  RealtimeFilter rt(*model_, FilterOptions{}, options, standingHold(*model_));
  for (int tick = 0; tick < 300; ++tick) {
    if (tick % 10 == 0) {
      ReferenceFrame f = frames_[static_cast<std::size_t>(tick)];
      f.time_s += kSenderClock;
      rt.addReference(f, 0.001 * tick);
    }
    rt.tick(0.001 * tick);
  }
  EXPECT_FALSE(rt.stale());
  // Silence for 0.6 s: stale after 0.1 s, then the figure holds still.
  Eigen::VectorXd q_at_hold;
  for (int tick = 300; tick < 900; ++tick) {
    rt.tick(0.001 * tick);
    if (tick == 450) q_at_hold = rt.filter().q();
  }
  EXPECT_TRUE(rt.stale());
  EXPECT_TRUE(rt.status() & kStatusStaleReference);
  EXPECT_LT(rt.filter().v().tail(model_->nj()).cwiseAbs().maxCoeff(), 0.05);
  EXPECT_LT((rt.filter().q() - q_at_hold).cwiseAbs().maxCoeff(), 0.02);
  EXPECT_GT(rt.counters().stale_ticks, 400u);
  // A new stream (another clock) takes over again.
  ReferenceFrame f = frames_[900];
  f.time_s += 5000.0;
  EXPECT_TRUE(rt.addReference(f, 0.9));
  rt.tick(0.901);
  EXPECT_FALSE(rt.stale());
}

TEST_F(Realtime, FramesGoingBackInTimeAreRejected) {
  RealtimeFilter rt(*model_, FilterOptions{}, RealtimeOptions{}, standingHold(*model_));
  ReferenceFrame f = frames_[100];
  EXPECT_TRUE(rt.addReference(f, 0.0));
  f.time_s -= 0.01;
  EXPECT_FALSE(rt.addReference(f, 0.001));
  EXPECT_EQ(rt.counters().frames_rejected, 1u);
}

TEST(RealtimeLimits, CommandsAreClampedToTheUrdfEffortLimits) {
  // The human figure with every effort limit at 5 N m: standing needs more.
  std::ifstream in(test::humanFigurePath());
  std::stringstream text;
  text << in.rdbuf();
  const std::string weak =
      std::regex_replace(text.str(), std::regex(R"(effort="[0-9.]+")"), R"(effort="5")");
  const std::string path = testing::TempDir() + "/weak_figure.urdf";
  std::ofstream(path) << weak;
  auto model = test::makeModel("dart", urdf::loadUrdfFile(path), ModelOptions{});
  // Holding a half squat takes far more than 5 N m at hips, knees and ankles.
  const ModelInfo& info = model->info();
  ReferenceFrame hold(model->nq(), model->nv());
  hold.q = info.neutralConfiguration();
  for (const char* side : {"l_", "r_"}) {
    const std::string p = side;
    hold.q[info.configurationIndex(info.findJoint(p + "hip_pitch"))] = -0.5;
    hold.q[info.configurationIndex(info.findJoint(p + "knee"))] = 1.0;
    hold.q[info.configurationIndex(info.findJoint(p + "ankle_pitch"))] = -0.5;
  }
  hold.q[2] = standingBaseHeight(*model, hold.q);
  RealtimeFilter rt(*model, FilterOptions{}, RealtimeOptions{}, hold);
  bool clamped = false;
  for (int tick = 0; tick < 50; ++tick) {
    rt.tick(0.001 * tick);
    clamped |= (rt.status() & kStatusTorqueClamped) != 0;
    EXPECT_LE(rt.command().cwiseAbs().maxCoeff(), 5.0);
  }
  EXPECT_TRUE(clamped);
  EXPECT_GT(rt.counters().torque_clamps, 0u);
}

}  // namespace
}  // namespace dynfilter::realtime

#include "dynfilter/realtime/replay_player.hpp"

namespace dynfilter::realtime {
namespace {

Clip line(const std::string& name, double slope, int frames, double rate) {
  Clip c;
  c.name = name;
  for (int k = 0; k < frames; ++k) {
    ReferenceFrame f(1, 1);
    f.time_s = 10.0 + k / rate;  // clips keep their own time stamps
    f.q << slope * k / rate;
    f.v << slope;
    f.vdot << 0.0;
    c.frames.push_back(f);
  }
  return c;
}

TEST(ReplayPlayer, SpeedOffsetLoopAndSwitching) {
  ReplayOptions options;
  options.speed = 2.0;
  options.start_offset_s = 0.5;
  options.loop = true;
  ReplayPlayer player({line("up", 1.0, 121, 120.0), line("down", -3.0, 61, 120.0)}, options,
                      false);
  ReferenceFrame out(1, 1);
  ASSERT_TRUE(player.frameAt(0.1, out));  // motion time 0.5 + 2 × 0.1 = 0.7 s
  EXPECT_NEAR(out.q[0], 0.7, 1e-12);
  EXPECT_NEAR(out.v[0], 2.0, 1e-12);  // velocity scales with speed
  ASSERT_TRUE(player.frameAt(0.4, out));  // 1.3 s → looped to 0.3 s
  EXPECT_NEAR(out.q[0], 0.3, 1e-12);
  player.switchTo(1, 1.0);
  ASSERT_TRUE(player.frameAt(1.1, out));  // clip 1 at 0.5 + 0.2 = 0.7 s → wraps at 0.5 s: 0.2
  EXPECT_NEAR(out.q[0], -3.0 * 0.2, 1e-12);
  EXPECT_EQ(player.currentClip(), 1);
}

TEST(ReplayPlayer, ANonLoopingClipEnds) {
  ReplayPlayer player({line("up", 1.0, 121, 120.0)}, ReplayOptions{}, false);
  ReferenceFrame out(1, 1);
  EXPECT_TRUE(player.frameAt(0.99, out));
  EXPECT_FALSE(player.frameAt(1.01, out));
  EXPECT_NEAR(out.q[0], 1.0, 1e-12);
  EXPECT_THROW(ReplayPlayer({}, ReplayOptions{}, false), std::invalid_argument);
}

}  // namespace
}  // namespace dynfilter::realtime
