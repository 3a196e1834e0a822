// Cost of the IDynamicsModel queries on one backend (DYNFILTER_BENCH_BACKEND: bench_dynamics
// is DART, bench_ode is ODE, both from this file and the same states), for the human figure
// (models/human_figure.urdf: floating base, 32 joints, nv = 38) standing on level ground.
//
// DART caches kinematics and dynamics per state and skips the update when a position is
// set to the value it already holds (ODE's backend poses every body in setState instead),
// so every timed iteration pushes a different state:
// kNumStates states are generated before timing and the loop cycles through them. Each
// timed benchmark other than BM_SetState includes one setState; BM_SetState reports that
// cost on its own so readers can subtract it. DART updates lazily, so forward kinematics
// is paid by the first query after setState, not by setState itself.
//
// Run with repetitions to get medians, e.g.
//   ./build/tests/bench/bench_dynamics --benchmark_repetitions=10
//       --benchmark_report_aggregates_only=true
// (one command line; see BENCHMARKS.md).

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <fstream>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "dynfilter/core/contact.hpp"
#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/model_options.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/core/types.hpp"
#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#if DYNFILTER_BENCH_DART
#include "dynfilter/dart/dart_model.hpp"
#endif

namespace {

using dynfilter::ContactList;
using dynfilter::IDynamicsModel;
using dynfilter::ModelInfo;

constexpr std::size_t kNumStates = 64;  // power of two: the loop index wraps with a mask
constexpr std::uint32_t kSeed = 20240601;
constexpr double kVelocityScale = 1.0;     // |v_i| ≤ this (m/s, rad/s)
constexpr double kLegPerturbation = 0.01;  // rad, standing states only
constexpr double kStandingDepth = 0.001;   // m below the nominal standing height

std::string sourcePath(const std::string& relative) {
  return std::string(DYNFILTER_SOURCE_DIR) + "/" + relative;
}

struct State {
  Eigen::VectorXd q;
  Eigen::VectorXd v;
  Eigen::VectorXd tau_J;  // torques for BM_ForwardDynamics
};

/// A random state: base near (0, 0, 1) m with a uniformly random orientation, joints
/// uniform within their limits ([−π, π] when unbounded), velocities uniform in
/// ±kVelocityScale, torques uniform in ±tau_max (±100 when unbounded).
State randomState(const ModelInfo& info, std::mt19937& rng) {
  std::uniform_real_distribution<double> symmetric(-1.0, 1.0);
  std::normal_distribution<double> gaussian(0.0, 1.0);
  State s;
  s.q.resize(info.nq);
  s.v.resize(info.nv);
  s.tau_J.resize(info.nj);
  if (info.floating_base) {
    s.q.head<3>() = Eigen::Vector3d(0.1 * symmetric(rng), 0.1 * symmetric(rng),
                                    1.0 + 0.1 * symmetric(rng));
    // A normalised 4-D Gaussian is uniform on the unit sphere of quaternions.
    Eigen::Vector4d wxyz;
    do {
      wxyz = Eigen::Vector4d(gaussian(rng), gaussian(rng), gaussian(rng), gaussian(rng));
    } while (wxyz.norm() < 1e-6);
    s.q.segment<4>(3) = wxyz.normalized();
  }
  for (int j = 0; j < info.nj; ++j) {
    const double lo = std::isfinite(info.q_lower[j]) ? info.q_lower[j] : -M_PI;
    const double hi = std::isfinite(info.q_upper[j]) ? info.q_upper[j] : M_PI;
    s.q[info.configurationIndex(j)] = std::uniform_real_distribution<double>(lo, hi)(rng);
    const double tau = std::isfinite(info.tau_max[j]) ? info.tau_max[j] : 100.0;
    s.tau_J[j] = tau * symmetric(rng);
  }
  for (int i = 0; i < info.nv; ++i) s.v[i] = kVelocityScale * symmetric(rng);
  return s;
}

bool isLegJoint(const std::string& name) {
  for (const char* prefix : {"l_hip", "l_knee", "l_ankle", "r_hip", "r_knee", "r_ankle"})
    if (name.rfind(prefix, 0) == 0) return true;
  return false;
}

/// Standing upright with the pelvis kStandingDepth below the nominal standing height
/// (soles slightly in the floor), leg joints perturbed by ±kLegPerturbation, at rest.
State standingState(const ModelInfo& info, double pelvis_height_m, std::mt19937& rng) {
  std::uniform_real_distribution<double> perturbation(-kLegPerturbation, kLegPerturbation);
  State s;
  s.q = info.neutralConfiguration();
  s.q[2] = pelvis_height_m - kStandingDepth;
  for (int j = 0; j < info.nj; ++j) {
    if (!isLegJoint(info.joint_names[j])) continue;
    double& qj = s.q[info.configurationIndex(j)];
    qj = std::min(std::max(qj + perturbation(rng), info.q_lower[j]), info.q_upper[j]);
  }
  s.v = Eigen::VectorXd::Zero(info.nv);
  s.tau_J = Eigen::VectorXd::Zero(info.nj);
  return s;
}

struct Context {
  std::unique_ptr<IDynamicsModel> model;
#if DYNFILTER_BENCH_DART
  std::unique_ptr<IDynamicsModel> skeleton_mass_model;  // A from Skeleton::getMassMatrix
#endif
  int l_foot = -1;
  int r_foot = -1;
  Eigen::Vector3d p_FootSole = Eigen::Vector3d::Zero();  // sole centre, foot frame
  std::vector<State> random_states;
  std::vector<State> standing_states;
  std::size_t standing_contacts_min = 0;
  std::size_t standing_contacts_max = 0;
};

Context makeContext() {
  Context c;
  c.model = dynfilter::loadModel(DYNFILTER_BENCH_BACKEND, sourcePath("models/human_figure.urdf"));
#if DYNFILTER_BENCH_DART
  c.skeleton_mass_model = dynfilter::dart_backend::loadDartModel(
      sourcePath("models/human_figure.urdf"), dynfilter::ModelOptions{},
      dynfilter::dart_backend::DartMassMatrix::kSkeleton);
#endif
  const ModelInfo& info = c.model->info();
  c.l_foot = info.findBody("l_foot");
  c.r_foot = info.findBody("r_foot");
  if (c.l_foot < 0 || c.r_foot < 0) throw std::runtime_error("human figure has no l_foot/r_foot");

  std::ifstream in(sourcePath("models/human_figure.json"));
  if (!in) throw std::runtime_error("cannot open models/human_figure.json");
  const nlohmann::json meta = nlohmann::json::parse(in);
  const auto& centre = meta.at("foot_sole").at("center_in_foot_frame_m");
  c.p_FootSole = Eigen::Vector3d(centre.at(0).get<double>(), centre.at(1).get<double>(),
                                 centre.at(2).get<double>());
  const double pelvis_height_m = meta.at("standing_pelvis_height_m").get<double>();

  std::mt19937 rng(kSeed);
  for (std::size_t k = 0; k < kNumStates; ++k) c.random_states.push_back(randomState(info, rng));
  for (std::size_t k = 0; k < kNumStates; ++k)
    c.standing_states.push_back(standingState(info, pelvis_height_m, rng));

  // How many contacts the standing states produce (reported in the context header).
  ContactList contacts;
  c.standing_contacts_min = contacts.capacity();
  for (const State& s : c.standing_states) {
    c.model->setState(s.q, s.v);
    c.model->detectContacts(contacts);
    c.standing_contacts_min = std::min(c.standing_contacts_min, contacts.size());
    c.standing_contacts_max = std::max(c.standing_contacts_max, contacts.size());
  }
  return c;
}

Context& context() {
  static Context c = makeContext();
  return c;
}

const State& next(const std::vector<State>& states, std::size_t& k) {
  const State& s = states[k];
  k = (k + 1) & (kNumStates - 1);
  return s;
}

void BM_SetState(benchmark::State& st) {
  Context& c = context();
  IDynamicsModel& model = *c.model;
  std::size_t k = 0;
  for (auto _ : st) {
    const State& s = next(c.random_states, k);
    model.setState(s.q, s.v);
    benchmark::DoNotOptimize(model.q().data());
    benchmark::ClobberMemory();
  }
}

void massMatrixLoop(benchmark::State& st, IDynamicsModel& model) {
  Context& c = context();
  Eigen::MatrixXd A(model.nv(), model.nv());
  std::size_t k = 0;
  for (auto _ : st) {
    const State& s = next(c.random_states, k);
    model.setState(s.q, s.v);
    model.massMatrix(A);
    benchmark::DoNotOptimize(A.data());
    benchmark::ClobberMemory();
  }
}

// The backend's default: Σ J_kᵀ M_k J_k over bodies.
void BM_MassMatrix(benchmark::State& st) { massMatrixLoop(st, *context().model); }
#if DYNFILTER_BENCH_DART
// DART's own Skeleton::getMassMatrix, for comparison.
void BM_MassMatrixDartSkeleton(benchmark::State& st) {
  massMatrixLoop(st, *context().skeleton_mass_model);
}
#endif

void BM_Bias(benchmark::State& st) {
  Context& c = context();
  IDynamicsModel& model = *c.model;
  Eigen::VectorXd b(model.nv());
  std::size_t k = 0;
  for (auto _ : st) {
    const State& s = next(c.random_states, k);
    model.setState(s.q, s.v);
    model.bias(b);
    benchmark::DoNotOptimize(b.data());
    benchmark::ClobberMemory();
  }
}

void BM_FootJacobians(benchmark::State& st) {
  Context& c = context();
  IDynamicsModel& model = *c.model;
  dynfilter::Matrix6Xd J_left(6, model.nv());
  dynfilter::Matrix6Xd J_right(6, model.nv());
  std::size_t k = 0;
  for (auto _ : st) {
    const State& s = next(c.random_states, k);
    model.setState(s.q, s.v);
    model.pointJacobian(c.l_foot, c.p_FootSole, J_left);
    model.pointJacobian(c.r_foot, c.p_FootSole, J_right);
    benchmark::DoNotOptimize(J_left.data());
    benchmark::DoNotOptimize(J_right.data());
    benchmark::ClobberMemory();
  }
}

void BM_FootJacobianDotTimesV(benchmark::State& st) {
  Context& c = context();
  IDynamicsModel& model = *c.model;
  dynfilter::Vector6d a_left;
  dynfilter::Vector6d a_right;
  std::size_t k = 0;
  for (auto _ : st) {
    const State& s = next(c.random_states, k);
    model.setState(s.q, s.v);
    a_left = model.pointJacobianDotTimesV(c.l_foot, c.p_FootSole);
    a_right = model.pointJacobianDotTimesV(c.r_foot, c.p_FootSole);
    benchmark::DoNotOptimize(a_left.data());
    benchmark::DoNotOptimize(a_right.data());
    benchmark::ClobberMemory();
  }
}

void BM_ForwardDynamics(benchmark::State& st) {
  Context& c = context();
  IDynamicsModel& model = *c.model;
  Eigen::VectorXd vdot(model.nv());
  std::size_t k = 0;
  for (auto _ : st) {
    const State& s = next(c.random_states, k);
    model.setState(s.q, s.v);
    model.forwardDynamics(s.tau_J, vdot);
    benchmark::DoNotOptimize(vdot.data());
    benchmark::ClobberMemory();
  }
}

void BM_DetectContacts(benchmark::State& st) {
  Context& c = context();
  IDynamicsModel& model = *c.model;
  ContactList contacts;
  std::size_t k = 0;
  double total_contacts = 0.0;
  double total_overflow = 0.0;
  for (auto _ : st) {
    const State& s = next(c.standing_states, k);
    model.setState(s.q, s.v);
    model.detectContacts(contacts);
    benchmark::DoNotOptimize(contacts.begin());
    benchmark::ClobberMemory();
    total_contacts += static_cast<double>(contacts.size());
    total_overflow += static_cast<double>(contacts.overflow());
  }
  st.counters["contacts"] = benchmark::Counter(total_contacts, benchmark::Counter::kAvgIterations);
  st.counters["overflow"] = benchmark::Counter(total_overflow, benchmark::Counter::kAvgIterations);
}

/// The test biped whose soles are meshes (convex hulls, package:// paths): standing 0–4 mm
/// deep with its base tilted by up to ±0.005 rad and turned to any yaw. Its ground contacts
/// come from core/ground_contacts (the hulls' vertices), not the collision engine.
struct MeshSoleContext {
  std::unique_ptr<IDynamicsModel> model;
  std::vector<State> states;
};

MeshSoleContext makeMeshSoleContext() {
  MeshSoleContext c;
  c.model = dynfilter::makeModel(
      DYNFILTER_BENCH_BACKEND,
      dynfilter::urdf::loadUrdfFile(sourcePath("tests/models/mesh_sole_biped.urdf"),
                                    {{sourcePath("tests/models")}, {}}));
  const ModelInfo& info = c.model->info();
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> symmetric(-1.0, 1.0);
  for (std::size_t k = 0; k < kNumStates; ++k) {
    State s;
    s.q = info.neutralConfiguration();
    const Eigen::Quaterniond R(Eigen::AngleAxisd(M_PI * symmetric(rng), Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(0.005 * symmetric(rng), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(0.005 * symmetric(rng), Eigen::Vector3d::UnitX()));
    s.q.segment<4>(3) << R.w(), R.x(), R.y(), R.z();
    s.q[2] = dynfilter::standingBaseHeight(*c.model, s.q) - 0.002 * (1.0 + symmetric(rng));
    s.v = Eigen::VectorXd::Zero(info.nv);
    c.states.push_back(s);
  }
  return c;
}

void BM_DetectContactsMeshSoles(benchmark::State& st) {
  static MeshSoleContext c = makeMeshSoleContext();
  ContactList contacts;
  std::size_t k = 0;
  double total_contacts = 0.0;
  for (auto _ : st) {
    const State& s = next(c.states, k);
    c.model->setState(s.q, s.v);
    c.model->detectContacts(contacts);
    benchmark::DoNotOptimize(contacts.begin());
    benchmark::ClobberMemory();
    total_contacts += static_cast<double>(contacts.size());
  }
  st.counters["contacts"] = benchmark::Counter(total_contacts, benchmark::Counter::kAvgIterations);
}

BENCHMARK(BM_SetState)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_MassMatrix)->Unit(benchmark::kMicrosecond);
#if DYNFILTER_BENCH_DART
BENCHMARK(BM_MassMatrixDartSkeleton)->Unit(benchmark::kMicrosecond);
#endif
BENCHMARK(BM_Bias)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FootJacobians)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FootJacobianDotTimesV)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ForwardDynamics)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DetectContacts)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_DetectContactsMeshSoles)->Unit(benchmark::kMicrosecond);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  try {
    const Context& c = context();
    const ModelInfo& info = c.model->info();
    benchmark::AddCustomContext("model", sourcePath("models/human_figure.urdf"));
    benchmark::AddCustomContext("backend", std::string(c.model->backendName()));
    benchmark::AddCustomContext("nj", std::to_string(info.nj));
    benchmark::AddCustomContext("nv", std::to_string(info.nv));
    benchmark::AddCustomContext("states_cycled", std::to_string(kNumStates));
    benchmark::AddCustomContext("standing_contacts",
                                std::to_string(c.standing_contacts_min) + ".." +
                                    std::to_string(c.standing_contacts_max));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench (%s): setup failed: %s\n", DYNFILTER_BENCH_BACKEND, e.what());
    return 1;
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
