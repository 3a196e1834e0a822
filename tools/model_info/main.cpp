// dynfilter-model-info: loads a URDF through a backend, prints what the model is (sizes,
// joints, limits, mass), where it touches the ground when standing, and how it behaves in
// the engine's own simulator when its joints hold their posture.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/kinematic_tree.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "model_cli.hpp"

namespace {

using dynfilter::ContactList;
using dynfilter::IDynamicsModel;

constexpr double kRadToDeg = 180.0 / M_PI;

void printJoints(IDynamicsModel& model) {
  const dynfilter::ModelInfo& info = model.info();
  const std::vector<dynfilter::JointGroup> groups = dynfilter::jointGroupsOf(model);
  std::printf("\n%-20s %9s %9s %9s %9s  %s\n", "joint", "lower°", "upper°", "|τ|max", "|q̇|max",
              "group (by structure)");
  for (int j = 0; j < info.nj; ++j)
    std::printf("%-20s %9.1f %9.1f %9.1f %9.1f  %s\n", info.joint_names[j].c_str(),
                info.q_lower[j] * kRadToDeg, info.q_upper[j] * kRadToDeg, info.tau_max[j],
                info.v_max[j], dynfilter::toString(groups[static_cast<std::size_t>(j)]));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Load a URDF model through a dynfilter backend and describe it."};
  std::string urdf_path = DYNFILTER_DEFAULT_MODEL;
  bool fixed_base = false;
  double seconds = 2.0;
  double dt = 1e-3;
  double kp = 2000.0, kd = 40.0;
  bool list_joints = false, joint_groups = false;
  std::string backend = "dart";
  auto* positional = app.add_option("urdf", urdf_path, "URDF file (default: the human figure)");
  app.add_option("-m,--model", urdf_path, "URDF file, as every tool takes it (same as the positional)")
      ->excludes(positional);
  app.add_flag("--fixed-base", fixed_base, "weld the root link to the world");
  app.add_option("--backend", backend, "dynamics backend: dart or ode")
      ->check(CLI::IsMember(dynfilter::availableBackends()));
  app.add_flag("--joints", list_joints, "print every joint with its limits");
  app.add_flag("--joint-groups", joint_groups,
               "print only CSV lines joint,group (spine|legs|arms|other, by structure) and exit")
      ->excludes("--joints");
  app.add_option("--seconds", seconds, "simulated standing time (s)")->check(CLI::NonNegativeNumber);
  app.add_option("--dt", dt, "simulation step (s)")->check(CLI::PositiveNumber);
  app.add_option("--kp", kp, "posture stiffness (N m / rad), capped per joint where a step of "
                 "--dt would make it unstable (a light joint)");
  app.add_option("--kd", kd, "posture damping (N m s / rad), capped the same way");
  dynfilter::tools::ModelCli model_cli;
  dynfilter::tools::addModelOptions(app, model_cli);
  CLI11_PARSE(app, argc, argv);

  try {
    const auto robot = dynfilter::tools::loadRobot(urdf_path, model_cli, /*floating_base=*/!fixed_base);
    if (!model_cli.verbose)
      for (const auto& w : robot.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    dynfilter::ModelOptions options;
    options.floating_base = !fixed_base;
    auto model = dynfilter::makeModel(backend, robot, options);
    const auto& info = model->info();
    if (joint_groups) {
      const std::vector<dynfilter::JointGroup> groups = dynfilter::jointGroupsOf(*model);
      std::printf("joint,group\n");
      for (int j = 0; j < info.nj; ++j)
        std::printf("%s,%s\n", info.joint_names[static_cast<std::size_t>(j)].c_str(),
                    dynfilter::toString(groups[static_cast<std::size_t>(j)]));
      return 0;
    }
    std::printf("model %s (%s backend) from %s\n", info.name.c_str(),
                std::string(model->backendName()).c_str(), urdf_path.c_str());
    std::printf("  bodies %zu, actuated joints N_J = %d, nq = %d, nv = N_G = %d, %s base\n",
                info.body_names.size(), info.nj, info.nq, info.nv,
                info.floating_base ? "floating" : "fixed");
    std::printf("  total mass %.3f kg\n", info.total_mass);
    if (!robot.mimic_joints.empty()) {
      std::printf("  mimic joints (no coordinate; q = k q_leader + c):\n");
      for (const int f : robot.mimic_joints) {
        const auto& j = robot.joints[static_cast<std::size_t>(f)];
        std::printf("    %s = %g * %s %+g\n", j.name.c_str(), j.mimic_multiplier,
                    robot.joints[static_cast<std::size_t>(j.mimic_leader)].name.c_str(),
                    j.mimic_offset);
      }
    }
    if (!robot.ignored_elements.empty() && !model_cli.verbose)
      std::printf("  %zu kinds of URDF elements ignored (--verbose lists them)\n",
                  robot.ignored_elements.size());
    if (list_joints) printJoints(*model);

    // Timing of the dynamics terms at one state (a benchmark lives in tests/bench).
    Eigen::MatrixXd A(info.nv, info.nv);
    Eigen::VectorXd b(info.nv);
    model->setState(info.neutralConfiguration(), Eigen::VectorXd::Zero(info.nv));
    const auto t0 = std::chrono::steady_clock::now();
    model->massMatrix(A);
    model->bias(b);
    const auto t1 = std::chrono::steady_clock::now();
    std::printf("  A and b at the neutral pose in %.0f µs (first call, uncached)\n",
                std::chrono::duration<double, std::micro>(t1 - t0).count());

    if (!info.floating_base) return 0;
    ContactList contacts;
    const double z0 = dynfilter::standingContacts(*model, info.neutralConfiguration(), contacts);
    const Eigen::VectorXd q = model->q();
    std::printf("\nstanding on level ground: base height %.4f m, %zu contact points\n", z0,
                contacts.size());
    for (const auto& c : contacts)
      std::printf("  %-10s p_W = (%+.3f, %+.3f, %+.4f) m  n_W = (%+.2f, %+.2f, %+.2f)\n",
                  info.body_names[c.body].c_str(), c.p_WC.x(), c.p_WC.y(), c.p_WC.z(),
                  c.n_W.x(), c.n_W.y(), c.n_W.z());

    if (seconds <= 0.0) return 0;
    // Hold the zero posture with joint PD (torques clamped to the URDF limits) while the
    // engine's own simulator integrates the whole body with ground contact.
    const Eigen::VectorXd q_ref = q.tail(info.nj);
    Eigen::VectorXd tau(info.nj);
    // One PD for every joint, but an explicit PD step is stable only while kp dt² and
    // kd dt stay small against the joint's inertia A_jj (neutral pose): a 10 g finger
    // diverges under gains that hold a thigh. Those joints get the stable cap.
    const int v0 = info.floating_base ? 6 : 0;
    Eigen::VectorXd kp_j(info.nj), kd_j(info.nj);
    int capped = 0;
    for (int j = 0; j < info.nj; ++j) {
      const double inertia = A(v0 + j, v0 + j);
      kp_j[j] = std::min(kp, 0.02 * inertia / (dt * dt));
      kd_j[j] = std::min(kd, 0.2 * inertia / dt);
      capped += kp_j[j] < kp || kd_j[j] < kd ? 1 : 0;
    }
    double peak_tau_ratio = 0.0;
    int peak_joint = 0;
    const int steps = static_cast<int>(std::lround(seconds / dt));
    for (int k = 0; k < steps; ++k) {
      const auto qj = model->q().tail(info.nj);
      const auto vj = model->v().tail(info.nj);
      for (int j = 0; j < info.nj; ++j) {
        const double raw = kp_j[j] * (q_ref[j] - qj[j]) - kd_j[j] * vj[j];
        tau[j] = std::clamp(raw, -info.tau_max[j], info.tau_max[j]);
        if (std::abs(tau[j]) / info.tau_max[j] > peak_tau_ratio) {
          peak_tau_ratio = std::abs(tau[j]) / info.tau_max[j];
          peak_joint = j;
        }
      }
      model->simulateStep(tau, dt);
    }
    model->detectContacts(contacts);
    const Eigen::Vector3d base = model->q().head<3>();
    std::printf("\nafter %.2f s standing under joint PD (kp %.0f, kd %.0f; %d light joint(s) "
                "capped for a stable step) in the engine:\n", seconds, kp, kd, capped);
    std::printf("  base at (%+.4f, %+.4f, %.4f) m (drop %.1f mm), %zu contact points\n", base.x(),
                base.y(), base.z(), (z0 - base.z()) * 1e3, contacts.size());
    if (info.nj > 0)
      std::printf("  largest torque used: %.0f %% of its limit (%s)\n", 100.0 * peak_tau_ratio,
                  info.joint_names[static_cast<std::size_t>(peak_joint)].c_str());
    const bool standing = base.z() > z0 - 0.05;
    std::printf("  %s\n", standing ? "still standing" : "fell");
    return standing ? 0 : 3;
  } catch (const dynfilter::ModelError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
