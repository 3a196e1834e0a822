#pragma once
/// @file
/// A dense convex QP and the interface of the solver that the filter's QP mode calls.
/// The core only formulates problems; a solver library implements IQpSolver (one per
/// QP engine, see solvers/), so the core depends on Eigen alone.
///
///   minimise    ½ xᵀ H x + gᵀ x
///   subject to  A x = b,   l ≤ C x ≤ u,   x_lower ≤ x ≤ x_upper
///
/// Unbounded sides are ±kQpInfinity. Dimensions are fixed when the problem is made:
/// a caller with fewer unknowns or rows pads them (identity rows on unused unknowns,
/// unbounded unused inequality rows).

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include <Eigen/Core>

namespace dynfilter {

/// Bound value meaning "no bound" (finite, so that every solver accepts it).
constexpr double kQpInfinity = 1e20;

struct DenseQp {
  Eigen::MatrixXd H;  ///< n × n, symmetric positive (semi-)definite
  Eigen::VectorXd g;  ///< n
  Eigen::MatrixXd A;  ///< n_eq × n
  Eigen::VectorXd b;  ///< n_eq
  Eigen::MatrixXd C;  ///< n_in × n
  Eigen::VectorXd l, u;                ///< n_in
  Eigen::VectorXd x_lower, x_upper;    ///< n

  DenseQp() = default;
  DenseQp(int n, int n_eq, int n_in);
  int n() const { return static_cast<int>(H.rows()); }
  int nEq() const { return static_cast<int>(A.rows()); }
  int nIn() const { return static_cast<int>(C.rows()); }
};

/// Settings every QP engine understands.
struct QpSolverSettings {
  /// Absolute tolerance on the primal and dual residuals. 1e-7 (N, m/s²) keeps Eq. 12
  /// within 1e-8 of the body weight; 1e-9 took 25 iterations instead of 2 (BENCHMARKS.md).
  double eps_abs = 1e-7;
  /// ProxQP's per-solve cap: outer (proximal) iterations, each of at most a few Newton
  /// steps (5), so that a solve's work is bounded. A standing tick needs 2; on the CMU
  /// clips 10 leaves every answer acceptable (an iterate stopped by the cap is used when
  /// it passes the constraint check; FilterOutput status kStatusQpIterationLimit). DAQP
  /// has its own cap on working-set changes (daqp::kMaxWorkingSetChanges).
  int max_iterations = 10;
  bool warm_start = true;  ///< start from the previous solution of the same instance
  /// The engine that tools and bindings make for the filter's QP mode, by name
  /// (solvers/engines: "daqp", "proxqp"). The filter itself solves with the factory it
  /// is given; this name only tells the programs which factory to give.
  std::string engine = "daqp";
};

enum class QpSolveStatus : int {
  kSolved = 0,
  kMaxIterations = 1,
  kPrimalInfeasible = 2,
  kDualInfeasible = 3,
  kNotFinite = 4,  ///< the solution or the problem data had NaN/Inf
};

/// Returns "solved", "max_iterations", ...; a static string.
const char* toString(QpSolveStatus status);

struct QpSolveInfo {
  QpSolveStatus status = QpSolveStatus::kSolved;
  int iterations = 0;
  double primal_residual = 0.0;  ///< max violation of the constraints at x
};

/// One QP engine instance for problems of fixed dimensions. solve() must not allocate
/// after the first call (the filter's per-tick path runs it).
class IQpSolver {
 public:
  virtual ~IQpSolver() = default;
  /// Solves @p problem (same dimensions on every call); writes x (dim n) even on failure
  /// (the engine's last iterate).
  virtual QpSolveInfo solve(const DenseQp& problem, Eigen::Ref<Eigen::VectorXd> x) = 0;
  /// Solves @p problem again, cold (or as restartFromLastSolution() just asked), after only
  /// its bounds (l, u, x_lower, x_upper) changed
  /// since the last call to solve(): H, g, A, b and C must be those of that call. An engine
  /// may then keep its factorisations of H and of the rows; the default solves from scratch.
  virtual QpSolveInfo resolveWithNewBounds(const DenseQp& problem, Eigen::Ref<Eigen::VectorXd> x) {
    resetWarmStart();
    return solve(problem, x);
  }
  /// The next solve starts cold (the problem's structure changed).
  virtual void resetWarmStart() = 0;
  /// The next solve starts from the working set of this engine's last solve that succeeded,
  /// without the rows whose bound on the active side is now unbounded: a re-solve of a
  /// problem that changed a little (a relaxation). Engines without a working set start cold.
  virtual void restartFromLastSolution() { resetWarmStart(); }
  /// The next solve or re-solve stops after @p share ∈ (0, 1] of this engine's cap on its
  /// iterations (QpSolveStatus::kMaxIterations): an attempt that a fallback follows when it
  /// fails. Later solves have the whole cap again. Engines without such a cap ignore it.
  virtual void limitNextSolve(double share) { (void)share; }
  /// Engine name, e.g. "proxqp".
  virtual const char* name() const = 0;
};

/// Makes an engine for problems with n unknowns, n_eq equalities and n_in inequalities.
/// Called at filter construction only; throws on failure, never returns null.
using QpSolverFactory = std::function<std::unique_ptr<IQpSolver>(
    int n, int n_eq, int n_in, const QpSolverSettings& settings)>;

}  // namespace dynfilter
