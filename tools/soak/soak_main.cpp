// dynfilter-soak — runs the whole LCM loop for a long time and checks that it stays healthy.
//
// Starts dynfilter-sim (robot on the harness), dynfilter and dynfilter-replay (looping its
// clips and switching between them every --switch-every-s) on a private UDP multicast URL,
// listens to every torque command and status the filter publishes, samples VmRSS / VmHWM
// of the three processes once a second, and checks (README "Real-time stack", "Soak test"
// in BENCHMARKS.md):
//   memory    for each process, after the warm-up: RSS(end) − RSS(warm-up) ≤ budget,
//             VmHWM(end) − VmHWM(warm-up) ≤ budget, and the least-squares line through the
//             RSS samples rises by ≤ budget over the window (no steady growth trend);
//   ticks     missed_ticks / ticks over the window ≤ --missed-budget;
//   torques   every torque_command_t decodes, names the model's joints once each, and
//             every τ is finite with |τ| ≤ the URDF effort limit;
//   counters  on every status: frames_received = accepted + rejected + dropped;
//   frames    no reference frame rejected (replay sends only valid frames);
//   listener  ≥ --min-decoded of the commands published in the window were decoded here;
//   processes all three ran to the end and exited 0 on SIGTERM.
// Prints a markdown report, writes it and a JSON one to --out-dir; exit 0 on pass, 1 on a
// failed check, 2 on a usage or start-up error.
#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>

#include "model_cli.hpp"
#include "child_process.hpp"
#include "histogram.hpp"
#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/core/filter_output.hpp"
#include "dynfilter/filter_status_t.hpp"
#include "dynfilter/lcm/messages.hpp"
#include "dynfilter/torque_command_t.hpp"
#include "process_support.hpp"

namespace {

using namespace dynfilter;
namespace msg = dynfilter::messages;
using processes::nowMicros;
using processes::nowSeconds;

// ---------------------------------------------------------------------------------------
// Memory of a process from /proc/<pid>/status (kB); false when it is gone.
struct MemoryKb {
  long rss = -1, hwm = -1;
};
bool readMemory(pid_t pid, MemoryKb& out) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  if (!in) return false;
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) out.rss = std::stol(line.substr(6));
    else if (line.rfind("VmHWM:", 0) == 0) out.hwm = std::stol(line.substr(6));
  }
  return out.rss >= 0 && out.hwm >= 0;
}

struct MemorySample {
  double t_s;  // since the start of the soak
  MemoryKb kb;
};

// A burst of missed ticks seen in the status stream.
struct MissEvent {
  double t_s;             // filter's utime, converted to the soak's clock (s since start)
  long missed;            // ticks missed at once
  double prev_tick_us;    // the tick before the late one took this long
};

// ---------------------------------------------------------------------------------------
// Decodes every torque command and status (reused messages; lcm-cpp's typed handlers
// would allocate a message per call).
struct Listener {
  Listener(const ModelInfo& model, double start_s)
      : info(model), names(model), start(start_s), tick_us(10.0, 5000), solve_us(5.0, 4000) {}

  void onCommand(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    std::lock_guard<std::mutex> lock(mutex);
    ++commands;
    last_command_s = nowSeconds();
    if (command.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) {
      ++malformed_commands;
      return;
    }
    if (replay_start_us == 0 && command.reference_sequence > 0)
      replay_start_us = command.reference_utime;  // its first frames: the replay's clock start
    const msg::MessageCheck check = names.map(command.joint_names, command.num_joints);
    const auto n = static_cast<std::size_t>(command.num_joints);
    if (!check.ok() || command.tau.size() != n) {
      ++bad_joint_sets;
      if (first_bad_torque.empty()) first_bad_torque = std::string("joint names: ") + check.reason;
      return;
    }
    bool non_finite = false, over = false;
    for (std::size_t i = 0; i < n; ++i) {
      const double tau = command.tau[i];
      const int j = names.indices()[i];
      if (j < 0) continue;  // a joint the model locks
      const double limit = info.tau_max[j];
      if (!std::isfinite(tau)) {
        non_finite = true;
        continue;
      }
      if (std::abs(tau) > limit * (1.0 + 1e-12)) {
        over = true;
        if (first_bad_torque.empty())
          first_bad_torque = command.joint_names[i] + ": |tau| " + std::to_string(std::abs(tau)) +
                             " > " + std::to_string(limit);
      }
      if (std::isfinite(limit) && limit > 0.0) max_limit_ratio = std::max(max_limit_ratio, std::abs(tau) / limit);
    }
    if (non_finite && first_bad_torque.empty()) first_bad_torque = "non-finite tau";
    non_finite_commands += non_finite;
    over_limit_commands += over;
    clamped_commands += (command.status & kStatusTorqueClamped) != 0;
  }

  void onStatus(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    std::lock_guard<std::mutex> lock(mutex);
    if (status.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) {
      ++malformed_statuses;
      return;
    }
    ++statuses;
    const filter_status_t& s = status;
    const std::int64_t sum = s.frames_accepted + s.frames_rejected + s.frames_dropped;
    if (s.frames_received != sum) {
      ++counter_violations;
      max_counter_gap = std::max<std::int64_t>(max_counter_gap, std::llabs(s.frames_received - sum));
      if (first_counter_violation.empty())
        first_counter_violation = "received " + std::to_string(s.frames_received) + " != accepted " +
                                  std::to_string(s.frames_accepted) + " + rejected " +
                                  std::to_string(s.frames_rejected) + " + dropped " +
                                  std::to_string(s.frames_dropped) + " (tick " + std::to_string(s.ticks) + ")";
    }
    if (have_status) {
      if (s.ticks <= last.ticks || s.missed_ticks < last.missed_ticks) ++counter_regressions;
      else statuses_lost += s.ticks - last.ticks - 1;
      if (s.missed_ticks > last.missed_ticks)
        misses.push_back({static_cast<double>(s.utime) * 1e-6 - start, static_cast<long>(s.missed_ticks - last.missed_ticks),
                          last.tick_us});
    } else {
      first = s;
      have_status = true;
    }
    for (int b = 0; b < 16; ++b)
      if (s.status & (1 << b)) {
        ++bits[static_cast<std::size_t>(b)];
        if (in_window) ++window_bits[static_cast<std::size_t>(b)];
      }
    if (s.status != 0 && reasons.size() < 32) ++reasons[s.reason];
    else if (s.status != 0 && reasons.count(s.reason)) ++reasons[s.reason];
    tick_us.add(s.tick_us);
    solve_us.add(s.solve_us);
    mode = s.mode;
    last.ticks = s.ticks;
    last.missed_ticks = s.missed_ticks;
    last.tick_us = s.tick_us;
    last.frames_received = s.frames_received;
    last.frames_accepted = s.frames_accepted;
    last.frames_rejected = s.frames_rejected;
    last.frames_dropped = s.frames_dropped;
    last.reseeds = s.reseeds;
    last.qp_solves = s.qp_solves;
    last.qp_fallbacks = s.qp_fallbacks;
    if (s.frames_rejected > 0 && first_reject_reason.empty() && (s.status & kStatusReferenceInvalid))
      first_reject_reason = s.reason;
  }

  // The running totals the report needs (copied under the lock).
  struct Counters {
    std::int64_t ticks = 0, missed_ticks = 0, frames_received = 0, frames_accepted = 0,
                 frames_rejected = 0, frames_dropped = 0, reseeds = 0, qp_solves = 0, qp_fallbacks = 0;
    double tick_us = 0.0;
  };
  const ModelInfo& info;
  msg::JointNameMap names;
  double start;
  std::mutex mutex;
  torque_command_t command;
  filter_status_t status;
  long commands = 0, malformed_commands = 0, bad_joint_sets = 0, non_finite_commands = 0,
       over_limit_commands = 0, clamped_commands = 0;
  double max_limit_ratio = 0.0, last_command_s = 0.0;
  std::string first_bad_torque;
  std::int64_t replay_start_us = 0;
  long statuses = 0, malformed_statuses = 0, counter_violations = 0, counter_regressions = 0;
  std::int64_t statuses_lost = 0, max_counter_gap = 0;
  std::string first_counter_violation, first_reject_reason, mode;
  bool have_status = false;
  filter_status_t first;
  Counters last;
  std::array<long, 16> bits{}, window_bits{};
  bool in_window = false;  // set by the main thread while the measured window runs
  std::map<std::string, long> reasons;
  tools::Histogram tick_us, solve_us;
  std::vector<MissEvent> misses;
};

// ---------------------------------------------------------------------------------------
struct ProcessRecord {
  std::string name;
  std::vector<std::string> args;
  std::string log;
  std::vector<MemorySample> samples;
  MemoryKb start, warm, end, peak;
  double growth_fit_kb = 0.0, slope_kb_per_min = 0.0;
  bool alive_to_end = true;
  double died_at_s = -1.0;
  int exit_code = -1, signal = 0;
};

// Least-squares line through the RSS samples at or after t0: its slope (kB/s).
double rssSlope(const std::vector<MemorySample>& samples, double t0) {
  double n = 0, st = 0, sr = 0, stt = 0, str = 0;
  for (const auto& s : samples) {
    if (s.t_s < t0) continue;
    const double r = static_cast<double>(s.kb.rss);
    n += 1;
    st += s.t_s;
    sr += r;
    stt += s.t_s * s.t_s;
    str += s.t_s * r;
  }
  const double den = n * stt - st * st;
  return (n < 3 || den <= 0.0) ? 0.0 : (n * str - st * sr) / den;
}

std::string jsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
      continue;
    }
    out += c;
  }
  return out + "\"";
}

std::string joined(const std::vector<std::string>& args) {
  std::string out;
  for (const auto& a : args) out += (out.empty() ? "" : " ") + a;
  return out;
}


struct Check {
  std::string name, criterion, measured;
  bool pass;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dynfilter-soak: run dynfilter + dynfilter-sim + dynfilter-replay for a long time "
               "and check memory, missed ticks, torques and counters."};
  double duration_s = 30.0, warmup_s = 5.0, switch_every_s = 5.0, rss_budget_mb = 1.0,
         missed_budget = 0.005, min_decoded = 0.99, settle_s = 1.5;
  std::string mode = "paper", process_dir = DYNFILTER_PROCESS_DIR, out_dir = "soak-out", url,
              model_path = DYNFILTER_DEFAULT_MODEL, sim_backend = "dart";
  std::vector<std::string> clips{std::string(DYNFILTER_SOURCE_DIR) + "/data/squat_reference.csv",
                                 std::string(DYNFILTER_SOURCE_DIR) + "/data/mocap/cmu/131_01_start_walk_stop.bvh"};
  std::vector<std::string> mappings{std::string(DYNFILTER_SOURCE_DIR) + "/data/mocap/cmu/mappings/131_01.yaml"};
  std::vector<std::string> filter_args, sim_args;
  app.add_option("--duration-s", duration_s, "measured window after the warm-up (s); CI 30, on demand 3600")
      ->check(CLI::PositiveNumber);
  app.add_option("--warmup-s", warmup_s, "warm-up after the replay starts, not measured (s)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--mode", mode, "the filter's solver mode")->check(CLI::IsMember({"paper", "qp"}));
  app.add_option("--clip", clips, "replay clips (CSV or BVH), switched in turn; default: the squat "
                 "CSV and the CMU 131_01 walk BVH")->take_all();
  app.add_option("--mapping", mappings, "retargeting mapping, one per .bvh clip in order")->take_all();
  app.add_option("--switch-every-s", switch_every_s, "switch to the next clip this often (s)")
      ->check(CLI::PositiveNumber);
  app.add_option("--rss-budget-mb", rss_budget_mb, "allowed memory growth per process over the window (MB)");
  app.add_option("--missed-budget", missed_budget, "allowed missed ticks / ticks over the window");
  app.add_option("--min-decoded", min_decoded, "fraction of the window's commands the listener must decode");
  app.add_option("--sim-backend", sim_backend, "dynfilter-sim's physics: dart or ode");
  app.add_option("--filter-arg", filter_args, "extra argument for dynfilter (repeatable)")->allow_extra_args(false);
  app.add_option("--sim-arg", sim_args, "extra argument for dynfilter-sim (repeatable)")->allow_extra_args(false);
  app.add_option("--process-dir", process_dir, "where dynfilter, dynfilter-sim, dynfilter-replay are");
  app.add_option("-m,--model", model_path, "URDF model (effort limits)");
  dynfilter::tools::ModelCli model_cli;
  dynfilter::tools::addModelOptions(app, model_cli);
  app.add_option("--out-dir", out_dir, "report.md, report.json and the processes' logs go here");
  app.add_option("--lcm-url", url, "LCM URL (default: a private udpm port per soak process)");
  CLI11_PARSE(app, argc, argv);
  if (app.count("--clip") > 0 && app.count("--mapping") == 0) mappings.clear();

  if (url.empty()) url = "udpm://239.255.76.67:" + std::to_string(7500 + getpid() % 200) + "?ttl=0";
  mkdir(out_dir.c_str(), 0755);
  const double budget_kb = rss_budget_mb * 1024.0;

  std::unique_ptr<IDynamicsModel> model;
  try {
    model = makeModel("dart", dynfilter::tools::loadRobot(model_path, model_cli), ModelOptions{});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynfilter-soak: %s\n", e.what());
    return 2;
  }
  const ModelInfo& info = model->info();

  // The replay's schedule: clip k % n at k · switch_every_s, past the end of the run.
  const double total_s = settle_s + warmup_s + duration_s;
  std::vector<std::string> replay_args{process_dir + "/dynfilter-replay"};
  replay_args.insert(replay_args.end(), clips.begin(), clips.end());
  for (const auto& m : mappings) replay_args.insert(replay_args.end(), {"--mapping", m});
  replay_args.push_back("--loop");
  for (int k = 1; k * switch_every_s < total_s + 10.0 && clips.size() > 1; ++k) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%g:%zu", k * switch_every_s, static_cast<std::size_t>(k) % clips.size());
    replay_args.insert(replay_args.end(), {"--switch", buf});
  }
  std::vector<std::string> filter_cmd{process_dir + "/dynfilter", "--mode", mode};
  filter_cmd.insert(filter_cmd.end(), filter_args.begin(), filter_args.end());
  std::vector<std::string> sim_cmd{process_dir + "/dynfilter-sim", "--harness", "--backend", sim_backend};
  sim_cmd.insert(sim_cmd.end(), sim_args.begin(), sim_args.end());

  std::vector<ProcessRecord> procs(3);
  const std::vector<std::string> names{"dynfilter-sim", "dynfilter", "dynfilter-replay"};
  const std::vector<std::vector<std::string>> commands{sim_cmd, filter_cmd, replay_args};
  for (std::size_t i = 0; i < procs.size(); ++i) {
    procs[i].name = names[i];
    procs[i].args = commands[i];
    procs[i].log = out_dir + "/" + names[i] + ".log";
    std::remove(procs[i].log.c_str());
  }

  processes::installStopHandlers();  // Ctrl-C ends the window early; the report still comes
  const double start = nowSeconds();
  Listener listener(info, start);
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "dynfilter-soak: cannot open LCM %s\n", url.c_str());
    return 2;
  }
  lcm.subscribe(msg::kTorqueCommandChannel, &Listener::onCommand, &listener);
  lcm.subscribe(msg::kFilterStatusChannel, &Listener::onStatus, &listener);
  std::atomic<bool> listening{true};
  std::thread listen_thread([&] {
    while (listening) lcm.handleTimeout(20);
  });

  std::fprintf(stderr, "dynfilter-soak: %s mode, %.0f s warm-up + %.0f s window on %s; logs in %s\n",
               mode.c_str(), warmup_s, duration_s, url.c_str(), out_dir.c_str());
  std::vector<std::unique_ptr<processes::Child>> children;
  // As the e2e test: the robot and the filter load and tick first, then the motion comes.
  children.push_back(std::make_unique<processes::Child>(procs[0].args, url, procs[0].log));
  children.push_back(std::make_unique<processes::Child>(procs[1].args, url, procs[1].log));

  auto sampleMemory = [&](double t) {
    for (std::size_t i = 0; i < children.size(); ++i) {
      ProcessRecord& p = procs[i];
      if (!p.alive_to_end) continue;
      MemoryKb kb;
      if (children[i]->running() && readMemory(children[i]->pid(), kb)) {
        p.samples.push_back({t, kb});
      } else {
        p.alive_to_end = false;
        p.died_at_s = t;
        std::fprintf(stderr, "dynfilter-soak: %s exited at t = %.1f s (see %s)\n", p.name.c_str(), t, p.log.c_str());
      }
    }
  };

  // Per-second samples; the window's baselines are taken at the first sample after warm-up.
  struct Mark {
    double t_s = 0.0;
    Listener::Counters c;
    long commands = 0;
  };
  Mark window_start, window_end;
  bool window_open = false;
  double replay_started = 0.0;
  double next_sample = start;
  double max_command_gap_s = 0.0;
  while (!processes::g_stop) {
    const double now = nowSeconds(), t = now - start;
    if (children.size() == 2 && t >= settle_s) {
      children.push_back(std::make_unique<processes::Child>(procs[2].args, url, procs[2].log));
      replay_started = t;
    }
    sampleMemory(t);
    {
      std::lock_guard<std::mutex> lock(listener.mutex);
      if (listener.last_command_s > 0.0) max_command_gap_s = std::max(max_command_gap_s, now - listener.last_command_s);
      if (!window_open && children.size() == 3 && t >= replay_started + warmup_s) {
        window_open = true;
        window_start = {t, listener.last, listener.commands};
        listener.in_window = true;
      }
      window_end = {t, listener.last, listener.commands};
    }
    if (window_open && t >= window_start.t_s + duration_s - 0.5) break;
    if (std::none_of(procs.begin(), procs.end(), [](const ProcessRecord& p) { return p.alive_to_end; })) break;
    next_sample += 1.0;
    while (nowSeconds() < next_sample && !processes::g_stop)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const bool interrupted = processes::g_stop;
  {
    std::lock_guard<std::mutex> lock(listener.mutex);
    listener.in_window = false;
  }
  // Stop in the reverse order: motion, filter, robot.
  for (std::size_t i = children.size(); i-- > 0;) {
    const bool was_running = children[i]->running();
    procs[i].exit_code = was_running ? children[i]->stop() : children[i]->exitCode();
    procs[i].signal = children[i]->termSignal();
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  listening = false;
  listen_thread.join();

  // ---- evaluation ------------------------------------------------------------------------
  std::lock_guard<std::mutex> lock(listener.mutex);
  const Listener& L = listener;
  const double window_s = window_end.t_s - window_start.t_s;
  const std::int64_t ticks = window_end.c.ticks - window_start.c.ticks;
  const std::int64_t missed = window_end.c.missed_ticks - window_start.c.missed_ticks;
  const double missed_fraction = ticks > 0 ? static_cast<double>(missed) / static_cast<double>(ticks) : 1.0;
  const long window_commands = window_end.commands - window_start.commands;
  // The filter publishes a command every tick it runs.
  const double decoded_fraction = ticks > 0 ? static_cast<double>(window_commands) / static_cast<double>(ticks) : 0.0;

  bool memory_ok = true;
  std::ostringstream memory_measured;
  for (auto& p : procs) {
    if (p.samples.empty()) {
      memory_ok = false;
      continue;
    }
    p.start = p.samples.front().kb;
    p.end = p.samples.back().kb;
    p.warm = p.end;
    for (const auto& s : p.samples)
      if (s.t_s >= window_start.t_s) {
        p.warm = s.kb;
        break;
      }
    for (const auto& s : p.samples) {
      p.peak.rss = std::max(p.peak.rss, s.kb.rss);
      p.peak.hwm = std::max(p.peak.hwm, s.kb.hwm);
    }
    const double slope = rssSlope(p.samples, window_start.t_s);
    p.slope_kb_per_min = slope * 60.0;
    p.growth_fit_kb = slope * window_s;
    const long d_rss = p.end.rss - p.warm.rss, d_hwm = p.end.hwm - p.warm.hwm;
    const bool ok = window_open && d_rss <= budget_kb && d_hwm <= budget_kb && p.growth_fit_kb <= budget_kb;
    memory_ok = memory_ok && ok;
    char buf[200];
    std::snprintf(buf, sizeof buf, "%s%s ΔRSS %+ld kB, ΔHWM %+ld kB, fit %+.0f kB", memory_measured.tellp() > 0 ? "; " : "",
                  p.name.c_str(), d_rss, d_hwm, p.growth_fit_kb);
    memory_measured << buf;
  }

  bool processes_ok = true;
  std::ostringstream proc_measured;
  for (const auto& p : procs) {
    processes_ok = processes_ok && p.alive_to_end && p.exit_code == 0;
    proc_measured << (proc_measured.tellp() > 0 ? "; " : "") << p.name << ": "
                  << (p.alive_to_end ? "ran to the end" : "died at " + std::to_string(p.died_at_s) + " s")
                  << ", exit " << p.exit_code << (p.signal ? " (signal " + std::to_string(p.signal) + ")" : "");
  }
  processes_ok = processes_ok && procs.size() == children.size();

  auto fmt = [](const char* f, auto... a) {
    char buf[512];
    std::snprintf(buf, sizeof buf, f, a...);
    return std::string(buf);
  };
  std::vector<Check> checks;
  checks.push_back({"memory", fmt("per process after warm-up: ΔVmRSS ≤ %.0f kB, ΔVmHWM ≤ %.0f kB, fitted RSS trend ≤ %.0f kB over the window",
                                  budget_kb, budget_kb, budget_kb),
                    memory_measured.str(), memory_ok});
  checks.push_back({"missed ticks", fmt("missed / ticks ≤ %.2f %% over the window", 100.0 * missed_budget),
                    fmt("%lld / %lld = %.3f %%", static_cast<long long>(missed), static_cast<long long>(ticks), 100.0 * missed_fraction),
                    window_open && ticks > 0 && missed_fraction <= missed_budget});
  const long bad_commands = L.malformed_commands + L.bad_joint_sets + L.non_finite_commands + L.over_limit_commands;
  checks.push_back({"torques", "every command decodes, names each model joint once, τ finite and |τ| ≤ URDF effort",
                    fmt("%ld commands, %ld bad (malformed %ld, joint set %ld, non-finite %ld, over limit %ld)%s%s", L.commands,
                        bad_commands, L.malformed_commands, L.bad_joint_sets, L.non_finite_commands, L.over_limit_commands,
                        L.first_bad_torque.empty() ? "" : "; first: ", L.first_bad_torque.c_str()),
                    L.commands > 0 && bad_commands == 0});
  checks.push_back({"counters", "every status: frames_received = accepted + rejected + dropped; ticks increase",
                    fmt("%ld statuses, %ld violations (largest gap %lld)%s%s, %ld regressions", L.statuses, L.counter_violations,
                        static_cast<long long>(L.max_counter_gap), L.first_counter_violation.empty() ? "" : "; first: ",
                        L.first_counter_violation.c_str(), L.counter_regressions),
                    L.statuses > 0 && L.counter_violations == 0 && L.counter_regressions == 0 && L.malformed_statuses == 0});
  checks.push_back({"rejected frames", "none (the replay sends only valid frames)",
                    fmt("%lld%s%s", static_cast<long long>(L.last.frames_rejected), L.first_reject_reason.empty() ? "" : ": ",
                        L.first_reject_reason.c_str()),
                    L.last.frames_rejected == 0});
  checks.push_back({"listener", fmt("decoded ≥ %.0f %% of the window's commands; no gap > 1 s", 100.0 * min_decoded),
                    fmt("%ld / %lld = %.2f %%, longest gap %.3f s", window_commands, static_cast<long long>(ticks),
                        100.0 * decoded_fraction, max_command_gap_s),
                    decoded_fraction >= min_decoded && max_command_gap_s <= 1.0});
  checks.push_back({"processes", "all ran to the end and exited 0 on SIGTERM", proc_measured.str(), processes_ok});
  if (!window_open) checks.push_back({"window", "the measured window was reached", "no", false});
  const bool pass = !interrupted && std::all_of(checks.begin(), checks.end(), [](const Check& c) { return c.pass; });

  // Misses near a clip switch: the filter plays the reference 50 ms late; from 0.1 s
  // before to 1 s after the switch reaches it.
  const double replay_t0 = L.replay_start_us ? static_cast<double>(L.replay_start_us) * 1e-6 - start : replay_started;
  long near_switch = 0, missed_near_switch = 0, misses_in_window = 0, ticks_missed_in_window = 0;
  for (const auto& e : L.misses) {
    if (e.t_s < window_start.t_s || e.t_s > window_end.t_s) continue;
    ++misses_in_window;
    ticks_missed_in_window += e.missed;
    const double since = std::fmod(e.t_s - replay_t0, switch_every_s);
    if (clips.size() > 1 && (since < 1.0 || since > switch_every_s - 0.1)) {
      ++near_switch;
      missed_near_switch += e.missed;
    }
  }
  std::vector<MissEvent> worst = L.misses;
  std::sort(worst.begin(), worst.end(), [](const MissEvent& a, const MissEvent& b) { return a.missed > b.missed; });
  if (worst.size() > 10) worst.resize(10);

  // ---- report ----------------------------------------------------------------------------
  std::ostringstream md;
  md << "# dynfilter-soak report\n\n"
     << "Result: **" << (pass ? "PASS" : "FAIL") << "**" << (interrupted ? " (interrupted)" : "") << "\n\n"
     << fmt("Filter mode %s (status says \"%s\"); robot on the harness (%s); clips switched every %g s, looping; "
            "warm-up %g s after the replay started; window %.1f s; LCM %s.\n\n",
            mode.c_str(), L.mode.c_str(), sim_backend.c_str(), switch_every_s, warmup_s, window_s, url.c_str());
  md << "| check | criterion | measured | |\n|---|---|---|---|\n";
  for (const auto& c : checks) md << "| " << c.name << " | " << c.criterion << " | " << c.measured << " | " << (c.pass ? "pass" : "**FAIL**") << " |\n";
  md << "\n## Ticks\n\n"
     << fmt("- window: %lld ticks (%.1f Hz), %lld missed (%.3f %%) in %ld bursts, %ld of them (%ld ticks) within "
            "[−0.1, +1] s of a clip switch\n",
            static_cast<long long>(ticks), window_s > 0 ? static_cast<double>(ticks) / window_s : 0.0,
            static_cast<long long>(missed), 100.0 * missed_fraction, misses_in_window, near_switch, missed_near_switch)
     << fmt("- whole run: %lld ticks, %lld missed; statuses decoded %ld (lost %lld), commands decoded %ld\n",
            static_cast<long long>(L.last.ticks), static_cast<long long>(L.last.missed_ticks), L.statuses,
            static_cast<long long>(L.statuses_lost), L.commands)
     << fmt("- tick_us p50 %.0f, p99 %.0f, p99.9 %.0f, max %.0f; solve_us p50 %.0f, p99 %.0f, max %.0f (whole run)\n",
            L.tick_us.percentile(0.5), L.tick_us.percentile(0.99), L.tick_us.percentile(0.999), L.tick_us.max(),
            L.solve_us.percentile(0.5), L.solve_us.percentile(0.99), L.solve_us.max());
  if (!worst.empty()) {
    md << "- largest bursts (s since start: ticks missed, previous tick_us):";
    for (const auto& e : worst) md << fmt(" %.1f: %ld, %.0f;", e.t_s, e.missed, e.prev_tick_us);
    md << "\n";
  }
  md << "\n## Frames and status\n\n"
     << fmt("- frames received %lld, accepted %lld, rejected %lld, dropped %lld; re-seeds %lld; QP solves %lld, "
            "fallbacks %lld\n",
            static_cast<long long>(L.last.frames_received), static_cast<long long>(L.last.frames_accepted),
            static_cast<long long>(L.last.frames_rejected), static_cast<long long>(L.last.frames_dropped),
            static_cast<long long>(L.last.reseeds), static_cast<long long>(L.last.qp_solves),
            static_cast<long long>(L.last.qp_fallbacks))
     << fmt("- torque: largest |τ| / limit %.3f; commands with the clamped bit %ld\n", L.max_limit_ratio, L.clamped_commands)
     << "- status bits seen (statuses with the bit, whole run / window):";
  bool any_bit = false;
  for (int b = 0; b < 16; ++b)
    if (L.bits[static_cast<std::size_t>(b)]) {
      any_bit = true;
      md << fmt(" %d %s: %ld / %ld;", 1 << b, msg::statusBitName(b) ? msg::statusBitName(b) : "?", L.bits[static_cast<std::size_t>(b)],
                L.window_bits[static_cast<std::size_t>(b)]);
    }
  md << (any_bit ? "\n" : " none\n");
  if (!L.reasons.empty()) {
    md << "- reasons (statuses):";
    for (const auto& [r, n] : L.reasons) md << " \"" << r << "\": " << n << ";";
    md << "\n";
  }
  md << "\n## Memory (kB; VmRSS / VmHWM, sampled every second)\n\n"
     << "| process | start | after warm-up | end | peak RSS | ΔRSS | ΔHWM | RSS trend (kB/min) | samples |\n"
     << "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& p : procs)
    md << fmt("| %s | %ld / %ld | %ld / %ld | %ld / %ld | %ld | %+ld | %+ld | %+.2f | %zu |\n", p.name.c_str(), p.start.rss,
              p.start.hwm, p.warm.rss, p.warm.hwm, p.end.rss, p.end.hwm, p.peak.rss, p.end.rss - p.warm.rss,
              p.end.hwm - p.warm.hwm, p.slope_kb_per_min, p.samples.size());
  md << "\n## Commands\n\n```sh\n";
  for (const auto& p : procs) md << joined(p.args) << "\n";
  md << "```\n";

  std::ostringstream js;
  js << "{\n  \"pass\": " << (pass ? "true" : "false") << ",\n  \"interrupted\": " << (interrupted ? "true" : "false")
     << ",\n  \"mode\": " << jsonString(mode) << ",\n  \"lcm_url\": " << jsonString(url)
     << fmt(",\n  \"warmup_s\": %g,\n  \"window_s\": %.3f,\n  \"switch_every_s\": %g", warmup_s, window_s, switch_every_s)
     << fmt(",\n  \"ticks\": %lld,\n  \"missed_ticks\": %lld,\n  \"missed_fraction\": %.6g", static_cast<long long>(ticks),
            static_cast<long long>(missed), missed_fraction)
     << fmt(",\n  \"missed_bursts\": %ld,\n  \"missed_bursts_near_switch\": %ld", misses_in_window, near_switch)
     << fmt(",\n  \"run_ticks\": %lld,\n  \"run_missed_ticks\": %lld", static_cast<long long>(L.last.ticks),
            static_cast<long long>(L.last.missed_ticks))
     << fmt(",\n  \"tick_us\": {\"p50\": %.0f, \"p99\": %.0f, \"p999\": %.0f, \"max\": %.0f}", L.tick_us.percentile(0.5),
            L.tick_us.percentile(0.99), L.tick_us.percentile(0.999), L.tick_us.max())
     << fmt(",\n  \"commands\": %ld,\n  \"window_commands\": %ld,\n  \"statuses\": %ld,\n  \"statuses_lost\": %lld", L.commands,
            window_commands, L.statuses, static_cast<long long>(L.statuses_lost))
     << fmt(",\n  \"frames\": {\"received\": %lld, \"accepted\": %lld, \"rejected\": %lld, \"dropped\": %lld}",
            static_cast<long long>(L.last.frames_received), static_cast<long long>(L.last.frames_accepted),
            static_cast<long long>(L.last.frames_rejected), static_cast<long long>(L.last.frames_dropped))
     << fmt(",\n  \"reseeds\": %lld,\n  \"counter_violations\": %ld,\n  \"bad_commands\": %ld,\n  \"max_tau_limit_ratio\": %.6g",
            static_cast<long long>(L.last.reseeds), L.counter_violations, bad_commands, L.max_limit_ratio)
     << ",\n  \"status_bits\": {";
  bool first_bit = true;
  for (int b = 0; b < 16; ++b)
    if (L.bits[static_cast<std::size_t>(b)]) {
      js << (first_bit ? "" : ", ") << "\"" << (1 << b) << "\": [" << L.bits[static_cast<std::size_t>(b)] << ", "
         << L.window_bits[static_cast<std::size_t>(b)] << "]";
      first_bit = false;
    }
  js << "},\n  \"missed_events\": [";
  for (std::size_t k = 0; k < L.misses.size() && k < 5000; ++k)
    js << (k ? ", " : "") << fmt("[%.3f, %ld]", L.misses[k].t_s, L.misses[k].missed);
  js << "],\n  \"checks\": [";
  for (std::size_t i = 0; i < checks.size(); ++i)
    js << (i ? "," : "") << "\n    {\"name\": " << jsonString(checks[i].name) << ", \"criterion\": " << jsonString(checks[i].criterion)
       << ", \"measured\": " << jsonString(checks[i].measured) << ", \"pass\": " << (checks[i].pass ? "true" : "false") << "}";
  js << "\n  ],\n  \"processes\": [";
  for (std::size_t i = 0; i < procs.size(); ++i) {
    const auto& p = procs[i];
    js << (i ? "," : "") << "\n    {\"name\": " << jsonString(p.name) << ", \"command\": " << jsonString(joined(p.args))
       << fmt(", \"exit_code\": %d, \"alive_to_end\": %s", p.exit_code, p.alive_to_end ? "true" : "false")
       << fmt(", \"rss_kb\": {\"start\": %ld, \"warm\": %ld, \"end\": %ld, \"peak\": %ld}", p.start.rss, p.warm.rss, p.end.rss, p.peak.rss)
       << fmt(", \"hwm_kb\": {\"start\": %ld, \"warm\": %ld, \"end\": %ld}", p.start.hwm, p.warm.hwm, p.end.hwm)
       << fmt(", \"rss_trend_kb_per_min\": %.4f, \"samples\": [", p.slope_kb_per_min);
    for (std::size_t k = 0; k < p.samples.size(); ++k)
      js << (k ? ", " : "") << fmt("[%.1f, %ld, %ld]", p.samples[k].t_s, p.samples[k].kb.rss, p.samples[k].kb.hwm);
    js << "]}";
  }
  js << "\n  ]\n}\n";

  std::fputs(md.str().c_str(), stdout);
  std::ofstream(out_dir + "/report.md") << md.str();
  std::ofstream(out_dir + "/report.json") << js.str();
  std::fprintf(stderr, "dynfilter-soak: %s; report in %s/report.md and report.json\n", pass ? "PASS" : "FAIL", out_dir.c_str());
  return pass ? 0 : 1;
}
