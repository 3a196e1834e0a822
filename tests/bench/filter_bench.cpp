// One filter tick on the human figure standing with both feet flat (two 6-axis face
// links), at 1 kHz, following a physically consistent swaying squat, in paper mode (arg 0)
// and QP mode (arg 1); and the paper tick broken into its parts. Run with repetitions for medians (see BENCHMARKS.md).
#include <benchmark/benchmark.h>

#include <memory>
#include <vector>

#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/paper_solver.hpp"
#include "dynfilter/qp_engines/qp_engines.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/reference_motions.hpp"
#include "support/test_support.hpp"

namespace {

using namespace dynfilter;

struct Setup {
  std::unique_ptr<IDynamicsModel> model;
  std::vector<ReferenceFrame> frames;
  Setup() {
    model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
    frames = test::simulateStandingSway(*model, 1.0, 1e-3);
  }
};

Setup& setup() {
  static Setup s;
  return s;
}

void BM_FilterTick(benchmark::State& state) {
  Setup& s = setup();
  FilterOptions options;
  // qp:0 the paper mode; qp:1 the QP mode with the default engine (DAQP); qp:2 with ProxQP.
  options.mode = state.range(0) >= 1 ? FilterMode::kQp : FilterMode::kPaper;
  if (state.range(0) == 2) options.qp.solver.engine = "proxqp";
  DynamicsFilter filter(*s.model, options, qp_engines::factory(options.qp.solver.engine));
  filter.reset(s.frames.front());
  std::size_t k = 0;
  double solve_s = 0.0, engine_s = 0.0, contacts = 0.0, iterations = 0.0, not_plain = 0.0;
  for (auto _ : state) {
    const FilterOutput& out = filter.step(s.frames[k]);
    benchmark::DoNotOptimize(out.tau_J.data());
    solve_s += out.solve_time_s;
    engine_s += out.qp_solver_time_s;
    contacts += out.num_contacts;
    iterations += out.qp_iterations;
    not_plain += (out.status & (kStatusQpFallback | kStatusQpRelaxed)) != 0 ? 1.0 : 0.0;
    if (++k == s.frames.size()) {
      state.PauseTiming();
      k = 0;
      filter.reset(s.frames.front());
      state.ResumeTiming();
    }
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["solve_us"] = benchmark::Counter(1e6 * solve_s / n);
  state.counters["engine_us"] = benchmark::Counter(1e6 * engine_s / n);
  state.counters["links"] = benchmark::Counter(contacts / n);
  state.counters["qp_iter"] = benchmark::Counter(iterations / n);
  state.counters["relaxed_or_fallback"] = benchmark::Counter(not_plain / n);
}
BENCHMARK(BM_FilterTick)->Arg(0)->Arg(1)->Arg(2)->ArgName("qp")->Unit(benchmark::kMicrosecond);

// The backend work of a tick: two setState calls (reference for P, then the filter's
// state), collision, A, b, and J, J̇v for the two sole links and P.
void BM_TickCollision(benchmark::State& state) {
  Setup& s = setup();
  ContactList contacts(64);
  std::size_t k = 0;
  for (auto _ : state) {
    s.model->setState(s.frames[k].q, s.frames[k].v);
    s.model->detectContacts(contacts);
    benchmark::DoNotOptimize(contacts.size());
    k = (k + 1) % s.frames.size();
  }
}
BENCHMARK(BM_TickCollision)->Unit(benchmark::kMicrosecond);

void BM_TickDynamicsTerms(benchmark::State& state) {
  Setup& s = setup();
  IDynamicsModel& m = *s.model;
  const int nv = m.nv();
  Eigen::MatrixXd A(nv, nv);
  Eigen::VectorXd b(nv);
  Matrix6Xd J(6, nv);
  const int l_foot = m.info().findBody("l_foot"), r_foot = m.info().findBody("r_foot");
  const int torso = m.info().findBody("torso");
  const Eigen::Vector3d sole(0.07, 0.0, -0.068), chest(0.0, 0.0, 0.3);
  std::size_t k = 0;
  for (auto _ : state) {
    const ReferenceFrame& f = s.frames[k];
    m.setState(f.q, f.v);  // reference state: task point P
    m.pointJacobian(torso, chest, J);
    benchmark::DoNotOptimize(m.pointJacobianDotTimesV(torso, chest));
    m.setState(s.frames[(k + 1) % s.frames.size()].q, f.v);  // filter state
    m.massMatrix(A);
    m.bias(b);
    for (int body : {l_foot, r_foot, torso}) {
      m.pointJacobian(body, body == torso ? chest : sole, J);
      benchmark::DoNotOptimize(m.pointJacobianDotTimesV(body, body == torso ? chest : sole));
    }
    benchmark::DoNotOptimize(A.data());
    k = (k + 1) % s.frames.size();
  }
}
BENCHMARK(BM_TickDynamicsTerms)->Unit(benchmark::kMicrosecond);

void BM_TickSolve(benchmark::State& state) {
  // Eq. 21–23 on the real problem of a standing tick (12 constraint rows).
  Setup& s = setup();
  IDynamicsModel& m = *s.model;
  const int nv = m.nv();
  DynamicsFilter filter(m, FilterOptions{});
  filter.reset(s.frames.front());
  for (int k = 0; k < 10; ++k) filter.step(s.frames[static_cast<std::size_t>(k)]);
  Eigen::MatrixXd A(nv, nv), H(12, nv);
  Eigen::VectorXd b(nv), u = Eigen::VectorXd::Zero(12), vdot(nv), tau_C(12), tau_J(m.nj());
  m.massMatrix(A);
  m.bias(b);
  Matrix6Xd J(6, nv);
  m.pointJacobian(m.info().findBody("l_foot"), Eigen::Vector3d(0.07, 0, -0.068), J);
  H.topRows(6) = J;
  m.pointJacobian(m.info().findBody("r_foot"), Eigen::Vector3d(0.07, 0, -0.068), J);
  H.bottomRows(6) = J;
  const Eigen::VectorXd vdot_desired = s.frames[10].vdot;
  PaperSolver solver(nv, 6, 48, PaperSolverOptions{});
  for (auto _ : state) {
    solver.solve(A, b, H, u, vdot_desired, vdot, tau_C, tau_J);
    benchmark::DoNotOptimize(vdot.data());
  }
}
BENCHMARK(BM_TickSolve)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
