// The real processes over real LCM (UDP multicast on loopback): dynfilter, dynfilter-sim
// and dynfilter-replay run together; a separate subscriber decodes what arrives.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <future>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "dynfilter/filter_status_t.hpp"
#include "dynfilter/lcm/messages.hpp"
#include "dynfilter/reference_frame_t.hpp"
#include "dynfilter/robot_state_t.hpp"
#include "dynfilter/torque_command_t.hpp"
#include "child_process.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

// A child process with its own LCM URL; SIGTERM when the object goes.
using processes::Child;

std::string uniqueUrl() {
  // One multicast port per test process so that parallel ctest runs do not mix.
  return "udpm://239.255.76.67:" + std::to_string(7700 + getpid() % 200) + "?ttl=0";
}

// Subscribes to everything the stack publishes and keeps what the checks need.
struct Monitor {
  explicit Monitor(const ModelInfo& model) : info(model), lcm(uniqueUrl()) {
    lcm.subscribe(messages::kTorqueCommandChannel, &Monitor::onCommand, this);
    lcm.subscribe(messages::kFilterStatusChannel, &Monitor::onStatus, this);
    lcm.subscribe(messages::kRobotStateChannel, &Monitor::onState, this);
    thread = std::thread([this] {
      while (!stop) lcm.handleTimeout(20);
    });
  }
  ~Monitor() {
    stop = true;
    thread.join();
  }
  void onCommand(const lcm::ReceiveBuffer*, const std::string&, const torque_command_t* m) {
    std::lock_guard<std::mutex> lock(mutex);
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
    command_times.push_back(t);
    for (int k = 0; k < m->num_joints; ++k) {
      const double tau = m->tau[static_cast<std::size_t>(k)];
      const int j = info.findJoint(m->joint_names[static_cast<std::size_t>(k)]);
      if (!std::isfinite(tau) || j < 0 || std::abs(tau) > info.tau_max[j] * (1 + 1e-12)) ++bad_torques;
    }
    last_command = *m;
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&, const filter_status_t* m) {
    std::lock_guard<std::mutex> lock(mutex);
    last_status = *m;
    ++statuses;
    if (tracking_armed && !have_first_armed_status) {
      first_armed_status = *m;
      have_first_armed_status = true;
    }
    if (tracking_armed) slot_errors.push_back(static_cast<double>(m->utime) * 1e-3 -
                                              static_cast<double>(m->ticks + m->missed_ticks));
    if (m->status & kStatusNonFinite) ++non_finite;
    if (tracking_armed && (m->status & (kStatusQpFallback | kStatusReseeded))) ++degraded_statuses;
  }
  void onState(const lcm::ReceiveBuffer*, const std::string&, const robot_state_t* m) {
    std::lock_guard<std::mutex> lock(mutex);
    last_state = *m;
    ++states;
    // Tracking: the simulated robot's joints against the filter's latest filtered joints.
    if (!last_command.q.empty() && m->num_joints == last_command.num_joints && tracking_armed) {
      double worst = 0.0;
      for (int k = 0; k < m->num_joints; ++k)
        worst = std::max(worst, std::abs(m->q[static_cast<std::size_t>(k)] - last_command.q[static_cast<std::size_t>(k)]));
      max_tracking_error = std::max(max_tracking_error, worst);
    }
    // The robot's own base: height range and tilt (roll/pitch) while armed.
    if (tracking_armed) {
      min_base_z = std::min(min_base_z, m->base_position[2]);
      max_base_z = std::max(max_base_z, m->base_position[2]);
      const double tilt = 2.0 * std::asin(std::min(1.0, std::hypot(m->base_quaternion[1], m->base_quaternion[2])));
      max_tilt_rad = std::max(max_tilt_rad, tilt);
    }
  }
  // Clears the command times, arms the tracking checks and waits @p duration; returns the
  // window's length (s).
  double measureFor(std::chrono::seconds duration) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      command_times.clear();
      slot_errors.clear();
      have_first_armed_status = false;
      tracking_armed = true;
    }
    const auto start = std::chrono::steady_clock::now();
    std::this_thread::sleep_for(duration);
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  const ModelInfo& info;
  lcm::LCM lcm;
  std::thread thread;
  std::atomic<bool> stop{false};
  std::mutex mutex;
  std::vector<double> command_times;
  // Per status while armed: the tick's time in 1 ms periods minus the periods accounted
  // for (ticks + missed ticks). Constant up to the delay of each status behind its slot.
  std::vector<double> slot_errors;
  filter_status_t first_armed_status;  // the first status of the window
  bool have_first_armed_status = false;
  long bad_torques = 0, statuses = 0, states = 0, non_finite = 0;
  bool tracking_armed = false;
  double max_tracking_error = 0.0;
  double min_base_z = 1e9, max_base_z = -1e9, max_tilt_rad = 0.0;
  long degraded_statuses = 0;
  torque_command_t last_command;
  filter_status_t last_status;
  robot_state_t last_state;
};

std::string bin(const char* name) { return std::string(DYNFILTER_PROCESS_DIR) + "/" + name; }

// The robot hangs on a test stand (--harness: root welded, no ground): the filter plans
// the free-floating figure on the ground, the simulated drives track its filtered joints.
// (The robot standing on its own feet is the closed-loop test below.)
TEST(LcmProcesses, FilterSimAndReplayRunTogether) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const ModelInfo& info = model->info();
  const std::string url = uniqueUrl();
  Monitor monitor(info);
  Child sim({bin("dynfilter-sim"), "--harness"}, url);
  Child filter({bin("dynfilter")}, url);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // both loaded and ticking
  Child replay({bin("dynfilter-replay"), test::sourcePath("data/squat_reference.csv"), "--loop"}, url);
  std::this_thread::sleep_for(std::chrono::seconds(2));
  const double window = monitor.measureFor(std::chrono::seconds(10));
  filter_status_t status;
  long commands = 0;
  {
    std::lock_guard<std::mutex> lock(monitor.mutex);
    commands = static_cast<long>(monitor.command_times.size());
    status = monitor.last_status;
    EXPECT_EQ(monitor.bad_torques, 0) << "non-finite or out-of-limit torques";
    EXPECT_EQ(monitor.non_finite, 0);
    EXPECT_GT(monitor.states, 9000);
    RecordProperty("max_joint_tracking_error_rad", std::to_string(monitor.max_tracking_error));
    EXPECT_LT(monitor.max_tracking_error, 0.05) << "simulated robot vs filtered joints (rad)";
  }
  const double rate = static_cast<double>(commands) / window;
  RecordProperty("command_rate_hz", std::to_string(rate));  // the speed is benchmarked
  // Accounting, which load alone cannot break: every 1 ms period of the window is a tick or
  // a counted missed tick. A status is stamped at or after its period's slot, so the
  // smallest (time − periods accounted) over each half of the window is the clock's origin
  // (a tick that was not delayed); periods lost or ticks run too fast would move it.
  {
    std::lock_guard<std::mutex> lock(monitor.mutex);
    const std::vector<double>& e = monitor.slot_errors;
    ASSERT_GT(e.size(), 1000u) << "status messages arrive";
    const auto half = e.begin() + static_cast<std::ptrdiff_t>(e.size() / 2);
    const double first = *std::min_element(e.begin(), half);
    const double second = *std::min_element(half, e.end());
    EXPECT_NEAR(second, first, 2.0) << "periods neither lost nor invented";
    EXPECT_GE(static_cast<std::int64_t>(status.ticks), commands) << "one command per tick at most";
  }
  EXPECT_EQ(status.status & (kStatusNonFinite | kStatusReferenceInvalid | kStatusStaleReference), 0)
      << status.reason;
  EXPECT_GT(status.frames_accepted, 1000);
  EXPECT_EQ(status.frames_rejected, 0);
  EXPECT_EQ(status.frames_received,
            status.frames_accepted + status.frames_rejected + status.frames_dropped);
  EXPECT_EQ(replay.stop(), 0);
  EXPECT_EQ(filter.stop(), 0) << "SIGTERM stops the filter cleanly";
  EXPECT_EQ(sim.stop(), 0);
}

// The loop closed as on hardware: the robot (ODE's engine) stands on its own feet, its
// drives apply the filter's torques alone (no servo), and the QP-mode filter starts every
// tick from the robot's measured state. The robot must follow the squat (pelvis 0.877 to
// 0.929 m) without tipping, at the robot's 1 kHz.
class LcmClosedLoop : public testing::TestWithParam<std::string> {};

TEST_P(LcmClosedLoop, TheRobotStandsAndSquatsWithTheLoopClosed) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const ModelInfo& info = model->info();
  const std::string url = uniqueUrl();
  Monitor monitor(info);
  // The filter first: the robot's drives go limp without commands.
  Child filter({bin("dynfilter"), "--mode", "qp", "--use-measured-state"}, url);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  Child sim({bin("dynfilter-sim"), "--backend", GetParam(), "--servo-error-rad", "0"}, url);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  Child replay({bin("dynfilter-replay"), test::sourcePath("data/squat_reference.csv"), "--loop"}, url);
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const double window = monitor.measureFor(std::chrono::seconds(10));
  std::lock_guard<std::mutex> lock(monitor.mutex);
  RecordProperty("min_base_z_m", std::to_string(monitor.min_base_z));
  RecordProperty("max_base_z_m", std::to_string(monitor.max_base_z));
  RecordProperty("max_tilt_rad", std::to_string(monitor.max_tilt_rad));
  const double rate = static_cast<double>(monitor.command_times.size()) / window;
  RecordProperty("command_rate_hz", std::to_string(rate));  // the speed is benchmarked
  // Ticks follow the robot's states. Accounting, which load alone cannot break: every
  // state the filter received in the window was answered by a tick, counted as overwritten
  // before the filter ran (missed_ticks in this mode), or rejected; none vanished.
  ASSERT_TRUE(monitor.have_first_armed_status);
  const filter_status_t& a = monitor.first_armed_status;
  const filter_status_t& b = monitor.last_status;
  const std::int64_t states = b.states_received - a.states_received;
  EXPECT_GT(states, 1000) << "the robot's states arrive";
  EXPECT_LE(states, (b.ticks - a.ticks) + (b.missed_ticks - a.missed_ticks) +
                        (b.states_rejected - a.states_rejected) + 1)
      << "a state neither answered nor counted";
  EXPECT_EQ(b.states_rejected, 0) << b.reason;
  RecordProperty("state_streams", std::to_string(b.state_streams));
  EXPECT_EQ(monitor.bad_torques, 0);
  EXPECT_EQ(monitor.non_finite, 0);
  // Measured: pelvis 0.877–0.929 m, tilt ~1e-9 rad (the squat's own pelvis does not tilt).
  EXPECT_GT(monitor.min_base_z, 0.86) << "the robot fell or sank";
  EXPECT_LT(monitor.min_base_z, 0.89) << "the robot did not squat";
  EXPECT_GT(monitor.max_base_z, 0.92) << "the robot did not come back up";
  EXPECT_LT(monitor.max_tilt_rad, 0.05);
  EXPECT_EQ(monitor.degraded_statuses, 0) << monitor.last_status.reason;
  EXPECT_EQ(monitor.last_status.mode, "qp");
}

// The robot on ODE's engine and on DART's (with the settings dynfilter-sim chooses for it).
INSTANTIATE_TEST_SUITE_P(Engines, LcmClosedLoop, testing::Values("ode", "dart"),
                         [](const testing::TestParamInfo<std::string>& p) { return p.param; });

// Sends bad reference frames to a running filter and checks that each is rejected with
// its reason, counted, and that good commands keep coming.
TEST(LcmProcesses, BadReferenceFramesAreRejectedAndTheFilterKeepsPublishing) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const ModelInfo& info = model->info();
  const std::string url = uniqueUrl();
  Monitor monitor(info);
  Child filter({bin("dynfilter")}, url);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  lcm::LCM sender(url);
  ReferenceFrame good(info.nq, info.nv);
  good.q = info.neutralConfiguration();
  good.q[2] = 0.93;
  // The sender's clock: its own steady clock, 1000 s ahead of ours.
  const auto t0 = std::chrono::steady_clock::now();
  auto senderUtime = [&]() {
    return 1000000000 + std::chrono::duration_cast<std::chrono::microseconds>(
                            std::chrono::steady_clock::now() - t0).count();
  };
  std::int64_t utime = 0, sequence = 0;
  auto send = [&](const reference_frame_t& m) { sender.publish(messages::kReferenceChannel, &m); };
  auto goodFrame = [&]() {
    reference_frame_t m;
    messages::fillReferenceFrame(info, good, utime = senderUtime(), ++sequence, m);
    return m;
  };
  for (int k = 0; k < 20; ++k) {
    send(goodFrame());
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  struct Case {
    const char* what;
    std::function<void(reference_frame_t&)> spoil;
    const char* reason_part;
  };
  const std::vector<Case> cases{
      {"wrong joint count", [](reference_frame_t& m) { m.num_joints -= 1; m.joint_names.pop_back(); m.q.pop_back(); m.qd.pop_back(); m.qdd.pop_back(); }, "joint"},
      {"unknown joint name", [](reference_frame_t& m) { m.joint_names[3] = "tail"; }, "joint"},
      {"NaN", [](reference_frame_t& m) { m.q[5] = std::nan(""); }, "finite"},
      {"Inf", [](reference_frame_t& m) { m.base_position[0] = INFINITY; }, "finite"},
      {"non-unit quaternion", [](reference_frame_t& m) { m.base_quaternion[0] = 1.1; }, "quaternion"},
      {"stamped an hour ahead", [&](reference_frame_t& m) { m.utime += 3600000000LL; }, "off the stream's clock"},
      {"a stray old frame", [&](reference_frame_t& m) { m.utime -= 100000; }, "not after the previous"},
  };
  long rejected_before = 0;
  {
    std::lock_guard<std::mutex> lock(monitor.mutex);
    rejected_before = monitor.last_status.frames_rejected;
  }
  for (const Case& c : cases) {
    reference_frame_t m = goodFrame();
    c.spoil(m);
    send(m);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    std::lock_guard<std::mutex> lock(monitor.mutex);
    EXPECT_EQ(monitor.last_status.frames_rejected, ++rejected_before) << c.what;
    EXPECT_NE(monitor.last_status.reason.find(c.reason_part), std::string::npos)
        << c.what << ": " << monitor.last_status.reason;
    send(goodFrame());
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  {
    std::lock_guard<std::mutex> lock(monitor.mutex);
    EXPECT_EQ(monitor.bad_torques, 0);
    EXPECT_GT(monitor.command_times.size(), 2000u);
    EXPECT_EQ(monitor.non_finite, 0);
    // No frame for 0.3 s > the 0.25 s timeout: holding, and saying so.
    EXPECT_TRUE(monitor.last_status.status & kStatusStaleReference) << monitor.last_status.reason;
  }
  // A frame brings it back.
  send(goodFrame());
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::int64_t streams = 0;
  {
    std::lock_guard<std::mutex> lock(monitor.mutex);
    EXPECT_FALSE(monitor.last_status.status & kStatusStaleReference) << monitor.last_status.reason;
    streams = monitor.last_status.reference_streams;
    EXPECT_GE(streams, 2) << "after the silence, a new stream";
  }
  // The sender restarts: its clock and sequence numbers begin again at 0. Its third frame
  // is followed (a new stream), long before the stale timeout.
  const auto restart = std::chrono::steady_clock::now();
  sequence = 0;
  for (int k = 0; k < 3; ++k) {
    reference_frame_t m;
    messages::fillReferenceFrame(info, good,
                                 std::chrono::duration_cast<std::chrono::microseconds>(
                                     std::chrono::steady_clock::now() - restart).count(),
                                 ++sequence, m);
    send(m);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  {
    std::lock_guard<std::mutex> lock(monitor.mutex);
    EXPECT_EQ(monitor.last_status.reference_streams, streams + 1) << monitor.last_status.reason;
    EXPECT_FALSE(monitor.last_status.status & kStatusStaleReference) << monitor.last_status.reason;
    EXPECT_EQ(monitor.last_status.frames_received, monitor.last_status.frames_accepted +
                                                       monitor.last_status.frames_rejected +
                                                       monitor.last_status.frames_dropped);
  }
  EXPECT_EQ(filter.stop(), 0);
}

}  // namespace
}  // namespace dynfilter

#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/io/reference_cleanup.hpp"
#include "dynfilter/io/retarget.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"

namespace dynfilter {
namespace {

// dynfilter-replay streams a BVH capture retargeted on the fly: every frame that arrives
// is a valid reference for the model, and the stream starts where the retargeted and
// cleaned-up clip does.
TEST(LcmProcesses, ReplayStreamsABvhCapture) {
  auto model = loadModel("dart", test::humanFigurePath());
  const ModelInfo& info = model->info();
  const std::string bvh = test::sourcePath("data/mocap/cmu/131_01_start_walk_stop.bvh");
  const std::string mapping = test::sourcePath("data/mocap/cmu/mappings/131_01.yaml");
  const io::RetargetMapping retarget_mapping = io::readRetargetMapping(mapping);
  // The replay streams what dynfilter-bvh2ref writes: retargeted, then cleaned up. Cleaned up
  // here on the other core while the replay cleans it up too (seconds each); only the model's
  // info is read meanwhile.
  auto expected_cleanup = std::async(std::launch::async, [&] {
    return io::cleanupReference(io::retargetBvhFile(bvh, retarget_mapping, *model).motion, *model,
                                retarget_mapping.cleanup, proxqp::factory());
  });

  const std::string url = uniqueUrl();
  lcm::LCM lcm(url);
  messages::ReferenceFrameReader reader(info);
  messages::ReferenceInput input(info);
  std::atomic<long> valid{0}, invalid{0};
  std::mutex mutex;
  Eigen::VectorXd first_q;
  struct Handler {
    std::function<void(const lcm::ReceiveBuffer*)> f;
    void on(const lcm::ReceiveBuffer* rbuf, const std::string&) { f(rbuf); }
  } handler{[&](const lcm::ReceiveBuffer* rbuf) {
    if (reader.read(rbuf->data, rbuf->data_size, input).ok()) {
      std::lock_guard<std::mutex> lock(mutex);
      if (valid++ == 0) first_q = input.frame.q;
    } else {
      ++invalid;
    }
  }};
  lcm.subscribe(messages::kReferenceChannel, &Handler::on, &handler);
  std::atomic<bool> stop{false};
  std::thread receive([&] {
    while (!stop) lcm.handleTimeout(20);
  });
  Child replay({bin("dynfilter-replay"), bvh, "--mapping", mapping, "--duration-s", "1.5"}, url);
  // It retargets and cleans the clip up (seconds), then streams 1.5 s and exits by itself.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (replay.running() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the last frames in flight
  EXPECT_FALSE(replay.running()) << "dynfilter-replay did not finish its 1.5 s within a minute";
  EXPECT_EQ(replay.stop(), 0);
  stop = true;
  receive.join();
  EXPECT_EQ(invalid.load(), 0);
  EXPECT_GT(valid.load(), 120) << "about 120 Hz for a good part of 1.5 s";
  const auto expected = expected_cleanup.get();
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(first_q.size(), info.nq);
  // The replay plays in real time from its start: under load its first publish comes a
  // little into the clip. The first frame must be one of the clip's first 0.25 s.
  double nearest = 1e9;
  for (const ReferenceFrame& f : expected.motion.frames) {
    if (f.time_s - expected.motion.frames.front().time_s > 0.25) break;
    nearest = std::min(nearest, (first_q - f.q).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(nearest, 0.02) << "the stream starts at the clip's beginning (interpolated)";
}

}  // namespace
}  // namespace dynfilter
