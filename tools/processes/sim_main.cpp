// dynfilter-sim — the simulated robot: its joint drives apply the latest torque command
// (zero-order hold) plus a servo on the command's filtered joint positions and velocities,
// like a real robot's drives, in a DART or ODE world at a fixed rate; it publishes the
// measured state. A diverging simulation stops the process.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>

#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/lcm/messages.hpp"
#include "model_cli.hpp"
#include "process_support.hpp"
#include "robot_engine.hpp"

namespace {

using namespace dynfilter;
namespace msg = dynfilter::messages;

// The latest valid command, from the receive thread. Preallocated.
struct CommandInbox {
  explicit CommandInbox(const ModelInfo& model_info)
      : names(model_info),
        tau(Eigen::VectorXd::Zero(model_info.nj)),
        q(Eigen::VectorXd::Zero(model_info.nj)),
        qd(Eigen::VectorXd::Zero(model_info.nj)),
        scratch(Eigen::VectorXd::Zero(model_info.nj)),
        scratch_q(Eigen::VectorXd::Zero(model_info.nj)),
        scratch_qd(Eigen::VectorXd::Zero(model_info.nj)) {}
  void onCommand(const lcm::ReceiveBuffer* rbuf, const std::string&) {
    if (message.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) {
      std::fprintf(stderr, "dynfilter-sim: malformed torque command\n");
      return;
    }
    const msg::MessageCheck check = names.map(message.joint_names, message.num_joints);
    const auto n = static_cast<std::size_t>(message.num_joints);
    if (!check.ok() || message.tau.size() != n || message.q.size() != n || message.qd.size() != n) {
      std::fprintf(stderr, "dynfilter-sim: torque command rejected: %s\n", check.reason);
      return;
    }
    for (int k = 0; k < message.num_joints; ++k) {
      const auto i = static_cast<std::size_t>(k);
      const double t = message.tau[i], p = message.q[i], w = message.qd[i];
      if (!std::isfinite(t) || !std::isfinite(p) || !std::isfinite(w)) {
        std::fprintf(stderr, "dynfilter-sim: torque command rejected: not finite\n");
        return;
      }
      const int j = names.indices()[i];
      if (j < 0) continue;  // a joint the model locks
      scratch[j] = t;
      scratch_q[j] = p;
      scratch_qd[j] = w;
    }
    std::lock_guard<std::mutex> lock(mutex);
    tau = scratch;
    q = scratch_q;
    qd = scratch_qd;
    last_utime = message.utime;
    ++count;
  }
  msg::JointNameMap names;
  torque_command_t message;
  std::mutex mutex;
  Eigen::VectorXd tau, q, qd;  // feed-forward torque and the filtered joint state
  Eigen::VectorXd scratch, scratch_q, scratch_qd;
  std::int64_t last_utime = 0;
  long count = 0;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dynfilter-sim: a simulated robot on LCM (DART or ODE)."};
  std::string model_path = DYNFILTER_DEFAULT_MODEL, backend = "dart", url;
  std::string command_channel = msg::kTorqueCommandChannel, state_channel = msg::kRobotStateChannel;
  double rate_hz = 1000.0, duration_s = 0.0, command_timeout_s = 0.1, servo_error_rad = 0.1;
  app.add_option("-m,--model", model_path, "URDF model (default: the human figure)");
  dynfilter::tools::ModelCli model_cli;
  dynfilter::tools::addModelOptions(app, model_cli);
  app.add_option("--backend", backend, "dart or ode")->check(CLI::IsMember(availableBackends()));
  app.add_option("--rate-hz", rate_hz, "simulation and publishing rate")->check(CLI::Range(1.0, 10000.0));
  app.add_option("--duration-s", duration_s, "stop after this long (0: until SIGINT/SIGTERM)");
  app.add_option("--command-timeout-s", command_timeout_s,
                 "no command for this long: zero torques (the robot's safe stop)");
  app.add_option("--servo-error-rad", servo_error_rad,
                 "joint servo on the command's filtered q, qd, on top of its torque: the "
                 "position error (rad) that asks for the joint's full effort (0: torque only)")
      ->check(CLI::NonNegativeNumber);
  bool harness = false;
  app.add_flag("--harness", harness,
               "the robot hangs on a test stand: root link welded, no ground (joint-level "
               "bring-up; the filter still plans the free-floating robot)");
  int substeps = 0;
  app.add_option("--substeps", substeps,
                 "engine steps per tick (0: the engine's own choice, robot_engine.hpp: 1)")
      ->check(CLI::Range(0, 100));
  processes::RealtimeProcessOptions process_options;
  processes::addRealtimeProcessOptions(app, process_options);
  app.add_option("--lcm-url", url, "LCM URL (default: $LCM_DEFAULT_URL)");
  app.add_option("--command-channel", command_channel);
  app.add_option("--state-channel", state_channel);
  CLI11_PARSE(app, argc, argv);

  try {
    // Before any thread (LCM's too) starts.
    const processes::CpuWakeLatencyHold wake_latency = processes::applyRealtimeProcessOptions(process_options);
    ModelOptions model_options;
    if (harness) {
      model_options.floating_base = false;
      model_options.environment.has_ground = false;
    }
    // Before the model: DART's contact softness is process-wide.
    const processes::RobotEngineSettings engine = processes::useAsRobot(backend);
    if (substeps == 0) substeps = engine.substeps;
    const auto robot = dynfilter::tools::loadRobot(model_path, model_cli);
    auto model = makeModel(backend, robot, model_options);
    const ModelInfo& info = model->info();
    // On the harness the robot still reports a free-floating state, its base held at the
    // standing pose, so that the filter can close the loop on it.
    auto free_model = makeModel(backend, robot, ModelOptions{});
    const ModelInfo& reported = free_model->info();
    Eigen::VectorXd q_report = reported.neutralConfiguration();
    if (reported.floating_base) q_report[2] = standingBaseHeight(*free_model, q_report);
    Eigen::VectorXd v_report = Eigen::VectorXd::Zero(reported.nv);
    Eigen::VectorXd q = harness ? info.neutralConfiguration() : q_report;
    model->setState(q, Eigen::VectorXd::Zero(info.nv));

    lcm::LCM lcm(url);
    if (!lcm.good()) throw std::runtime_error("cannot open LCM");
    CommandInbox inbox(info);
    lcm.subscribe(command_channel, &CommandInbox::onCommand, &inbox);
    processes::installStopHandlers();
    // Receiving outranks the control loop: messages must not wait behind it.
    std::thread receive_thread([&lcm] {
      processes::tryRealtimeScheduling(51);
      while (!processes::g_stop) lcm.handleTimeout(20);
    });
    std::fprintf(stderr, "dynfilter-sim: %s on %s at %.0f Hz, %d engine step(s) a tick; %s; %s\n",
                 info.name.c_str(), backend.c_str(), rate_hz, substeps,
                 processes::tryRealtimeScheduling(), wake_latency.note());

    // The robot's joint servos: τ = τ_ff + K_p (q_f − q) + K_d (q̇_f − q̇). K_p asks for the
    // joint's full effort at --servo-error-rad; K_d damps the joint's own inertia (diagonal
    // of A at the start) critically, which keeps light distal joints stable at 1 kHz.
    Eigen::MatrixXd A(info.nv, info.nv);
    model->massMatrix(A);
    const Eigen::VectorXd inertia = A.diagonal().tail(info.nj);
    Eigen::VectorXd kp = Eigen::VectorXd::Zero(info.nj), kd = Eigen::VectorXd::Zero(info.nj);
    if (servo_error_rad > 0.0)
      for (int j = 0; j < info.nj; ++j) {
        kp[j] = std::isfinite(info.tau_max[j]) ? info.tau_max[j] / servo_error_rad : 0.0;
        kd[j] = 2.0 * std::sqrt(kp[j] * inertia[j]);
      }
    Eigen::VectorXd q_cmd = q.tail(info.nj), qd_cmd = Eigen::VectorXd::Zero(info.nj);
    Eigen::VectorXd tau_ff = Eigen::VectorXd::Zero(info.nj);
    robot_state_t state;
    std::vector<std::uint8_t> buffer;
    Eigen::VectorXd tau = Eigen::VectorXd::Zero(info.nj);
    const double dt = 1.0 / rate_hz;
    processes::Ticker ticker(rate_hz);
    const double start = processes::nowSeconds();
    double last_command_s = start;
    long missed = 0, last_count = 0;
    while (!processes::g_stop && (duration_s <= 0.0 || processes::nowSeconds() - start < duration_s)) {
      missed += ticker.wait();
      {
        std::lock_guard<std::mutex> lock(inbox.mutex);
        if (inbox.count != last_count) {
          tau_ff = inbox.tau;
          q_cmd = inbox.q;
          qd_cmd = inbox.qd;
          last_count = inbox.count;
          last_command_s = processes::nowSeconds();
        }
      }
      if (processes::nowSeconds() - last_command_s > command_timeout_s) {
        tau.setZero();  // no controller: the drives go limp
      } else {
        tau = tau_ff + kp.cwiseProduct(q_cmd - model->q().tail(info.nj)) +
              kd.cwiseProduct(qd_cmd - model->v().tail(info.nj));
        for (int j = 0; j < info.nj; ++j)
          tau[j] = std::clamp(tau[j], -info.tau_max[j], info.tau_max[j]);
      }
      try {
        for (int s = 0; s < substeps; ++s) model->simulateStep(tau, dt / substeps);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "dynfilter-sim: %s\n", e.what());
        processes::g_stop = true;
      }
      q_report.tail(info.nj) = model->q().tail(info.nj);
      v_report.tail(info.nj) = model->v().tail(info.nj);
      if (!harness) {
        q_report = model->q();
        v_report = model->v();
      }
      msg::fillRobotState(reported, processes::nowMicros(), q_report, v_report, &tau, state);
      lcm.publish(state_channel, buffer.data(), msg::encodeMessage(state, buffer));
    }
    processes::g_stop = true;
    receive_thread.join();
    std::fprintf(stderr, "dynfilter-sim: stopped; %ld commands applied, %ld missed ticks\n",
                 last_count, missed);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynfilter-sim: error: %s\n", e.what());
    return 2;
  }
}
