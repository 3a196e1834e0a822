#include "dynfilter/proxqp/proxqp_solver.hpp"

#include <stdexcept>
#include <string>

#include <proxsuite/proxqp/dense/dense.hpp>

#include "active_set_step.hpp"

namespace dynfilter::proxqp {
namespace {

namespace pq = proxsuite::proxqp;

// Newton steps of ProxQP's inner loop per outer iteration (its max_iter_in).
constexpr int kNewtonStepsPerIteration = 5;
// Guesses of the active-set step before ProxQP runs (each one linear solve).
constexpr int kActiveSetSteps = 4;

class ProxQpSolver final : public IQpSolver {
 public:
  ProxQpSolver(int n, int n_eq, int n_in, const QpSolverSettings& settings)
      : qp_(n, n_eq, n_in, true),
        settings_(settings),
        l_(n_in),
        u_(n_in),
        x_lower_(n),
        x_upper_(n),
        H_(n, n),
        A_(n_eq, n),
        C_(n_in, n),
        active_set_(n, n_eq, n_in),
        y_(n_eq),
        z_(n_in + n) {
    // ProxQP 0.7.2 leaves these workspace flags uninitialised and its duality-gap check
    // reads them before the first solve sets them (UBSan: "load of value 190 ... bool").
    qp_.work.active_set_up.setConstant(false);
    qp_.work.active_set_low.setConstant(false);
    qp_.work.active_inequalities.setConstant(false);
    qp_.settings.eps_abs = settings.eps_abs;
    qp_.settings.eps_rel = 0.0;
    // The cap: outer (proximal) iterations, and Newton steps within each. With ProxQP's
    // default of 1500 Newton steps per outer iteration single ticks of the CMU clips ran
    // 1500+ steps (15-64 ms); with 5, the cap changes no answer there (BENCHMARKS.md).
    qp_.settings.max_iter = settings.max_iterations;
    qp_.settings.max_iter_in = kNewtonStepsPerIteration;
    qp_.settings.verbose = false;
    qp_.settings.compute_timings = false;
    // Infeasibility tests keep ProxQP's defaults (eps_primal_inf = 1e-4); a false
    // certificate after a warm start is retried once from cold below.
    qp_.settings.initial_guess = pq::InitialGuessStatus::EQUALITY_CONSTRAINED_INITIAL_GUESS;
  }

  QpSolveInfo solve(const DenseQp& p, Eigen::Ref<Eigen::VectorXd> x) override {
    QpSolveInfo info;
    // Warm: first the previous solution's active set (exact KKT check, no ProxQP run when
    // it holds); its answer is ProxQP's next warm start.
    if (initialized_ && qp_.settings.initial_guess == pq::InitialGuessStatus::WARM_START_WITH_PREVIOUS_RESULT) {
      const int steps = active_set_.solve(p, settings_.eps_abs, kActiveSetSteps, x, y_, z_);
      if (steps > 0) {
        qp_.results.x = x;
        qp_.results.y = y_;
        qp_.results.z = z_;
        info.status = QpSolveStatus::kSolved;
        info.iterations = steps;
        info.primal_residual = active_set_.residual();
        return info;
      }
    }
    // ProxQP recognises an unbounded side by its own infinite_bound value (its duality gap
    // and infeasibility tests skip those sides); kQpInfinity is mapped onto it.
    mapInfinity(p.l, l_);
    mapInfinity(p.u, u_);
    mapInfinity(p.x_lower, x_lower_);
    mapInfinity(p.x_upper, x_upper_);
    // ProxQP stores row-major matrices: copies into preallocated row-major members keep
    // Eigen::Ref from making temporaries.
    H_ = p.H;
    A_ = p.A;
    C_ = p.C;
    if (!initialized_) {
      qp_.init(H_, p.g, A_, p.b, C_, l_, u_, x_lower_, x_upper_, true);
      initialized_ = true;
    } else {
      // Ruiz equilibration is recomputed on a cold start (a new contact set) only: ~80 µs
      // a tick on the standing figure; the problem changes little while the contacts stay.
      const bool warm =
          qp_.settings.initial_guess == pq::InitialGuessStatus::WARM_START_WITH_PREVIOUS_RESULT;
      update(p, !warm);
    }
    qp_.solve();
    int iterations = static_cast<int>(qp_.results.info.iter);
    // Measured on the CMU clips: a warm start from a solution of a neighbouring problem
    // sometimes ends in a false infeasibility certificate after 1-3 iterations that a cold
    // start solves. So a warm start that fails — infeasible, or stopped by the cap — is
    // retried once from the equality-constrained guess. (Retrying only on infeasibility
    // left capped warm iterates that the filter rejected: the CMU walk's first second
    // went relaxed with the balance tasks in the objective.) A solve is at most two capped
    // solves.
    const auto status = qp_.results.info.status;
    if (status != pq::QPSolverOutput::PROXQP_SOLVED &&
        qp_.settings.initial_guess == pq::InitialGuessStatus::WARM_START_WITH_PREVIOUS_RESULT) {
      qp_.settings.initial_guess = pq::InitialGuessStatus::EQUALITY_CONSTRAINED_INITIAL_GUESS;
      update(p, true);  // and re-scaled
      qp_.solve();
      iterations += static_cast<int>(qp_.results.info.iter);
    }
    x = qp_.results.x;
    info.iterations = iterations;
    info.primal_residual = qp_.results.info.pri_res;
    switch (qp_.results.info.status) {
      case pq::QPSolverOutput::PROXQP_SOLVED:
        info.status = QpSolveStatus::kSolved;
        break;
      case pq::QPSolverOutput::PROXQP_MAX_ITER_REACHED:
        info.status = QpSolveStatus::kMaxIterations;
        break;
      case pq::QPSolverOutput::PROXQP_DUAL_INFEASIBLE:
        info.status = QpSolveStatus::kDualInfeasible;
        break;
      default:  // primal infeasible, closest feasible, not run
        info.status = QpSolveStatus::kPrimalInfeasible;
        break;
    }
    if (!x.allFinite()) info.status = QpSolveStatus::kNotFinite;
    // Warm-start the next tick from a solution, or from where the cap stopped.
    const bool usable = info.status == QpSolveStatus::kSolved || info.status == QpSolveStatus::kMaxIterations;
    if (usable) active_set_.guessFromMultipliers(p, qp_.results.z);
    else active_set_.clear();
    qp_.settings.initial_guess = settings_.warm_start && usable
                                     ? pq::InitialGuessStatus::WARM_START_WITH_PREVIOUS_RESULT
                                     : pq::InitialGuessStatus::EQUALITY_CONSTRAINED_INITIAL_GUESS;
    return info;
  }

  const char* name() const override { return "proxqp"; }

  void resetWarmStart() override {
    active_set_.clear();
    qp_.settings.initial_guess = pq::InitialGuessStatus::EQUALITY_CONSTRAINED_INITIAL_GUESS;
  }

 private:
  // proxsuite's update() copies the vectors through .eval() temporaries (4 allocations a
  // solve): they are written into its model here instead, and only the matrices and box
  // bounds go through update() (which flags the refactorisation).
  void update(const DenseQp& p, bool precondition) {
    qp_.model.g = p.g;
    qp_.model.b = p.b;
    qp_.model.l = l_;
    qp_.model.u = u_;
    qp_.update(H_, std::nullopt, A_, std::nullopt, C_, std::nullopt, std::nullopt, x_lower_, x_upper_,
               precondition);
  }

  static void mapInfinity(const Eigen::VectorXd& in, Eigen::VectorXd& out) {
    const double inf = proxsuite::helpers::infinite_bound<double>::value();
    for (Eigen::Index i = 0; i < in.size(); ++i)
      out[i] = in[i] >= kQpInfinity ? inf : in[i] <= -kQpInfinity ? -inf : in[i];
  }

  pq::dense::QP<double> qp_;
  QpSolverSettings settings_;
  bool initialized_ = false;
  Eigen::VectorXd l_, u_, x_lower_, x_upper_;
  using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  RowMajorMatrix H_, A_, C_;
  qp_active_set::ActiveSetStep active_set_;
  Eigen::VectorXd y_, z_;  // multipliers of the active-set step
};

}  // namespace

std::unique_ptr<IQpSolver> makeSolver(int n, int n_eq, int n_in, const QpSolverSettings& settings) {
  if (n <= 0 || n_eq < 0 || n_in < 0)
    throw std::invalid_argument("proxqp: invalid problem dimensions n=" + std::to_string(n) +
                                " n_eq=" + std::to_string(n_eq) + " n_in=" + std::to_string(n_in));
  if (!(settings.eps_abs > 0.0) || settings.max_iterations < 1)
    throw std::invalid_argument("proxqp: eps_abs must be > 0 and max_iterations >= 1");
  return std::make_unique<ProxQpSolver>(n, n_eq, n_in, settings);
}

QpSolverFactory factory() {
  return [](int n, int n_eq, int n_in, const QpSolverSettings& settings) {
    return makeSolver(n, n_eq, n_in, settings);
  };
}

}  // namespace dynfilter::proxqp
