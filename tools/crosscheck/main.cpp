// dynfilter-crosscheck: the same robot through two independent engines (DART and ODE).
//
//   dynfilter-crosscheck [robot.urdf] [--states 100] [--seed 1] [--states-file s.csv]
//                        [--model-b other.urdf] [--tol 1e-9] [--json out.json]
//   dynfilter-crosscheck [robot.urdf] --filtered filtered.csv --filtered-backend dart
//
// Sampled states: A, b, the Jacobians and J̇·v of the contact bodies, forward dynamics
// under the same torques, contact points (standing), and a short simulated trajectory
// under the same torques (how the gap grows). Filtered motion: Eq. 12 re-evaluated on
// every frame by the other backend. Exit status 1 when a tolerance is exceeded.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "model_cli.hpp"
#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/io/filtered_motion_check.hpp"
#include "dynfilter/io/filtered_motion_reader.hpp"
#include "dynfilter/io/input_error.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"

namespace {

using namespace dynfilter;
using Json = nlohmann::json;

double relativeError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  if (a.size() == 0) return 0.0;
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

Json toJson(const Eigen::MatrixXd& m) {
  Json rows = Json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    Json row = Json::array();
    for (Eigen::Index j = 0; j < m.cols(); ++j) row.push_back(m(i, j));
    rows.push_back(row);
  }
  return m.cols() == 1 ? Json(std::vector<double>(m.data(), m.data() + m.size())) : rows;
}

// Worst relative error per compared quantity, with its tolerance.
struct Table {
  std::map<std::string, double> worst;
  std::vector<std::string> order;
  void add(const std::string& name, double error) {
    if (!worst.count(name)) order.push_back(name);
    worst[name] = std::max(worst[name], error);
  }
};

// Links that carry collision geometry, plus leaf links: the points users care about.
std::vector<int> bodiesOfInterest(const urdf::RobotDescription& robot) {
  std::vector<int> bodies;
  for (std::size_t k = 0; k < robot.links.size(); ++k)
    if (!robot.links[k].collisions.empty() || robot.links[k].child_joints.empty())
      bodies.push_back(static_cast<int>(k));
  return bodies;
}

int checkFiltered(const urdf::RobotDescription& robot, const std::string& backend,
                  const std::string& filtered_path, bool fixed_base, double tol_weight) {
  ModelOptions options;
  options.floating_base = !fixed_base;
  auto model = makeModel(backend, robot, options);
  const ModelInfo& info = model->info();
  const auto frames = io::readFilteredMotion(filtered_path, info);
  const io::FilteredMotionResiduals res = io::evaluateFilteredMotion(*model, frames);
  const double worst_base = res.worst_base_n, worst_all = res.worst_all;
  const std::size_t worst_frame = res.worst_base_frame;
  const double weight = info.total_mass * 9.81;
  std::printf("Eq. 12 of %s (%zu frames) re-evaluated with the %s backend:\n",
              filtered_path.c_str(), frames.size(), backend.c_str());
  std::printf("  unactuated base rows: max %.3g N (%.3g of body weight, frame %zu at t = %.4f s)\n",
              worst_base, worst_base / weight, worst_frame,
              frames.empty() ? 0.0 : frames[worst_frame].state.time_s);
  std::printf("  all rows:             max %.3g\n", worst_all);
  // Every row must hold: the base rows (no actuator) and the joint rows (the torques).
  const bool ok = worst_all <= tol_weight * weight;
  std::printf("  %s (tolerance on every row: %.3g × body weight = %.3g)\n", ok ? "PASS" : "FAIL",
              tol_weight, tol_weight * weight);
  return ok ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Compare the dynamics of one robot in DART and in ODE."};
  std::string model_a = DYNFILTER_DEFAULT_MODEL, model_b, states_file, json_path, filtered;
  std::string backend_a = "dart", backend_b = "ode", filtered_backend = "dart";
  int states = 100;
  unsigned seed = 1;
  bool fixed_base = false;
  double tol = 1e-9, tol_contact_m = 2e-3, trajectory_s = 0.2, tol_weight = 1e-8;
  auto* positional = app.add_option("model", model_a, "URDF (default: the human figure)");
  app.add_option("-m,--model", model_a, "URDF, as every tool takes it (same as the positional)")
      ->excludes(positional);
  app.add_option("--model-b", model_b, "a different URDF for the second backend (default: the same)");
  app.add_option("--backend-a", backend_a)->check(CLI::IsMember(availableBackends()));
  app.add_option("--backend-b", backend_b)->check(CLI::IsMember(availableBackends()));
  app.add_option("--states", states, "number of random states")->check(CLI::PositiveNumber);
  app.add_option("--seed", seed, "random seed");
  app.add_option("--states-file", states_file, "states from a reference motion CSV instead");
  app.add_flag("--fixed-base", fixed_base, "weld the root link to the world");
  app.add_option("--tol", tol, "relative tolerance on A, b, J, J̇v, forward dynamics");
  app.add_option("--tol-contact-m", tol_contact_m, "tolerance on contact point positions (m)");
  app.add_option("--trajectory-s", trajectory_s, "simulated trajectory length (s), reported");
  app.add_option("--json", json_path, "write every compared quantity per state to this file");
  app.add_option("--filtered", filtered, "a dynfilter-offline output: re-evaluate Eq. 12");
  app.add_option("--filtered-backend", filtered_backend,
                 "the backend that made --filtered; the other one checks it")
      ->check(CLI::IsMember(availableBackends()));
  app.add_option("--tol-weight", tol_weight, "Eq. 12 tolerance on every row, fraction of body weight");
  tools::ModelCli model_cli;
  tools::addModelOptions(app, model_cli);
  CLI11_PARSE(app, argc, argv);

  try {
    if (!filtered.empty()) {
      const std::string other = filtered_backend == "dart" ? "ode" : "dart";
      return checkFiltered(tools::loadRobot(model_a, model_cli, !fixed_base), other, filtered, fixed_base,
                           tol_weight);
    }
    if (model_b.empty()) model_b = model_a;
    ModelOptions options;
    options.floating_base = !fixed_base;
    const auto robot_a = tools::loadRobot(model_a, model_cli, !fixed_base);
    const auto robot_b = tools::loadRobot(model_b, model_cli, !fixed_base && model_b != model_a);
    auto a = makeModel(backend_a, robot_a, options);
    auto b = makeModel(backend_b, robot_b, options);
    const ModelInfo& info = a->info();
    if (b->info().joint_names != info.joint_names)
      throw std::invalid_argument("the two models have different joints");
    const int nv = info.nv, nj = info.nj;

    std::vector<std::pair<Eigen::VectorXd, Eigen::VectorXd>> samples;
    if (!states_file.empty()) {
      io::ReferenceReadOptions ro;
      ro.allow_extra_columns = true;
      for (const auto& f : io::readReferenceMotion(states_file, info, ro).frames)
        samples.emplace_back(f.q, f.v);
    } else {
      std::mt19937 rng(seed);
      for (int s = 0; s < states; ++s) {
        Eigen::VectorXd q, v;
        randomState(info, rng, 1.0, q, v);
        samples.emplace_back(q, v);
      }
    }

    Table table;
    Json json = {{"model_a", model_a}, {"model_b", model_b}, {"backend_a", backend_a},
                 {"backend_b", backend_b}, {"states", Json::array()}};
    const std::vector<int> bodies = bodiesOfInterest(robot_a);
    std::mt19937 torque_rng(seed + 1);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    Eigen::MatrixXd A_a(nv, nv), A_b(nv, nv);
    Eigen::VectorXd b_a(nv), b_b(nv), f_a(nv), f_b(nv), tau(nj);
    Matrix6Xd J_a(6, nv), J_b(6, nv);
    for (const auto& [q, v] : samples) {
      a->setState(q, v);
      b->setState(q, v);
      a->massMatrix(A_a);
      b->massMatrix(A_b);
      a->bias(b_a);
      b->bias(b_b);
      for (int j = 0; j < nj; ++j)
        tau[j] = unit(torque_rng) * (std::isfinite(info.tau_max[j]) ? info.tau_max[j] : 10.0);
      a->forwardDynamics(tau, f_a);
      b->forwardDynamics(tau, f_b);
      Json entry = {{"q", toJson(q)}, {"v", toJson(v)}, {"tau", toJson(tau)},
                    {"A", {{backend_a, toJson(A_a)}, {backend_b, toJson(A_b)}}},
                    {"b", {{backend_a, toJson(b_a)}, {backend_b, toJson(b_b)}}},
                    {"vdot", {{backend_a, toJson(f_a)}, {backend_b, toJson(f_b)}}}};
      Json errors = {{"mass_matrix", relativeError(A_b, A_a)}, {"bias", relativeError(b_b, b_a)},
                     {"forward_dynamics", relativeError(f_b, f_a)}};
      table.add("mass matrix A", errors["mass_matrix"]);
      table.add("bias b", errors["bias"]);
      table.add("forward dynamics v̇", errors["forward_dynamics"]);
      for (int body : bodies) {
        const Eigen::Vector3d p = robot_a.links[static_cast<std::size_t>(body)].inertial.p_LCom;
        a->pointJacobian(body, p, J_a);
        b->pointJacobian(body, p, J_b);
        const auto& name = info.body_names[static_cast<std::size_t>(body)];
        const double ej = relativeError(J_b, J_a);
        const double ed = relativeError(b->pointJacobianDotTimesV(body, p),
                                        a->pointJacobianDotTimesV(body, p));
        errors["jacobian:" + name] = ej;
        errors["jdotv:" + name] = ed;
        table.add("Jacobian " + name, ej);
        table.add("J̇·v " + name, ed);
      }
      entry["relative_error"] = errors;
      json["states"].push_back(entry);
    }

    bool ok = true;
    std::printf("%s: %s vs %s, %zu states (%s)\n", info.name.c_str(), backend_a.c_str(),
                backend_b.c_str(), samples.size(),
                states_file.empty() ? ("seed " + std::to_string(seed)).c_str() : states_file.c_str());
    std::printf("  %-34s %12s %10s\n", "quantity", "worst rel.", "tolerance");
    for (const auto& name : table.order) {
      const bool pass = table.worst[name] <= tol;
      ok &= pass;
      std::printf("  %-34s %12.3g %10.1g  %s\n", name.c_str(), table.worst[name], tol,
                  pass ? "ok" : "FAIL");
    }

    // Contacts of the model standing on level ground (floating base only).
    if (info.floating_base) {
      Eigen::VectorXd q = info.neutralConfiguration(), v = Eigen::VectorXd::Zero(nv);
      q[2] = standingBaseHeight(*a, q) - 1e-3;
      ContactList ca, cb;
      a->setState(q, v);
      b->setState(q, v);
      a->detectContacts(ca);
      b->detectContacts(cb);
      double worst = 0.0;
      for (const auto& x : ca) {
        double nearest = INFINITY;
        for (const auto& y : cb)
          if (y.body == x.body) nearest = std::min(nearest, (y.p_WC - x.p_WC).norm());
        worst = std::max(worst, nearest);
      }
      const bool pass = ca.size() == cb.size() && worst <= tol_contact_m;
      ok &= pass;
      std::printf("  %-34s %5zu vs %-5zu max %.3g m  %s\n", "contact points (standing -1 mm)",
                  ca.size(), cb.size(), worst, pass ? "ok" : "FAIL");
      json["contacts"] = {{"count", {ca.size(), cb.size()}}, {"max_distance_m", worst}};
    }

    // A short trajectory in each engine's own simulator, no ground, same torques.
    ModelOptions flight = options;
    flight.environment.has_ground = false;
    auto sa = makeModel(backend_a, robot_a, flight);
    auto sb = makeModel(backend_b, robot_b, flight);
    sa->setState(samples.front().first, samples.front().second);
    sb->setState(samples.front().first, samples.front().second);
    const double dt = 1e-3;
    const int steps = static_cast<int>(std::lround(trajectory_s / dt));
    Json gaps = Json::array();
    std::printf("  trajectory gap |q_a − q_b|∞ in each engine's simulator (no ground, dt 1 ms):\n   ");
    Eigen::VectorXd dq(nv);
    // Torques that accelerate every joint by about 1 rad/s² (scaled by its own inertia),
    // so light distal links do not spin up.
    Eigen::MatrixXd A0(nv, nv);
    sa->massMatrix(A0);
    // The trajectory is reported, not checked: an engine's simulator that refuses to go on
    // (a runaway on light links) ends it with the reason, and the checks above decide.
    for (int k = 1; k <= steps; ++k) {
      for (int j = 0; j < nj; ++j)
        tau[j] = A0(info.velocityIndex(j), info.velocityIndex(j)) * std::sin(0.02 * k + j);
      std::string stopped;
      for (IDynamicsModel* sim : {sa.get(), sb.get()}) {
        try {
          sim->simulateStep(tau, dt);
        } catch (const std::runtime_error& e) {
          char at[32];
          std::snprintf(at, sizeof at, "%.3f s", k * dt);
          stopped = std::string(sim->backendName()) + "'s simulator stopped at " + at + ": " + e.what();
          break;
        }
      }
      if (!stopped.empty()) {
        std::printf("\n  %s", stopped.c_str());
        json["trajectory_stopped"] = stopped;
        break;
      }
      if (k % std::max(1, steps / 5) == 0) {
        differenceConfiguration(info.floating_base, sa->q(), sb->q(), dq);
        const double gap = dq.cwiseAbs().maxCoeff();
        std::printf(" %.3fs: %.2g", k * dt, gap);
        gaps.push_back({{"t_s", k * dt}, {"gap", gap}});
      }
    }
    std::printf("\n");
    json["trajectory_gap"] = gaps;
    if (!json_path.empty()) {
      std::ofstream out(json_path);
      out << json.dump() << "\n";
      if (!out) throw std::runtime_error("cannot write " + json_path);
    }
    std::printf("%s\n", ok ? "PASS" : "FAIL: a tolerance was exceeded");
    return ok ? 0 : 1;
  } catch (const ModelError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const io::InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}
