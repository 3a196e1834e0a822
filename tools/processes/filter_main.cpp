// dynfilter — the real-time filter process.
//
// Subscribes to reference frames (and, with --use-measured-state, the robot's state),
// ticks the filter at a fixed rate against the latest reference, and publishes a torque
// command, the contact state and a status every tick. Receiving runs on its own thread;
// the control tick does not allocate and does not block on I/O. SIGINT/SIGTERM stop it.
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>

#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/qp_engines/qp_engines.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/io/config.hpp"
#include "dynfilter/lcm/messages.hpp"
#include "dynfilter/realtime/realtime_filter.hpp"
#include "model_cli.hpp"
#include "histogram.hpp"
#include "process_support.hpp"

namespace {

using namespace dynfilter;
namespace msg = dynfilter::messages;

// What the receive thread hands to the control thread: validated frames in a small ring
// (the oldest is dropped when full) and the latest robot state. Preallocated.
class Inbox {
 public:
  Inbox(const ModelInfo& info, int capacity) : ring_(static_cast<std::size_t>(capacity), msg::ReferenceInput(info)), state_(info) {}

  void pushReference(const msg::ReferenceInput& in) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++received_;
    if (size_ == static_cast<int>(ring_.size())) {
      head_ = (head_ + 1) % static_cast<int>(ring_.size());
      --size_;
      ++dropped_;
    }
    ring_[static_cast<std::size_t>((head_ + size_) % static_cast<int>(ring_.size()))] = in;
    ++size_;
  }
  void reject(const char* reason) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++received_;
    ++rejected_;
    last_reject_ = reason;
  }
  void rejectState(const char* reason) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++states_received_;
    ++states_rejected_;
    last_state_reject_ = reason;
  }
  void pushState(const msg::RobotStateInput& in) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++states_received_;
      if (state_fresh_) ++states_overwritten_;  // the control thread never saw the last one
      state_ = in;
      state_fresh_ = true;
    }
    state_arrived_.notify_one();
  }
  // Control thread, state-triggered mode: waits until a state arrives unseen (true) or
  // the timeout passes (false).
  bool waitForState(double timeout_s) {
    std::unique_lock<std::mutex> lock(mutex_);
    return state_arrived_.wait_for(lock, std::chrono::duration<double>(timeout_s),
                                   [this] { return state_fresh_; });
  }
  long statesOverwritten() {
    std::lock_guard<std::mutex> lock(mutex_);
    return states_overwritten_;
  }

  // Control thread: hands every pending frame and a fresh state to the filter.
  template <typename OnFrame, typename OnState>
  void drain(OnFrame&& on_frame, OnState&& on_state) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (; size_ > 0; --size_, head_ = (head_ + 1) % static_cast<int>(ring_.size()))
      on_frame(ring_[static_cast<std::size_t>(head_)]);
    if (state_fresh_) on_state(state_);
    state_fresh_ = false;
    // The counts as of this drain: every frame received by now has been handed over
    // (accepted or rejected by the filter), rejected here or dropped, so that received =
    // accepted + rejected + dropped holds in the status. Counting later would include
    // frames still waiting in the ring.
    drained_received_ = received_;
    drained_rejected_ = rejected_;
    drained_dropped_ = dropped_;
    drained_last_reject_ = last_reject_;
    drained_states_received_ = states_received_;
    drained_states_rejected_ = states_rejected_;
    drained_last_state_reject_ = last_state_reject_;
  }
  /// The counts as of the last drain(): reference frames, then robot states.
  void counts(long& received, long& rejected, long& dropped, const char*& last_reject) {
    std::lock_guard<std::mutex> lock(mutex_);
    received = drained_received_;
    rejected = drained_rejected_;
    dropped = drained_dropped_;
    last_reject = drained_last_reject_;
  }
  void stateCounts(long& received, long& rejected, const char*& last_reject) {
    std::lock_guard<std::mutex> lock(mutex_);
    received = drained_states_received_;
    rejected = drained_states_rejected_;
    last_reject = drained_last_state_reject_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable state_arrived_;
  long states_overwritten_ = 0;
  std::vector<msg::ReferenceInput> ring_;
  int head_ = 0, size_ = 0;
  msg::RobotStateInput state_;
  bool state_fresh_ = false;
  long received_ = 0, rejected_ = 0, dropped_ = 0;
  const char* last_reject_ = nullptr;
  long drained_received_ = 0, drained_rejected_ = 0, drained_dropped_ = 0;
  const char* drained_last_reject_ = nullptr;
  long states_received_ = 0, states_rejected_ = 0;
  const char* last_state_reject_ = nullptr;
  long drained_states_received_ = 0, drained_states_rejected_ = 0;
  const char* drained_last_state_reject_ = nullptr;
};

// Receive-thread handlers: decode into reused objects, validate, hand over.
struct Receiver {
  Receiver(const ModelInfo& info, Inbox& target)
      : references(info), states(info), reference_in(info), state_in(info), inbox(target) {}
  void onReference(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    const msg::MessageCheck check = references.read(rbuf->data, rbuf->data_size, reference_in);
    if (check.ok()) {
      inbox.pushReference(reference_in);
    } else {
      inbox.reject(check.reason);
      std::fprintf(stderr, "dynfilter: reference frame rejected: %s\n", check.reason);
    }
  }
  void onState(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    const msg::MessageCheck check = states.read(rbuf->data, rbuf->data_size, state_in);
    if (check.ok()) {
      receive_us.add(static_cast<double>(processes::nowMicros() - state_in.utime));
      inbox.pushState(state_in);
    } else {
      inbox.rejectState(check.reason);
      std::fprintf(stderr, "dynfilter: robot state rejected: %s\n", check.reason);
    }
  }
  msg::ReferenceFrameReader references;
  msg::RobotStateReader states;
  msg::ReferenceInput reference_in;
  msg::RobotStateInput state_in;
  Inbox& inbox;
  tools::Histogram receive_us{5.0, 4000};  // a state's utime -> its handling here (µs)
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dynfilter: the real-time dynamics filter over LCM."};
  std::string model_path = DYNFILTER_DEFAULT_MODEL, backend = "dart", config_path, url;
  std::string reference_channel = msg::kReferenceChannel, state_channel = msg::kRobotStateChannel;
  std::string command_channel = msg::kTorqueCommandChannel,
              contact_channel = msg::kContactStateChannel, status_channel = msg::kFilterStatusChannel;
  double rate_hz = 1000.0, duration_s = 0.0;
  realtime::RealtimeOptions rt_options;
  app.add_option("-m,--model", model_path, "URDF model (default: the human figure)");
  dynfilter::tools::ModelCli model_cli;
  dynfilter::tools::addModelOptions(app, model_cli);
  app.add_option("--backend", backend, "dart or ode")->check(CLI::IsMember(availableBackends()));
  app.add_option("-c,--config", config_path, "YAML configuration");
  std::string mode;
  app.add_option("--mode", mode, "solver: paper (Eq. 21-23) or qp (contact-consistent QP); "
                 "overrides the config's mode")
      ->check(CLI::IsMember({"paper", "qp"}));
  app.add_option("--rate-hz", rate_hz, "control rate")->check(CLI::Range(1.0, 10000.0));
  app.add_option("--duration-s", duration_s, "stop after this long (0: until SIGINT/SIGTERM)");
  app.add_flag("--use-measured-state", rt_options.use_measured_state,
               "start each tick from the robot's measured state; the robot's state messages "
               "then trigger the ticks (the rate becomes the robot's), falling back to "
               "--rate-hz when they stop");
  app.add_flag("--balance-preview,!--no-balance-preview", rt_options.balance_preview,
               "feed the reference delay's frames to the balance layer as its look-ahead "
               "(default: on)");
  app.add_flag("--align-reference,!--no-align-reference", rt_options.align_to_robot,
               "place each reference stream under the robot: x, y and yaw of its first frame "
               "onto the robot's base (default: on; off: frames are in the robot's world)");
  app.add_option("--stream-blend-s", rt_options.stream_blend_s,
                 "soft start: the reference goes from the robot's posture, at rest, into a new "
                 "stream over this time (0: none)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--stale-timeout-s", rt_options.stale_timeout_s, "hold posture after this silence");
  app.add_option("--reference-delay-s", rt_options.reference_delay_s,
                 "play the reference this far behind its newest frame");
  app.add_option("--clock-tolerance-s", rt_options.clock_tolerance_s,
                 "a frame or state whose clock offset (receive time - utime) moves this far "
                 "from its stream's is off the stream (README, \"Streams\")");
  app.add_option("--new-stream-messages", rt_options.new_stream_messages,
                 "messages in a row off the followed stream but consistent among themselves "
                 "that make a new stream (a restarted sender, a jumped clock)")
      ->check(CLI::Range(1, 1000));
  app.add_option("--max-clock-offset-s", rt_options.max_clock_offset_s,
                 "senders stamp on this host's clock: reject stamps further than this from "
                 "the receive time (0: off, clocks may differ)");
  bool fixed_base = false;
  app.add_flag("--fixed-base", fixed_base,
               "plan the robot with its root welded and no ground (a robot on a test stand)");
  processes::RealtimeProcessOptions process_options;
  processes::addRealtimeProcessOptions(app, process_options);
  app.add_option("--lcm-url", url, "LCM URL (default: $LCM_DEFAULT_URL)");
  app.add_option("--reference-channel", reference_channel);
  app.add_option("--state-channel", state_channel);
  app.add_option("--command-channel", command_channel);
  app.add_option("--contact-channel", contact_channel);
  app.add_option("--status-channel", status_channel);
  CLI11_PARSE(app, argc, argv);

  try {
    // Before any thread (LCM's too) starts.
    const processes::CpuWakeLatencyHold wake_latency = processes::applyRealtimeProcessOptions(process_options);
    io::FilterConfig config = config_path.empty() ? io::FilterConfig{} : io::loadFilterConfig(config_path);
    config.filter.dt_s = 1.0 / rate_hz;
    if (!mode.empty()) parseFilterMode(mode, config.filter.mode);
    ModelOptions model_options;
    model_options.environment = config.environment;
    if (fixed_base) {
      model_options.floating_base = false;
      model_options.environment.has_ground = false;
    }
    auto model = makeModel(backend, dynfilter::tools::loadRobot(model_path, model_cli), model_options);
    const ModelInfo& info = model->info();

    ReferenceFrame hold(info.nq, info.nv);
    hold.q = info.neutralConfiguration();
    if (info.floating_base) hold.q[2] = standingBaseHeight(*model, hold.q);
    realtime::RealtimeFilter rt(*model, config.filter, rt_options, hold, qp_engines::factory(config.filter.qp.solver.engine));
    if (config.filter.task.enabled && config.filter.task.body.empty())
      std::fprintf(stderr, "dynfilter: task point on \"%s\" (task.body not configured: the model's trunk)\n",
                   info.body_names[static_cast<std::size_t>(rt.filter().taskBody())].c_str());

    lcm::LCM lcm(url);
    if (!lcm.good()) throw std::runtime_error("cannot open LCM (" + (url.empty() ? std::string("default URL") : url) + ")");
    Inbox inbox(info, 16);
    Receiver receiver(info, inbox);
    lcm.subscribe(reference_channel, &Receiver::onReference, &receiver);
    if (rt_options.use_measured_state) lcm.subscribe(state_channel, &Receiver::onState, &receiver);

    processes::installStopHandlers();
    // Receiving outranks the control loop: messages must not wait behind it.
    std::thread receive_thread([&lcm] {
      processes::tryRealtimeScheduling(51);
      while (!processes::g_stop) lcm.handleTimeout(20);
    });
    std::fprintf(stderr, "dynfilter: %s (%s, %d joints) at %.0f Hz; %s; %s\n", info.name.c_str(),
                 backend.c_str(), info.nj, rate_hz, processes::tryRealtimeScheduling(), wake_latency.note());

    torque_command_t command;
    contact_state_t contacts;
    filter_status_t status;
    std::vector<std::uint8_t> buffer;
    msg::CommandStamps stamps;
    msg::StatusReport report;
    report.mode = toString(config.filter.mode);
    long missed = 0, received = 0, rejected = 0, dropped = 0, states_received = 0,
         states_rejected = 0;
    const char* last_reject = nullptr;
    const char* last_state_reject = nullptr;
    // The reason of the latest rejection, whoever rejected it (reader or stream policy).
    const char* detail = nullptr;
    long seen_rejected = 0, seen_states_rejected = 0;
    std::int64_t state_utime = 0, answered_state_utime = 0;
    processes::Ticker ticker(rate_hz);
    // Where a state's answer spends its time (µs): until the tick starts, in the tick, all.
    tools::Histogram wake_us(5.0, 4000), tick_us(5.0, 4000), answer_us(5.0, 4000);
    const double start = processes::nowSeconds();
    const bool state_triggered = rt_options.use_measured_state;
    while (!processes::g_stop && (duration_s <= 0.0 || processes::nowSeconds() - start < duration_s)) {
      // Ticks follow the robot's state messages when the loop is closed on them (lowest
      // latency: the command answers each state at once); otherwise the own clock.
      if (state_triggered) {
        if (!inbox.waitForState(2.0 * ticker.period())) ticker.wait();
        missed = inbox.statesOverwritten();
      } else {
        missed += ticker.wait();
      }
      const double now = processes::nowSeconds();
      inbox.drain(
          [&](const msg::ReferenceInput& in) {
            if (rt.addReference(in.frame, now, in.sequence)) {
              stamps.reference_utime = in.utime;
              stamps.reference_sequence = in.sequence;
            } else {
              detail = realtime::describe(rt.referenceStream().lastRejection());
            }
          },
          [&](const msg::RobotStateInput& s) {
            if (rt.addMeasuredState(s.q, s.v, static_cast<double>(s.utime) * 1e-6, now))
              state_utime = s.utime;
            else
              detail = realtime::describe(rt.stateStream().lastRejection());
          });
      const std::int64_t tick_start_us = processes::nowMicros();
      const FilterOutput& out = rt.tick(now);
      stamps.utime = processes::nowMicros();
      tick_us.add(static_cast<double>(stamps.utime - tick_start_us));
      if (state_triggered && state_utime > 0 && state_utime != answered_state_utime) {
        wake_us.add(static_cast<double>(tick_start_us - state_utime));
        answer_us.add(static_cast<double>(stamps.utime - state_utime));
        answered_state_utime = state_utime;
      }
      stamps.robot_state_utime = rt_options.use_measured_state ? state_utime : 0;
      msg::fillTorqueCommand(info, out, stamps, rt.status(), &rt.command(), command);
      lcm.publish(command_channel, buffer.data(), msg::encodeMessage(command, buffer));
      msg::fillContactState(info, out, stamps.utime, contacts);
      lcm.publish(contact_channel, buffer.data(), msg::encodeMessage(contacts, buffer));
      inbox.counts(received, rejected, dropped, last_reject);
      inbox.stateCounts(states_received, states_rejected, last_state_reject);
      if (rejected != seen_rejected) detail = last_reject;
      if (states_rejected != seen_states_rejected) detail = last_state_reject;
      seen_rejected = rejected;
      seen_states_rejected = states_rejected;
      const auto& c = rt.counters();
      report.utime = stamps.utime;
      report.extra_status = rt.status();
      report.detail = detail;
      report.latency_us = stamps.robot_state_utime ? static_cast<double>(stamps.utime - state_utime) : 0.0;
      report.frames_received = received;
      report.frames_accepted = static_cast<std::int64_t>(c.frames_accepted);
      report.frames_rejected = rejected + static_cast<std::int64_t>(c.frames_rejected);
      report.frames_dropped = dropped;
      report.ticks = static_cast<std::int64_t>(c.ticks);
      report.missed_ticks = missed;
      report.reseeds = static_cast<std::int64_t>(c.reseeds);
      report.reference_streams = static_cast<std::int64_t>(rt.referenceStream().counters().streams);
      report.states_received = states_received;
      report.states_rejected =
          states_rejected + static_cast<std::int64_t>(rt.stateStream().counters().rejected);
      report.state_streams = static_cast<std::int64_t>(rt.stateStream().counters().streams);
      msg::fillFilterStatus(out, report, status);
      lcm.publish(status_channel, buffer.data(), msg::encodeMessage(status, buffer));
    }
    processes::g_stop = true;
    receive_thread.join();
    std::fprintf(stderr,
                 "dynfilter: stopped after %llu ticks, %ld missed; frames received %ld, accepted "
                 "%llu, rejected %lld, dropped %ld; reference streams %lld, state streams %lld\n",
                 static_cast<unsigned long long>(rt.counters().ticks), missed, received,
                 static_cast<unsigned long long>(rt.counters().frames_accepted),
                 static_cast<long long>(report.frames_rejected), dropped,
                 static_cast<long long>(report.reference_streams),
                 static_cast<long long>(report.state_streams));
    std::fprintf(stderr, "dynfilter: tick p50 %.0f, p99 %.0f, p99.9 %.0f, max %.0f us\n",
                 tick_us.percentile(0.5), tick_us.percentile(0.99), tick_us.percentile(0.999), tick_us.max());
    if (answer_us.count() > 0)
      std::fprintf(stderr,
                   "dynfilter: robot state (its utime) -> received p50 %.0f, p99 %.0f, max %.0f us; -> "
                   "tick start p50 %.0f, p99 %.0f, max %.0f us; -> command p50 %.0f, p99 %.0f, max "
                   "%.0f us (%ld states answered)\n",
                   receiver.receive_us.percentile(0.5), receiver.receive_us.percentile(0.99),
                   receiver.receive_us.max(), wake_us.percentile(0.5), wake_us.percentile(0.99),
                   wake_us.max(), answer_us.percentile(0.5), answer_us.percentile(0.99), answer_us.max(),
                   answer_us.count());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynfilter: error: %s\n", e.what());
    return 2;
  }
}
