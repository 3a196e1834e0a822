// dynfilter-latency — listens to a running stack and measures the loop: for every torque
// command that answers a robot state, the delay from the state's utime to the command's
// utime (same host clock); the command rate; missed ticks from the filter's status.
#include <algorithm>
#include <cstdio>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>

#include "dynfilter/core/filter_output.hpp"
#include "dynfilter/filter_status_t.hpp"
#include "dynfilter/lcm/messages.hpp"
#include "dynfilter/torque_command_t.hpp"
#include "process_support.hpp"

namespace {
struct Listener {
  void onCommand(const lcm::ReceiveBuffer*, const std::string&, const dynfilter::torque_command_t* m) {
    std::lock_guard<std::mutex> lock(mutex);
    ++commands;
    if (m->robot_state_utime > 0 && m->robot_state_utime != last_state_utime) {
      latencies_us.push_back(static_cast<double>(m->utime - m->robot_state_utime));
      last_state_utime = m->robot_state_utime;
    }
  }
  void onStatus(const lcm::ReceiveBuffer*, const std::string&, const dynfilter::filter_status_t* m) {
    std::lock_guard<std::mutex> lock(mutex);
    if (first_status_ticks < 0) {
      first_status_ticks = m->ticks;
      first_missed = m->missed_ticks;
      first_states = m->states_received;
      first_states_rejected = m->states_rejected;
    }
    last_ticks = m->ticks;
    last_missed = m->missed_ticks;
    last_states = m->states_received;
    last_states_rejected = m->states_rejected;
    if (m->status & (dynfilter::kStatusNonFinite | dynfilter::kStatusReseeded)) ++failed_ticks;
  }
  std::mutex mutex;
  long commands = 0;
  std::int64_t last_state_utime = 0;
  std::vector<double> latencies_us;
  std::int64_t first_status_ticks = -1, first_missed = 0, last_ticks = 0, last_missed = 0;
  std::int64_t first_states = 0, last_states = 0, first_states_rejected = 0, last_states_rejected = 0;
  long failed_ticks = 0;  // non-finite solve or re-seed: the loop ran but the filter did not
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * static_cast<double>(v.size() - 1))];
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dynfilter-latency: measure a running dynfilter stack over LCM."};
  double seconds = 60.0;
  std::string url;
  app.add_option("--seconds", seconds, "measurement window");
  app.add_option("--lcm-url", url, "LCM URL (default: $LCM_DEFAULT_URL)");
  CLI11_PARSE(app, argc, argv);
  lcm::LCM lcm(url);
  if (!lcm.good()) return 2;
  Listener listener;
  lcm.subscribe(dynfilter::messages::kTorqueCommandChannel, &Listener::onCommand, &listener);
  lcm.subscribe(dynfilter::messages::kFilterStatusChannel, &Listener::onStatus, &listener);
  const double start = dynfilter::processes::nowSeconds();
  while (dynfilter::processes::nowSeconds() - start < seconds) lcm.handleTimeout(50);
  std::lock_guard<std::mutex> lock(listener.mutex);
  const double window = dynfilter::processes::nowSeconds() - start;
  std::printf("window %.1f s: %ld commands (%.1f Hz), %zu answered robot states\n", window,
              listener.commands, static_cast<double>(listener.commands) / window,
              listener.latencies_us.size());
  std::printf("state → command latency: p50 %.0f µs, p99 %.0f µs, max %.0f µs\n",
              percentile(listener.latencies_us, 0.5), percentile(listener.latencies_us, 0.99),
              percentile(listener.latencies_us, 1.0));
  std::printf("filter ticks %lld, missed ticks %lld, failed ticks (non-finite/re-seeded) %ld\n",
              static_cast<long long>(listener.last_ticks - listener.first_status_ticks),
              static_cast<long long>(listener.last_missed - listener.first_missed),
              listener.failed_ticks);
  // With the loop closed on the robot state, missed ticks are the states overwritten before
  // the filter ran: every state the filter received is answered, overwritten or rejected.
  std::printf("robot states received by the filter %lld (rejected %lld); overwritten %lld\n",
              static_cast<long long>(listener.last_states - listener.first_states),
              static_cast<long long>(listener.last_states_rejected - listener.first_states_rejected),
              static_cast<long long>(listener.last_missed - listener.first_missed));
  return 0;
}
