#include "dynfilter/daqp/daqp_solver.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

extern "C" {
#include <api.h>
#include <utils.h>
}

#include "active_set_step.hpp"

namespace dynfilter::daqp {
namespace {

// DAQP's row-major storage of the general rows [A; C].
using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Guesses of the active-set step before DAQP runs (each one linear solve).
constexpr int kActiveSetSteps = 4;

double mapBound(double value) {
  if (value >= kQpInfinity) return DAQP_INF;
  if (value <= -kQpInfinity) return -DAQP_INF;
  return value;
}

class DaqpSolver final : public IQpSolver {
 public:
  DaqpSolver(int n, int n_eq, int n_in, const QpSolverSettings& settings)
      : n_(n),
        n_eq_(n_eq),
        n_in_(n_in),
        m_(n + n_eq + n_in),
        eps_abs_(settings.eps_abs),
        warm_start_(settings.warm_start),
        H_(n, n),
        f_(n),
        rows_(n_eq + n_in, n),
        upper_(m_),
        lower_(m_),
        sense_(static_cast<std::size_t>(m_), 0),
        solved_sense_(static_cast<std::size_t>(m_), 0),
        lambda_(m_),
        active_set_(n, n_eq, n_in),
        y_(n_eq),
        z_(n_in + n) {
    daqp_default_settings(&settings_);
    // Equality rows are in the working set, so Eq. 12 holds to round-off; the primal
    // tolerance applies to the inequalities (N, m/s²), like ProxQP's eps_abs.
    settings_.primal_tol = settings.eps_abs;
    // The equality rows stay rows: their elimination allocates on every update.
    settings_.eq_reduction = DAQP_EQ_REDUCTION_OFF;
    problem_.n = n;
    problem_.m = m_;
    problem_.ms = n;
    problem_.H = H_.data();
    problem_.f = f_.data();
    problem_.A = rows_.data();
    problem_.bupper = upper_.data();
    problem_.blower = lower_.data();
    problem_.sense = sense_.data();
    problem_.break_points = nullptr;
    problem_.nh = 0;
    problem_.problem_type = 0;
    resetSense();
  }

  ~DaqpSolver() override {
    if (set_up_) {
      work_.settings = nullptr;  // ours, not DAQP's
      free_daqp_workspace(&work_);
      free_daqp_ldp(&work_);
    }
  }

  DaqpSolver(const DaqpSolver&) = delete;
  DaqpSolver& operator=(const DaqpSolver&) = delete;

  QpSolveInfo solve(const DenseQp& p, Eigen::Ref<Eigen::VectorXd> x) override {
    QpSolveInfo info;
    const bool was_loaded = loaded_;
    loaded_ = false;
    // Warm: the last answer's active set first (one linear solve, every KKT condition
    // checked); DAQP runs only when it fails.
    const int limit = std::exchange(next_limit_, kMaxWorkingSetChanges);
    if (const int steps = active_set_.solve(p, eps_abs_, kActiveSetSteps, x, y_, z_); steps > 0) {
      info.iterations = steps;
      info.primal_residual = active_set_.residual();
      return info;
    }
    // DAQP's factor of H and its v = R⁻ᵀ f stay valid while H and g do (a re-solve whose
    // rows changed, e.g. a relaxation): then only the rows' images are formed again.
    const bool same_objective = was_loaded && H_.cwiseEqual(p.H).all() && f_.cwiseEqual(p.g).all();
    if (!same_objective) {
      H_ = p.H;
      f_ = p.g;
    }
    rows_.topRows(n_eq_) = p.A;
    rows_.bottomRows(n_in_) = p.C;
    if (!H_.allFinite() || !f_.allFinite() || !rows_.allFinite()) {
      info.status = QpSolveStatus::kNotFinite;
      return info;
    }
    if (same_objective) return run(p, x, DAQP_UPDATE_M | DAQP_UPDATE_d, limit);
    return run(p, x, DAQP_UPDATE_Rinv | DAQP_UPDATE_M | DAQP_UPDATE_v | DAQP_UPDATE_d, limit);
  }

  QpSolveInfo resolveWithNewBounds(const DenseQp& p, Eigen::Ref<Eigen::VectorXd> x) override {
    if (!restart_) resetWarmStart();
    if (!loaded_) return solve(p, x);
    // DAQP holds the factor of H and the rows times its inverse from the last solve: only
    // the bounds' images need forming again (saves two O(n³) steps on a relaxed tick).
    return run(p, x, DAQP_UPDATE_d, std::exchange(next_limit_, kMaxWorkingSetChanges));
  }

  void resetWarmStart() override {
    cold_ = true;
    restart_ = false;
    active_set_.clear();
  }

  void restartFromLastSolution() override {
    active_set_.clear();
    restart_ = warm_start_ && solved_sense_valid_;  // without warm starts, cold as every solve
    cold_ = !restart_;
  }

  void limitNextSolve(double share) override {
    next_limit_ = std::clamp(static_cast<int>(share * kMaxWorkingSetChanges), 1, kMaxWorkingSetChanges);
  }

  const char* name() const override { return "daqp"; }

 private:
  // Copies the bounds, updates DAQP's problem by @p mask and solves in at most @p limit
  // working-set changes.
  QpSolveInfo run(const DenseQp& p, Eigen::Ref<Eigen::VectorXd> x, int mask, int limit) {
    QpSolveInfo info;
    for (int i = 0; i < n_; ++i) {
      upper_[i] = mapBound(p.x_upper[i]);
      lower_[i] = mapBound(p.x_lower[i]);
    }
    for (int i = 0; i < n_eq_; ++i) upper_[n_ + i] = lower_[n_ + i] = p.b[i];
    for (int i = 0; i < n_in_; ++i) {
      upper_[n_ + n_eq_ + i] = mapBound(p.u[i]);
      lower_[n_ + n_eq_ + i] = mapBound(p.l[i]);
    }

    int flag = 0;
    if (!set_up_) {
      work_ = DAQPWorkspace{};
      work_.settings = &settings_;
      flag = setup_daqp(&problem_, &work_, nullptr);
      set_up_ = flag >= 0;  // a failed setup has freed its workspace: set up again next time
    } else {
      // Hot start: the working set of the last solve stays unless the caller reset it.
      if (restart_) {
        // The equality rows as always; of the rest, the side each was active on, unless
        // that side is now unbounded (DAQP's own markers, e.g. of zero rows, are dropped).
        resetSense();
        for (int i = 0; i < m_; ++i) {
          if (i >= n_ && i < n_ + n_eq_) continue;
          const int s = DAQP_ZERO_ROW_SENSE(solved_sense_[static_cast<std::size_t>(i)]);
          const bool lower_side = (s & DAQP_LOWER) != 0;
          if ((s & DAQP_ACTIVE) && std::abs(lower_side ? lower_[i] : upper_[i]) < DAQP_INF)
            sense_[static_cast<std::size_t>(i)] = s & (DAQP_ACTIVE | DAQP_LOWER);
        }
        mask |= DAQP_UPDATE_sense;
      } else if (cold_) {
        resetSense();
        mask |= DAQP_UPDATE_sense;
      }
      flag = daqp_update_ldp(mask, &work_, &problem_);
    }
    cold_ = !warm_start_;
    restart_ = false;
    if (flag < 0) {
      // Not set up (e.g. H not positive definite, or bounds that cross): start cold next.
      cold_ = true;
      info.status = flag == DAQP_EXIT_INFEASIBLE ? QpSolveStatus::kPrimalInfeasible
                                                 : QpSolveStatus::kNotFinite;
      return info;
    }
    loaded_ = true;
    DAQPResult result{};
    result.x = x.data();
    result.lam = lambda_.data();
    settings_.iter_limit = limit;
    daqp_solve(&result, &work_);
    info.iterations = result.iter;
    switch (result.exitflag) {
      case DAQP_EXIT_OPTIMAL:
      case DAQP_EXIT_SOFT_OPTIMAL:
      case DAQP_EXIT_OPTIMAL_INEXACT:
        info.status = QpSolveStatus::kSolved;
        break;
      case DAQP_EXIT_ITERLIMIT:
      case DAQP_EXIT_TIMELIMIT:
      case DAQP_EXIT_CYCLE:
        info.status = QpSolveStatus::kMaxIterations;
        cold_ = true;
        break;
      case DAQP_EXIT_UNBOUNDED:
      case DAQP_EXIT_NONCONVEX:
        info.status = QpSolveStatus::kDualInfeasible;
        cold_ = true;
        break;
      default:  // infeasible, an overdetermined start
        info.status = QpSolveStatus::kPrimalInfeasible;
        cold_ = true;
        break;
    }
    if (!x.allFinite()) {
      info.status = QpSolveStatus::kNotFinite;
      cold_ = true;
    }
    if (info.status == QpSolveStatus::kSolved) {
      std::copy(work_.sense, work_.sense + m_, solved_sense_.begin());
      solved_sense_valid_ = true;
    }
    if (info.status == QpSolveStatus::kSolved && warm_start_) {
      // DAQP's multipliers (box, equalities, rows; > 0 at an upper bound) as the next guess.
      z_.head(n_in_) = lambda_.tail(n_in_);
      z_.tail(n_) = lambda_.head(n_);
      active_set_.guessFromMultipliers(p, z_);
    } else {
      active_set_.clear();
    }
    info.primal_residual = primalResidual(p, x);
    return info;
  }

  void resetSense() {
    for (int i = 0; i < m_; ++i)
      sense_[static_cast<std::size_t>(i)] =
          i >= n_ && i < n_ + n_eq_ ? DAQP_ACTIVE + DAQP_IMMUTABLE : 0;
  }

  double primalResidual(const DenseQp& p, const Eigen::Ref<const Eigen::VectorXd>& x) const {
    double r = 0.0;
    for (int i = 0; i < n_eq_; ++i) r = std::max(r, std::abs(p.A.row(i).dot(x) - p.b[i]));
    for (int i = 0; i < n_in_; ++i) {
      const double cx = p.C.row(i).dot(x);
      r = std::max({r, cx - p.u[i], p.l[i] - cx});
    }
    for (int i = 0; i < n_; ++i) r = std::max({r, x[i] - p.x_upper[i], p.x_lower[i] - x[i]});
    return r;
  }

  int n_, n_eq_, n_in_, m_;
  double eps_abs_;
  bool warm_start_;
  bool set_up_ = false;
  bool cold_ = true;
  bool loaded_ = false;  // DAQP's workspace holds H, g and the rows of the last solve()
  bool restart_ = false;  // the next run starts from solved_sense_
  bool solved_sense_valid_ = false;
  int next_limit_ = kMaxWorkingSetChanges;  // DAQP's iteration cap for the next run
  RowMajorMatrix H_;
  Eigen::VectorXd f_;
  RowMajorMatrix rows_;
  Eigen::VectorXd upper_, lower_;
  std::vector<int> sense_;
  std::vector<int> solved_sense_;  // DAQP's working-set flags after the last success (m)
  Eigen::VectorXd lambda_;
  qp_active_set::ActiveSetStep active_set_;
  Eigen::VectorXd y_, z_;  // multipliers of the active-set step
  DAQPSettings settings_{};
  DAQPProblem problem_{};
  DAQPWorkspace work_{};
};

}  // namespace

std::unique_ptr<IQpSolver> makeSolver(int n, int n_eq, int n_in, const QpSolverSettings& settings) {
  if (n <= 0 || n_eq < 0 || n_in < 0)
    throw std::invalid_argument("daqp: invalid problem dimensions n=" + std::to_string(n) +
                                " n_eq=" + std::to_string(n_eq) + " n_in=" + std::to_string(n_in));
  if (!(settings.eps_abs > 0.0))
    throw std::invalid_argument("daqp: eps_abs must be > 0");
  return std::make_unique<DaqpSolver>(n, n_eq, n_in, settings);
}

QpSolverFactory factory() {
  return [](int n, int n_eq, int n_in, const QpSolverSettings& settings) {
    return makeSolver(n, n_eq, n_in, settings);
  };
}

}  // namespace dynfilter::daqp
