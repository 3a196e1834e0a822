// The filter as a 1 kHz control loop fed by a slower reference stream.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/qp_engines/qp_engines.hpp"
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

// The real-time options with no soft start: the sample is compared with the stream itself
// (the soft start has its own test).
RealtimeOptions withoutSoftStart() {
  RealtimeOptions options;
  options.stream_blend_s = 0.0;
  return options;
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
  RealtimeFilter rt(*model_, FilterOptions{}, withoutSoftStart(), standingHold(*model_));
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

TEST_F(Realtime, MalformedFramesAreRejectedWithoutTouchingTheStream) {
  RealtimeFilter rt(*model_, FilterOptions{}, RealtimeOptions{}, standingHold(*model_));
  ReferenceFrame f = frames_[100];
  ReferenceFrame short_q = f;
  short_q.q.resize(model_->nq() - 1);
  EXPECT_FALSE(rt.addReference(short_q, 0.0));
  ReferenceFrame nan = f;
  nan.v[10] = std::nan("");
  EXPECT_FALSE(rt.addReference(nan, 0.0));
  EXPECT_EQ(rt.counters().frames_rejected, 2u);
  EXPECT_EQ(rt.referenceStream().counters().streams, 0u) << "the stream policy never saw them";
  EXPECT_TRUE(rt.addReference(f, 0.001));
  rt.tick(0.002);
  EXPECT_TRUE(rt.command().allFinite());
}

TEST_F(Realtime, BadOptionsThrow) {
  RealtimeOptions blend;
  blend.stream_blend_s = -1.0;
  EXPECT_THROW(RealtimeFilter(*model_, FilterOptions{}, blend, standingHold(*model_)), std::invalid_argument);
  RealtimeOptions delay;
  delay.reference_delay_s = std::nan("");
  EXPECT_THROW(RealtimeFilter(*model_, FilterOptions{}, delay, standingHold(*model_)), std::invalid_argument);
  delay.reference_delay_s = 10.5;  // its frames are kept: bounded
  try {
    RealtimeFilter rt(*model_, FilterOptions{}, delay, standingHold(*model_));
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("must be <= 10 s"), std::string::npos) << e.what();
  }
  RealtimeOptions silence;
  silence.stale_timeout_s = std::numeric_limits<double>::infinity();
  EXPECT_THROW(RealtimeFilter(*model_, FilterOptions{}, silence, standingHold(*model_)), std::invalid_argument);
}

TEST_F(Realtime, FramesGoingBackInTimeAreRejected) {
  RealtimeFilter rt(*model_, FilterOptions{}, RealtimeOptions{}, standingHold(*model_));
  ReferenceFrame f = frames_[100];
  EXPECT_TRUE(rt.addReference(f, 0.0));
  f.time_s -= 0.01;
  EXPECT_FALSE(rt.addReference(f, 0.001));
  EXPECT_EQ(rt.counters().frames_rejected, 1u);
  EXPECT_EQ(rt.referenceStream().lastRejection(), StreamVerdict::kNotAfterPrevious);
}

// Streams: the real sender sends the simulated motion at 60 Hz (every 16 ticks of 1 ms),
// stamped motion time + offset(tick) on its clock (the offset changes when it restarts);
// inject(tick, now) may send other frames. The filter ticks at 1 kHz. From check_from on,
// no tick may be stale; returns the worst joint error of the sampled reference against
// the motion at the sample's time on the real sender's clock.
template <class Offset, class Inject>
double runStream(RealtimeFilter& rt, const std::vector<ReferenceFrame>& frames, int ticks,
                 int check_from, Offset&& offset, Inject&& inject) {
  const int nj = static_cast<int>(frames.front().q.size()) - 7;
  double worst = 0.0;
  for (int tick = 0; tick < ticks; ++tick) {
    const double now = 0.001 * tick;
    inject(tick, now);
    if (tick % 16 == 0) {
      ReferenceFrame f = frames[static_cast<std::size_t>(tick)];
      f.time_s += offset(tick);
      rt.addReference(f, now, tick / 16);
    }
    rt.tick(now);
    if (tick < check_from) continue;
    EXPECT_FALSE(rt.status() & kStatusStaleReference) << "tick " << tick;
    const double motion_time = rt.lastReference().time_s - offset(tick);
    const long i = std::clamp(std::lround(motion_time * 1000.0), 0L,
                              static_cast<long>(frames.size()) - 1);
    worst = std::max(worst, (rt.lastReference().q - frames[static_cast<std::size_t>(i)].q)
                                .tail(nj).cwiseAbs().maxCoeff());
  }
  return worst;
}

// The sample lies the reference delay behind the newest frame at any sender's rate: a
// 1 kHz sender with the default 50 ms, and a 60 Hz one with 0.4 s. Before, the buffer kept
// 16 frames (16 ms at 1 kHz, 0.27 s at 60 Hz): the sample fell before the oldest frame and
// held that frame's pose at rest, a reference that stepped and never moved.
TEST_F(Realtime, TheReferenceDelayIsHonouredAtAnySendersRate) {
  const int nj = model_->nj();
  for (const auto& [period_ticks, delay_s] : {std::pair{1, 0.05}, std::pair{16, 0.4}}) {
    RealtimeOptions options = withoutSoftStart();
    options.reference_delay_s = delay_s;
    RealtimeFilter rt(*model_, FilterOptions{}, options, standingHold(*model_));
    double worst_pose = 0.0, worst_lag = 0.0, fastest = 0.0;
    for (int tick = 0; tick < 1400; ++tick) {
      const double now = 0.001 * tick;
      if (tick % period_ticks == 0) {
        ReferenceFrame f = frames_[static_cast<std::size_t>(tick)];
        f.time_s += kSenderClock;
        ASSERT_TRUE(rt.addReference(f, now));
      }
      rt.tick(now);
      if (now < delay_s + 0.2) continue;  // the start: the stream's first frame held
      const ReferenceFrame& r = rt.lastReference();
      const double t = r.time_s - kSenderClock;
      worst_lag = std::max(worst_lag, std::abs(now - t - delay_s));
      worst_pose = std::max(worst_pose,
                            (r.q - frames_[static_cast<std::size_t>(std::lround(t * 1000.0))].q).tail(nj).cwiseAbs().maxCoeff());
      fastest = std::max(fastest, r.v.tail(nj).cwiseAbs().maxCoeff());
    }
    SCOPED_TRACE("a frame every " + std::to_string(period_ticks) + " ms, delay " + std::to_string(delay_s) + " s");
    EXPECT_LT(worst_lag, 1e-9);
    EXPECT_LT(worst_pose, period_ticks == 1 ? 1e-12 : 2e-3);
    EXPECT_GT(fastest, 0.1) << "the sample moves with the stream";
  }
}

// A 1 kHz sender with a reference delay of 0.8 s keeps 800 frames ahead of the sampled
// time in the balance layer's preview, more than its configured capacity (512): the
// preview is sized for the delay, so the samples the DCM target needs first (those just
// ahead of the sampled time) are not the ones dropped.
TEST_F(Realtime, TheBalancePreviewHoldsTheFramesOfTheDelayAtAnySendersRate) {
  FilterOptions qp;
  qp.mode = FilterMode::kQp;
  ASSERT_LT(qp.balance.preview_capacity, 800);
  RealtimeOptions options = withoutSoftStart();
  options.reference_delay_s = 0.8;
  RealtimeFilter rt(*model_, qp, options, standingHold(*model_), qp_engines::factory("daqp"));
  int fewest_used = std::numeric_limits<int>::max();
  for (int tick = 0; tick < 1300; ++tick) {
    const double now = 0.001 * tick;
    ReferenceFrame f = frames_[static_cast<std::size_t>(tick)];
    f.time_s += kSenderClock;
    ASSERT_TRUE(rt.addReference(f, now));
    rt.tick(now);
    if (now > 0.9) fewest_used = std::min(fewest_used, rt.filter().balance()->preview_samples);
  }
  // preview_s = 50 ms of 1 ms frames ahead of each tick.
  EXPECT_GE(fewest_used, 45);
}

TEST_F(Realtime, OneFutureStampedFrameDoesNotInterruptTheRealStream) {
  RealtimeFilter rt(*model_, FilterOptions{}, withoutSoftStart(), standingHold(*model_));
  bool rejected = true;
  const double worst = runStream(
      rt, frames_, 1400, 100, [](int) { return kSenderClock; },
      [&](int tick, double now) {
        if (tick != 500) return;
        ReferenceFrame bogus = frames_[500];
        bogus.time_s += kSenderClock + test::kSecondsPerHour;
        bogus.q.tail(model_->nj()).array() += 0.5;  // and far from the motion
        rejected = !rt.addReference(bogus, now, 12345);
      });
  EXPECT_TRUE(rejected);
  EXPECT_LT(worst, 2e-3) << "the sample follows the real stream throughout";
  EXPECT_EQ(rt.referenceStream().counters().streams, 1u);
  EXPECT_EQ(rt.referenceStream().lastRejection(), StreamVerdict::kOffStreamClock);
  EXPECT_EQ(rt.counters().frames_rejected, 1u);
  EXPECT_EQ(rt.counters().stale_ticks, 0u);
}

TEST_F(Realtime, AFutureStampedFirstFrameThenTheRealStreamIsTrackedWithinTheStaleTimeout) {
  RealtimeOptions options = withoutSoftStart();
  ASSERT_EQ(options.stale_timeout_s, 0.25);
  RealtimeFilter rt(*model_, FilterOptions{}, options, standingHold(*model_));
  const double worst = runStream(
      rt, frames_, 1000, 150, [](int) { return kSenderClock; },
      [&](int tick, double now) {
        if (tick != 0) return;
        ReferenceFrame bogus = frames_[0];
        bogus.time_s += kSenderClock + test::kSecondsPerHour;
        EXPECT_TRUE(rt.addReference(bogus, now, 0)) << "nothing to tell it from yet";
      });
  // Two real frames are evidence, the third (tick 32) starts the stream; 50 ms of delay
  // later the sample is on it: well within the 0.25 s stale timeout.
  EXPECT_LT(worst, 2e-3);
  EXPECT_EQ(rt.referenceStream().counters().streams, 2u);
  EXPECT_EQ(rt.counters().frames_rejected, 2u);
  EXPECT_EQ(rt.counters().stale_ticks, 0u);
}

TEST_F(Realtime, ARestartedSenderIsFollowedWithinTheStaleTimeout) {
  RealtimeOptions options = withoutSoftStart();
  RealtimeFilter rt(*model_, FilterOptions{}, options, standingHold(*model_));
  // At tick 608 the sender restarts: its clock (and sequence) start again at 0.
  auto offset = [](int tick) { return tick < 608 ? kSenderClock : -0.608; };
  double worst = runStream(rt, frames_, 600, 100, offset, [](int, double) {});
  EXPECT_LT(worst, 2e-3);
  // The restart: 2 frames of evidence, the third (tick 640) is followed; allow its 50 ms
  // of reference delay, then the sample must be the restarted stream's.
  for (int tick = 600; tick < 1400; ++tick) {
    const double now = 0.001 * tick;
    if (tick % 16 == 0) {
      ReferenceFrame f = frames_[static_cast<std::size_t>(tick)];
      f.time_s += offset(tick);
      rt.addReference(f, now, (tick - 608) / 16);
    }
    rt.tick(now);
    EXPECT_FALSE(rt.status() & kStatusStaleReference) << "tick " << tick;
    if (tick < 608 + 150) continue;
    const double motion_time = rt.lastReference().time_s - offset(tick);
    const auto i = static_cast<std::size_t>(std::lround(motion_time * 1000.0));
    ASSERT_LT(i, frames_.size()) << "tick " << tick << ": sampling the old stream's clock";
    worst = std::max(worst, (rt.lastReference().q - frames_[i].q).tail(model_->nj()).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 2e-3);
  EXPECT_EQ(rt.referenceStream().counters().streams, 2u);
  EXPECT_EQ(rt.counters().frames_rejected, 2u);
  EXPECT_EQ(rt.counters().stale_ticks, 0u);
}

TEST_F(Realtime, AStrayOldFrameInsideALiveStreamIsRejected) {
  RealtimeFilter rt(*model_, FilterOptions{}, withoutSoftStart(), standingHold(*model_));
  int strays_accepted = 0;
  const double worst = runStream(
      rt, frames_, 1400, 100, [](int) { return kSenderClock; },
      [&](int tick, double now) {
        if (tick % 16 != 8 || tick < 100) return;  // between every two real frames
        ReferenceFrame old = frames_[static_cast<std::size_t>(tick - 80)];
        old.time_s += kSenderClock;
        strays_accepted += rt.addReference(old, now, tick / 16 - 5) ? 1 : 0;
      });
  EXPECT_EQ(strays_accepted, 0);
  EXPECT_LT(worst, 2e-3);
  EXPECT_EQ(rt.referenceStream().counters().streams, 1u);
  EXPECT_EQ(rt.referenceStream().lastRejection(), StreamVerdict::kNotAfterPrevious);
}

TEST_F(Realtime, RobotStatesFollowTheirOwnStream) {
  RealtimeOptions options;
  options.use_measured_state = true;
  RealtimeFilter rt(*model_, FilterOptions{}, options, standingHold(*model_));
  const ReferenceFrame& f = frames_[0];
  const double robot_clock = 77.0;
  for (int k = 0; k < 100; ++k) ASSERT_TRUE(rt.addMeasuredState(f.q, f.v, robot_clock + 0.001 * k, 0.001 * k));
  // A state stamped an hour ahead, and a stale copy of an old one: neither is used.
  EXPECT_FALSE(rt.addMeasuredState(f.q, f.v, robot_clock + test::kSecondsPerHour, 0.1));
  EXPECT_FALSE(rt.addMeasuredState(f.q, f.v, robot_clock + 0.05, 0.1));
  EXPECT_EQ(rt.stateStream().lastRejection(), StreamVerdict::kNotAfterPrevious);
  // The robot restarts with its clock at 0: followed from its third state.
  EXPECT_FALSE(rt.addMeasuredState(f.q, f.v, 0.000, 0.101));
  EXPECT_FALSE(rt.addMeasuredState(f.q, f.v, 0.001, 0.102));
  EXPECT_TRUE(rt.addMeasuredState(f.q, f.v, 0.002, 0.103));
  EXPECT_TRUE(rt.addMeasuredState(f.q, f.v, 0.003, 0.104));
  EXPECT_EQ(rt.stateStream().counters().streams, 2u);
  EXPECT_EQ(rt.stateStream().counters().rejected, 4u);
}

// A stream's first frame arrives; for the reference delay after it the sample waits at
// that frame, at rest, on the sender's clock, instead of sampling before it (where the
// balance layer's preview, which starts at that frame, had nothing to agree with).
TEST_F(Realtime, TheSampleNeverPrecedesTheStreamsFirstFrame) {
  RealtimeOptions options = withoutSoftStart();
  RealtimeFilter rt(*model_, FilterOptions{}, options, standingHold(*model_));
  const int nj = model_->nj();
  double previous_time = -1e300;
  for (int tick = 0; tick < 200; ++tick) {
    const double now = 0.001 * tick;
    if (tick % 16 == 0) {
      ReferenceFrame f = frames_[static_cast<std::size_t>(300 + tick)];  // mid-motion
      f.time_s = kSenderClock + now;
      ASSERT_TRUE(rt.addReference(f, now));
    }
    rt.tick(now);
    const ReferenceFrame& r = rt.lastReference();
    ASSERT_GE(r.time_s, kSenderClock) << "tick " << tick << ": before the first frame";
    ASSERT_GE(r.time_s, previous_time) << "tick " << tick;
    previous_time = r.time_s;
    if (tick < 50) {  // the reference delay: the first frame, at rest
      EXPECT_EQ(r.time_s, kSenderClock) << "tick " << tick;
      EXPECT_LT((r.q - frames_[300].q).tail(nj).cwiseAbs().maxCoeff(), 1e-12);
      EXPECT_EQ(r.v.cwiseAbs().maxCoeff(), 0.0);
    }
  }
  EXPECT_NEAR(previous_time, kSenderClock + 0.199 - 0.05, 1e-9) << "then it plays 50 ms behind";
}

// A sender silent for 200 ms every 0.5 s (descheduled on a loaded machine): the sampled
// time never passes the newest frame (it waits there, at rest) and never jumps — after a
// wait it catches up at most 1.5× real time. Before, it ran past the newest frame (its pose
// at rest) and jumped on by up to 150 ms of motion when the next frame came.
TEST_F(Realtime, AfterASendersSilenceTheSampleCatchesUpWithoutJumping) {
  RealtimeOptions options = withoutSoftStart();
  RealtimeFilter rt(*model_, FilterOptions{}, options, standingHold(*model_));
  double previous = -1.0, newest = -1.0, largest_advance = 0.0;
  int waiting_ticks = 0;
  for (int tick = 0; tick < 1400; ++tick) {
    const double now = 0.001 * tick;
    const bool silent = tick >= 200 && (tick - 200) % 500 < 200;
    if (tick % 16 == 0 && !silent) {
      ReferenceFrame f = frames_[static_cast<std::size_t>(tick)];
      f.time_s = kSenderClock + now;
      ASSERT_TRUE(rt.addReference(f, now));
      newest = f.time_s;
    }
    rt.tick(now);
    const ReferenceFrame& r = rt.lastReference();
    ASSERT_LE(r.time_s, newest + 1e-12) << "tick " << tick << ": past the newest frame";
    if (previous >= 0.0) largest_advance = std::max(largest_advance, r.time_s - previous);
    if (previous >= 0.0 && r.time_s == previous) {
      ++waiting_ticks;
      EXPECT_EQ(r.v.cwiseAbs().maxCoeff(), 0.0) << "waiting at rest, tick " << tick;
    }
    previous = r.time_s;
  }
  EXPECT_LE(largest_advance, 1.5e-3 + 1e-12) << "no jump";
  EXPECT_GT(waiting_ticks, 300) << "it waited in each silence";
  EXPECT_EQ(rt.counters().stale_ticks, 0u);
}

// A stream captured elsewhere (2 m away, turned 1 rad) starts under the robot: the
// horizontal placement takes its first base pose onto the filter's; later frames keep
// their motion relative to the first. Off, the frames are used as they come.
TEST_F(Realtime, AStreamCapturedElsewhereIsPlacedUnderTheRobot) {
  Eigen::Isometry3d X_CW = Eigen::Isometry3d::Identity();  // the capture's world from ours
  X_CW.linear() = Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  X_CW.translation() = Eigen::Vector3d(2.0, -1.0, 0.0);
  auto captured = [&](int i) {
    ReferenceFrame f = frames_[static_cast<std::size_t>(i)];
    f.q.head<3>() = X_CW * Eigen::Vector3d(f.q.head<3>());
    const Eigen::Quaterniond R(Eigen::Quaterniond(X_CW.linear()) *
                               Eigen::Quaterniond(f.q[3], f.q[4], f.q[5], f.q[6]));
    f.q.segment<4>(3) << R.w(), R.x(), R.y(), R.z();
    f.time_s = kSenderClock + 0.001 * i;
    return f;
  };
  for (const bool align : {true, false}) {
    RealtimeOptions options = withoutSoftStart();
    options.align_to_robot = align;
    RealtimeFilter rt(*model_, FilterOptions{}, options, standingHold(*model_));
    const Eigen::Vector2d robot_xy = rt.filter().q().head<2>();
    double worst_m = 0.0;
    for (int tick = 0; tick < 600; ++tick) {
      if (tick % 16 == 0) {
        ASSERT_TRUE(rt.addReference(captured(tick), 0.001 * tick));
      }
      rt.tick(0.001 * tick);
      if (tick < 60) continue;
      // The sample against the motion at its time, taken back to our world.
      const int i = static_cast<int>(std::lround((rt.lastReference().time_s - kSenderClock) * 1000.0));
      const Eigen::Vector3d expected =
          rt.streamPlacement() * (X_CW * Eigen::Vector3d(frames_[static_cast<std::size_t>(i)].q.head<3>()));
      worst_m = std::max(worst_m, (rt.lastReference().q.head<3>() - expected).norm());
    }
    EXPECT_LT(worst_m, 1e-3) << "the placement is one rigid motion for the whole stream";
    const Eigen::Isometry3d X = rt.streamPlacement() * X_CW;  // ours from ours: identity when placed
    if (align) {
      // The sway starts within a millimetre of the hold pose at the origin.
      EXPECT_LT((X.translation().head<2>() - robot_xy + frames_[0].q.head<2>() - robot_xy).norm(), 2e-3);
      EXPECT_LT(Eigen::AngleAxisd(X.linear()).angle(), 1e-3);
    } else {
      EXPECT_TRUE(rt.streamPlacement().isApprox(Eigen::Isometry3d::Identity()));
      EXPECT_GT(rt.lastReference().q.head<2>().norm(), 2.0);
    }
  }
}

// Soft start: a stream whose joints are 0.3 rad from the robot's posture, and moving,
// starts at the robot's posture and at rest, is q_robot + s(τ) (q_stream − q_robot) with
// velocity s v_stream + ṡ (q_stream − q_robot) on the way (closed form at the frames' times,
// joints), and is the stream itself after stream_blend_s; without it the sample steps by
// 0.3 rad.
TEST_F(Realtime, AStreamStartsAtTheRobotsPostureAtRestAndBlendsIntoTheStream) {
  const int nj = model_->nj();
  for (const double blend_s : {0.5, 0.0}) {
    SCOPED_TRACE("blend " + std::to_string(blend_s) + " s");
    RealtimeOptions options;
    options.stream_blend_s = blend_s;
    RealtimeFilter rt(*model_, FilterOptions{}, options, standingHold(*model_));
    Eigen::VectorXd previous = rt.filter().q();
    const Eigen::VectorXd q0 = rt.filter().q().tail(nj);
    double largest_step = 0.0, worst_after = 0.0, worst_q = 0.0, worst_v = 0.0;
    int closed_forms = 0;
    auto frame = [&](int tick) {
      ReferenceFrame f = frames_[static_cast<std::size_t>(tick)];
      f.q.tail(nj).array() += 0.3;
      f.time_s = kSenderClock + 0.001 * tick;
      return f;
    };
    for (int tick = 0; tick < 800; ++tick) {
      const double now = 0.001 * tick;
      if (tick % 16 == 0) {
        ASSERT_TRUE(rt.addReference(frame(tick), now));
      }
      rt.tick(now);
      const ReferenceFrame& r = rt.lastReference();
      if (tick == 0 && blend_s > 0.0) {
        EXPECT_LT((r.q.tail(nj) - q0).cwiseAbs().maxCoeff(), 1e-9) << "starts at the robot";
        EXPECT_LT(r.v.tail(nj).cwiseAbs().maxCoeff(), 1e-12) << "at rest";
      }
      largest_step = std::max(largest_step, (r.q - previous).tail(nj).cwiseAbs().maxCoeff());
      previous = r.q;
      const double t = r.time_s - kSenderClock;
      const int k = static_cast<int>(std::lround(t * 1000.0));
      if (blend_s > 0.0 && t < blend_s && k % 16 == 0 && std::abs(t - 0.001 * k) < 1e-9) {
        const ReferenceFrame f = frame(k);
        const double tau = t / blend_s;
        const double s = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau);
        const double sdot = 30.0 * tau * tau * (1.0 - tau) * (1.0 - tau) / blend_s;
        const Eigen::VectorXd d = f.q.tail(nj) - q0;
        worst_q = std::max(worst_q, (r.q.tail(nj) - (q0 + s * d)).cwiseAbs().maxCoeff());
        worst_v = std::max(worst_v, (r.v.tail(nj) - (s * f.v.tail(nj) + sdot * d)).cwiseAbs().maxCoeff());
        ++closed_forms;
      }
      // After the blend (and the sway's start-up transient, coarse at 60 Hz).
      if (t >= std::max(blend_s, 0.1) + 0.01) {
        Eigen::VectorXd q = frames_[static_cast<std::size_t>(k)].q;
        q.tail(nj).array() += 0.3;
        worst_after = std::max(worst_after, (r.q - q).tail(nj).cwiseAbs().maxCoeff());
      }
    }
    EXPECT_LT(worst_after, 2e-3) << "then the stream itself";
    if (blend_s > 0.0) {
      EXPECT_GE(closed_forms, 25);
      EXPECT_LT(worst_q, 1e-12);
      EXPECT_LT(worst_v, 1e-12);
      // |d| ≤ 0.3 rad and the sway's ≤ 0.1 rad, over 0.5 s with the quintic's peak slope
      // 1.875: 1.5e-3 rad a tick, plus the stream's own motion.
      EXPECT_LT(largest_step, 2.5e-3);
      EXPECT_LT(rt.streamOffset().tail(nj).maxCoeff(), -0.29);
    } else {
      EXPECT_GT(largest_step, 0.29);
    }
  }
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
