// The DAQP adapter (dynfilter::daqp::makeSolver): small QPs with answers worked out from the
// KKT conditions, random QPs against ProxQP, and the engine registry (qp_engines).
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include <Eigen/LU>
#include <gtest/gtest.h>

#include "dynfilter/core/qp_solver.hpp"
#include "dynfilter/daqp/daqp_solver.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"
#include "dynfilter/qp_engines/qp_engines.hpp"

#include "filter/qp_test_problems.hpp"

namespace dynfilter {
namespace {

using test::projectionProblem;
using test::tightSettings;

// A random strictly convex QP that drifts like the filter's ticks: H = L Lᵀ / n + 0.1 I with
// a random L, random rows A, C and vectors g, b; drift() moves L and g by random steps.
// Bounds are the caller's (boxAndRows() sets symmetric ones).
struct DriftingQp {
  DriftingQp(int n, int n_eq, int n_in, unsigned seed) : rng(seed), qp(n, n_eq, n_in) {
    L = Eigen::MatrixXd::NullaryExpr(n, n, [&] { return draw(); });
    qp.A = Eigen::MatrixXd::NullaryExpr(n_eq, n, [&] { return draw(); });
    qp.C = Eigen::MatrixXd::NullaryExpr(n_in, n, [&] { return draw(); });
    qp.g = 3.0 * Eigen::VectorXd::NullaryExpr(n, [&] { return draw(); });
    qp.b = 0.5 * Eigen::VectorXd::NullaryExpr(n_eq, [&] { return draw(); });
  }
  void drift(double factor_step, double g_step) {
    const int n = qp.n();
    L += factor_step * Eigen::MatrixXd::NullaryExpr(n, n, [&] { return draw(); });
    qp.H = L * L.transpose() / n + 0.1 * Eigen::MatrixXd::Identity(n, n);
    qp.g += g_step * Eigen::VectorXd::NullaryExpr(n, [&] { return draw(); });
  }
  // Every unknown within ±box, every row of C within ±row.
  void boxAndRows(double box, double row) {
    qp.x_lower.setConstant(-box);
    qp.x_upper.setConstant(box);
    qp.l.setConstant(-row);
    qp.u.setConstant(row);
  }
  double draw() { return normal(rng); }
  double uniform() { return unit(rng); }

  std::mt19937 rng;
  std::normal_distribution<double> normal{0.0, 1.0};
  std::uniform_real_distribution<double> unit{0.0, 1.0};
  DenseQp qp;
  Eigen::MatrixXd L;
};

TEST(DaqpAdapter, ProjectionWithActiveBoxAndRowMatchesKktToRoundOff) {
  auto solver = daqp::makeSolver(3, 1, 2, QpSolverSettings{});
  EXPECT_STREQ(solver->name(), "daqp");
  Eigen::VectorXd x = Eigen::VectorXd::Constant(3, 99.0);
  const QpSolveInfo info = solver->solve(projectionProblem(), x);
  ASSERT_EQ(info.status, QpSolveStatus::kSolved) << toString(info.status);
  // An active-set answer solves the KKT system of its working set exactly.
  EXPECT_NEAR(x[0], 1.0, 1e-13);
  EXPECT_NEAR(x[1], 0.25, 1e-13);
  EXPECT_NEAR(x[2], -0.25, 1e-13);
  EXPECT_LE(info.primal_residual, 1e-13);
}

TEST(DaqpAdapter, HotStartsFollowChangedDataAndResetStartsCold) {
  auto solver = daqp::makeSolver(3, 1, 2, QpSolverSettings{});
  DenseQp qp = projectionProblem();
  Eigen::VectorXd x(3);
  const QpSolveInfo cold = solver->solve(qp, x);
  ASSERT_EQ(cold.status, QpSolveStatus::kSolved);
  // Same working set, box at 0.9: x = (0.9, 0.35, −0.25) (λ = −0.65; multipliers 0.45, 0.4).
  qp.x_upper[0] = 0.9;
  const QpSolveInfo hot = solver->solve(qp, x);
  ASSERT_EQ(hot.status, QpSolveStatus::kSolved);
  EXPECT_LE(hot.iterations, cold.iterations);
  EXPECT_NEAR(x[0], 0.9, 1e-13);
  EXPECT_NEAR(x[1], 0.35, 1e-13);
  EXPECT_NEAR(x[2], -0.25, 1e-13);
  // Both guesses wrong: c = (2, 1, 1.5) projects onto the plane at (5/6, −1/6, 1/3), inside
  // both bounds; the hot start must leave the working set.
  qp.g = -Eigen::Vector3d(2.0, 1.0, 1.5);
  ASSERT_EQ(solver->solve(qp, x).status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[0], 5.0 / 6.0, 1e-12);
  EXPECT_NEAR(x[1], -1.0 / 6.0, 1e-12);
  EXPECT_NEAR(x[2], 1.0 / 3.0, 1e-12);
  solver->resetWarmStart();
  qp = projectionProblem();
  ASSERT_EQ(solver->solve(qp, x).status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[1], 0.25, 1e-13);
}

TEST(DaqpAdapter, WithoutWarmStartEverySolveStartsCold) {
  QpSolverSettings cold;
  cold.warm_start = false;
  auto solver = daqp::makeSolver(3, 1, 2, cold);
  Eigen::VectorXd x(3);
  const QpSolveInfo first = solver->solve(projectionProblem(), x);
  const QpSolveInfo second = solver->solve(projectionProblem(), x);
  ASSERT_EQ(second.status, QpSolveStatus::kSolved);
  EXPECT_EQ(second.iterations, first.iterations);
  EXPECT_GT(second.iterations, 1) << "two bounds to add from the equality-only start";
  EXPECT_NEAR(x[1], 0.25, 1e-13);
  solver->restartFromLastSolution();  // a restart is a warm start: cold here too
  EXPECT_EQ(solver->solve(projectionProblem(), x).iterations, first.iterations);
}

TEST(DaqpAdapter, InfiniteBoundsAreUnbounded) {
  // Only Σx = 1 binds: the projection (4/3, 1/3, −2/3). A bound taken as the finite 1e20
  // would still give this answer but scale DAQP's LDP; it must be mapped to DAQP_INF.
  auto solver = daqp::makeSolver(3, 1, 2, QpSolverSettings{});
  DenseQp qp = projectionProblem();
  qp.l.setConstant(-kQpInfinity);
  qp.u.setConstant(kQpInfinity);
  qp.x_upper.setConstant(kQpInfinity);
  Eigen::VectorXd x(3);
  ASSERT_EQ(solver->solve(qp, x).status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[0], 4.0 / 3.0, 1e-13);
  EXPECT_NEAR(x[1], 1.0 / 3.0, 1e-13);
  EXPECT_NEAR(x[2], -2.0 / 3.0, 1e-13);
}

TEST(DaqpAdapter, InfeasibleProblemIsNotReportedSolved) {
  // x ≥ 1 (box) and x ≤ 0 (row of C).
  auto solver = daqp::makeSolver(1, 0, 1, QpSolverSettings{});
  DenseQp qp = test::boxAgainstRowProblem();
  Eigen::VectorXd x(1);
  EXPECT_EQ(solver->solve(qp, x).status, QpSolveStatus::kPrimalInfeasible);
  EXPECT_NE(solver->solve(qp, x).status, QpSolveStatus::kSolved);
  // A feasible problem on the same instance afterwards is solved: x ≤ 2 instead.
  qp.u[0] = 2.0;
  ASSERT_EQ(solver->solve(qp, x).status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[0], 1.0, 1e-13);
}

TEST(DaqpAdapter, ABoundsOnlyResolveAfterAnInfeasibleSolveGivesTheRelaxedAnswer) {
  // The filter's relaxation: x ≥ 1 (box) against x ≤ 0 (row) is infeasible. With g = 1,
  // dropping the box leaves min ½x² + x s.t. x ≤ 0 → x = −1; the box −0.75 ≤ x ≤ −0.5 then
  // binds below: x = −0.75.
  auto solver = daqp::makeSolver(1, 0, 1, QpSolverSettings{});
  DenseQp qp = test::boxAgainstRowProblem();
  qp.g[0] = 1.0;  // pulls x towards −1 so that a wrong stale bound would show
  Eigen::VectorXd x(1);
  ASSERT_EQ(solver->solve(qp, x).status, QpSolveStatus::kPrimalInfeasible);
  qp.x_lower[0] = -kQpInfinity;
  ASSERT_EQ(solver->resolveWithNewBounds(qp, x).status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[0], -1.0, 1e-13) << "min ½x² + x with x ≤ 0";
  qp.x_upper[0] = -0.5;
  qp.x_lower[0] = -0.75;
  ASSERT_EQ(solver->resolveWithNewBounds(qp, x).status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[0], -0.75, 1e-13);
}

// Random drifting QPs: after each full solve, its bounds are moved (some dropped, some
// tightened) and re-solved with resolveWithNewBounds; the answer must equal a new instance's
// cold solve of the same problem, whether the full solve ran DAQP or was answered by the
// warm active-set guess (then the instance holds no factorisation of this problem).
TEST(DaqpAdapter, BoundsOnlyResolvesEqualColdSolvesOfTheSameProblem) {
  const int n = 20, n_eq = 4, n_in = 24;
  DriftingQp drifting(n, n_eq, n_in, 5);
  DenseQp& qp = drifting.qp;
  auto solver = daqp::makeSolver(n, n_eq, n_in, QpSolverSettings{});
  int resolved = 0, bounds_binding = 0;
  for (int k = 0; k < 30; ++k) {
    drifting.drift(0.02, 0.1);
    drifting.boxAndRows(0.6, 1.0);
    Eigen::VectorXd x(n), x_cold(n);
    solver->solve(qp, x);
    // Every third tick moves g a little and solves again: the warm guess answers that in one
    // step, so DAQP itself still holds the g before the move.
    if (k % 3 == 2) {
      qp.g += 1e-4 * Eigen::VectorXd::NullaryExpr(n, [&] { return drifting.draw(); });
      EXPECT_EQ(solver->solve(qp, x).iterations, 1) << "tick " << k;
    }
    for (int i = 0; i < n; ++i) {
      const double r = drifting.uniform();
      if (r < 0.3) {
        qp.x_lower[i] = -kQpInfinity;
        qp.x_upper[i] = kQpInfinity;
      } else if (r < 0.5) {
        qp.x_upper[i] = 0.3;
      }
    }
    for (int i = 0; i < n_in; ++i) {
      if (drifting.uniform() < 0.3) {
        qp.l[i] = -kQpInfinity;
        qp.u[i] = kQpInfinity;
      }
    }
    const QpSolveInfo info = solver->resolveWithNewBounds(qp, x);
    auto cold = daqp::makeSolver(n, n_eq, n_in, QpSolverSettings{});
    const QpSolveInfo cold_info = cold->solve(qp, x_cold);
    ASSERT_EQ(info.status, cold_info.status) << "tick " << k;
    if (info.status != QpSolveStatus::kSolved) continue;
    ++resolved;
    EXPECT_LT((x - x_cold).cwiseAbs().maxCoeff(), 1e-9) << "tick " << k;
    for (int i = 0; i < n; ++i) bounds_binding += std::abs(x[i] - 0.3) < 1e-9 ? 1 : 0;
  }
  EXPECT_GT(resolved, 20);
  EXPECT_GT(bounds_binding, 10) << "the moved bounds must bind for the comparison to mean anything";
}

TEST(DaqpAdapter, ARestartHonoursARowThatWasZeroInTheLastSolvedProblem) {
  // The filter's tick: the last answer had a zero row (a link slot not in use), this tick's
  // full problem uses the row and is infeasible (x ≥ 1 against x₀ + x₁ ≤ 1), the relaxation
  // drops the box and restarts from the last answer: min ½‖x − (2, 2)‖² s.t. x₀ + x₁ ≤ 1
  // → (0.5, 0.5). DAQP marks a zero row as immutable in its working-set flags; a restart that
  // copied that mark would ignore the row and answer (2, 2).
  auto solver = daqp::makeSolver(2, 0, 1, QpSolverSettings{});
  DenseQp qp(2, 0, 1);
  qp.H.setIdentity();
  qp.g = -Eigen::Vector2d(2.0, 2.0);
  qp.C.setZero();
  qp.l[0] = -1.0;
  qp.u[0] = 1.0;
  qp.x_lower.setConstant(-10.0);
  qp.x_upper.setConstant(10.0);
  Eigen::VectorXd x(2);
  ASSERT_EQ(solver->solve(qp, x).status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[0], 2.0, 1e-13);
  qp.C << 1.0, 1.0;
  qp.l[0] = -kQpInfinity;
  qp.x_lower.setConstant(1.0);
  ASSERT_EQ(solver->solve(qp, x).status, QpSolveStatus::kPrimalInfeasible);
  qp.x_lower.setConstant(-kQpInfinity);
  solver->restartFromLastSolution();
  ASSERT_EQ(solver->resolveWithNewBounds(qp, x).status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[0], 0.5, 1e-12);
  EXPECT_NEAR(x[1], 0.5, 1e-12);
}

// The filter's relaxations restart from the last answer's working set: on a drifting
// sequence, each tick's problem changes a little, a tightened copy fails, and the relaxed
// copy (some bounds dropped, one of them the side the last answer held) is restarted. The
// answers equal a new instance's cold solves, in fewer working-set changes than cold
// re-solves of the same instance need.
TEST(DaqpAdapter, RestartsFromTheLastSolutionGiveTheColdAnswersInFewerChanges) {
  const int n = 20, n_eq = 4, n_in = 24;
  DriftingQp drifting(n, n_eq, n_in, 11);
  DenseQp& qp = drifting.qp;
  auto restarted = daqp::makeSolver(n, n_eq, n_in, QpSolverSettings{});
  auto cold = daqp::makeSolver(n, n_eq, n_in, QpSolverSettings{});
  int compared = 0, restart_changes = 0, cold_changes = 0, held_side_dropped = 0;
  for (int k = 0; k < 40; ++k) {
    drifting.drift(0.01, 0.05);
    drifting.boxAndRows(0.6, 1.0);
    Eigen::VectorXd x(n), x_cold(n), x_fresh(n);
    if (restarted->solve(qp, x).status != QpSolveStatus::kSolved) continue;
    const Eigen::VectorXd x_last = x;
    // The tick's full problem: infeasible (x₀ pushed past the rows' reach).
    DenseQp tight = qp;
    tight.x_lower[0] = tight.x_upper[0] = 1e3;
    restarted->solve(tight, x);
    cold->solve(tight, x_cold);
    // The relaxation: the box dropped on a third of the unknowns, among them every one the
    // last answer held at a bound.
    DenseQp relaxed = qp;
    for (int i = 0; i < n; ++i) {
      const bool held = std::abs(std::abs(x_last[i]) - 0.6) < 1e-9;
      if (held || drifting.uniform() < 0.3) {
        relaxed.x_lower[i] = -kQpInfinity;
        relaxed.x_upper[i] = kQpInfinity;
        held_side_dropped += held ? 1 : 0;
      }
    }
    restarted->restartFromLastSolution();
    const QpSolveInfo info = restarted->resolveWithNewBounds(relaxed, x);
    cold->resetWarmStart();
    const QpSolveInfo cold_info = cold->resolveWithNewBounds(relaxed, x_cold);
    auto fresh = daqp::makeSolver(n, n_eq, n_in, QpSolverSettings{});
    ASSERT_EQ(info.status, fresh->solve(relaxed, x_fresh).status) << "tick " << k;
    ASSERT_EQ(cold_info.status, info.status) << "tick " << k;
    if (info.status != QpSolveStatus::kSolved) continue;
    ++compared;
    restart_changes += info.iterations;
    cold_changes += cold_info.iterations;
    EXPECT_LT((x - x_fresh).cwiseAbs().maxCoeff(), 1e-9) << "tick " << k;
    EXPECT_LT((x_cold - x_fresh).cwiseAbs().maxCoeff(), 1e-9) << "tick " << k;
  }
  EXPECT_GT(compared, 30);
  EXPECT_GT(held_side_dropped, 10) << "the restart must meet rows whose held side is gone";
  EXPECT_LT(restart_changes, cold_changes) << "restarts " << restart_changes << ", cold " << cold_changes;
  RecordProperty("restart_changes", restart_changes);
  RecordProperty("cold_changes", cold_changes);
}

TEST(DaqpAdapter, ReSolvesWithNewRowsOrANewObjectiveGiveTheFreshAnswers) {
  // The adapter keeps DAQP's factor of H when H and g are those of the last solve (a
  // re-solve whose rows changed: a pivot, a relaxation): the rows' images must still be
  // formed again, and any change of H, however small, must be factorised.
  const int n = 16, n_eq = 3, n_in = 20;
  DriftingQp drifting(n, n_eq, n_in, 5);
  DenseQp& qp = drifting.qp;
  auto solver = daqp::makeSolver(n, n_eq, n_in, QpSolverSettings{});
  int compared = 0;
  for (int k = 0; k < 30; ++k) {
    drifting.drift(0.02, 0.05);
    drifting.boxAndRows(0.6, 1.0);
    Eigen::VectorXd x(n), x_fresh(n);
    solver->solve(qp, x);
    DenseQp rows = qp;  // one equality row and two inequality rows replaced
    rows.A.row(k % n_eq) = Eigen::VectorXd::NullaryExpr(n, [&] { return drifting.draw(); });
    for (const int r : {k % n_in, (k + 7) % n_in})
      rows.C.row(r) = Eigen::VectorXd::NullaryExpr(n, [&] { return drifting.draw(); });
    DenseQp objective = rows;  // and H moved by 1e-3 in one entry pair
    objective.H(1, 2) += 1e-3;
    objective.H(2, 1) += 1e-3;
    for (const DenseQp* changed : {&rows, &objective}) {
      solver->restartFromLastSolution();
      const QpSolveInfo info = solver->solve(*changed, x);
      auto fresh = daqp::makeSolver(n, n_eq, n_in, QpSolverSettings{});
      const QpSolveInfo fresh_info = fresh->solve(*changed, x_fresh);
      ASSERT_EQ(info.status, fresh_info.status) << "step " << k;
      if (info.status != QpSolveStatus::kSolved) continue;
      ++compared;
      EXPECT_LT((x - x_fresh).cwiseAbs().maxCoeff(), 1e-9) << "step " << k;
    }
  }
  EXPECT_GT(compared, 40);
}

TEST(DaqpAdapter, ALimitedSolveStopsAtItsShareOfTheCapAndTheNextHasItAll) {
  // Projection of x = 2 onto the box [-1, 1]ⁿ from a cold start: n bounds enter one by one.
  const int n = 100;
  DenseQp qp(n, 0, 0);
  qp.H.setIdentity();
  qp.g.setConstant(-2.0);
  qp.x_lower.setConstant(-1.0);
  qp.x_upper.setConstant(1.0);
  auto solver = daqp::makeSolver(n, 0, 0, QpSolverSettings{});
  Eigen::VectorXd x(n);
  solver->limitNextSolve(0.5);
  const QpSolveInfo limited = solver->solve(qp, x);
  EXPECT_EQ(limited.status, QpSolveStatus::kMaxIterations);
  EXPECT_EQ(limited.iterations, daqp::kMaxWorkingSetChanges / 2);
  solver->resetWarmStart();
  const QpSolveInfo whole = solver->solve(qp, x);
  ASSERT_EQ(whole.status, QpSolveStatus::kSolved);
  EXPECT_GE(whole.iterations, n);
  EXPECT_LT((x - Eigen::VectorXd::Ones(n)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(DaqpAdapter, NonFiniteDataIsReportedNotSolved) {
  auto solver = daqp::makeSolver(3, 1, 2, QpSolverSettings{});
  DenseQp qp = projectionProblem();
  qp.H(1, 1) = std::numeric_limits<double>::quiet_NaN();
  Eigen::VectorXd x(3);
  EXPECT_EQ(solver->solve(qp, x).status, QpSolveStatus::kNotFinite);
  ASSERT_EQ(solver->solve(projectionProblem(), x).status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[0], 1.0, 1e-13);
}

TEST(DaqpAdapter, AnIndefiniteProblemIsRejectedAndTheInstanceStaysUsable) {
  // H = diag(1, −1, 1) has no minimum: DAQP's setup fails on its first solve (it frees its
  // workspace then); the instance must report it and set up again for the next problem.
  auto solver = daqp::makeSolver(3, 1, 2, QpSolverSettings{});
  DenseQp qp = projectionProblem();
  qp.H(1, 1) = -1.0;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(3);
  EXPECT_NE(solver->solve(qp, x).status, QpSolveStatus::kSolved);
  EXPECT_NE(solver->solve(qp, x).status, QpSolveStatus::kSolved);
  ASSERT_EQ(solver->solve(projectionProblem(), x).status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[0], 1.0, 1e-13);
  EXPECT_NEAR(x[1], 0.25, 1e-13);
  // And once set up, an indefinite update is rejected the same way.
  EXPECT_NE(solver->solve(qp, x).status, QpSolveStatus::kSolved);
  ASSERT_EQ(solver->solve(projectionProblem(), x).status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[2], -0.25, 1e-13);
}

// The optimality certificate of x: the rows active at x (within tol, signed so that each
// reads s·row·x ≤ s·bound) with the equalities form a KKT system whose solution must be x,
// with non-negative multipliers on the inequalities. Returns the most negative multiplier
// and writes the KKT point's distance from x.
double kktCertificate(const DenseQp& qp, const Eigen::VectorXd& x, double tol, double& distance) {
  const int n = qp.n();
  Eigen::MatrixXd G(qp.nEq() + qp.nIn() + n, n);
  Eigen::VectorXd h(G.rows());
  int rows = 0;
  for (int i = 0; i < qp.nEq(); ++i, ++rows) {
    G.row(rows) = qp.A.row(i);
    h[rows] = qp.b[i];
  }
  const int first_inequality = rows;
  const Eigen::VectorXd cx = qp.C * x;
  for (int i = 0; i < qp.nIn(); ++i) {
    if (cx[i] > qp.u[i] - tol) G.row(rows) = qp.C.row(i), h[rows++] = qp.u[i];
    else if (cx[i] < qp.l[i] + tol) G.row(rows) = -qp.C.row(i), h[rows++] = -qp.l[i];
  }
  for (int i = 0; i < n; ++i) {
    if (x[i] > qp.x_upper[i] - tol) G.row(rows) = Eigen::VectorXd::Unit(n, i).transpose(), h[rows++] = qp.x_upper[i];
    else if (x[i] < qp.x_lower[i] + tol) G.row(rows) = -Eigen::VectorXd::Unit(n, i).transpose(), h[rows++] = -qp.x_lower[i];
  }
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(n + rows, n + rows);
  K.topLeftCorner(n, n) = qp.H;
  K.topRightCorner(n, rows) = G.topRows(rows).transpose();
  K.bottomLeftCorner(rows, n) = G.topRows(rows);
  Eigen::VectorXd rhs(n + rows);
  rhs << -qp.g, h.head(rows);
  const Eigen::VectorXd sol = K.fullPivLu().solve(rhs);
  distance = (sol.head(n) - x).cwiseAbs().maxCoeff();
  const int num_inequalities = rows - first_inequality;
  return num_inequalities > 0 ? sol.tail(num_inequalities).minCoeff() : 0.0;
}

double objective(const DenseQp& qp, const Eigen::VectorXd& x) { return 0.5 * x.dot(qp.H * x) + qp.g.dot(x); }

// A sequence of random strictly convex QPs drifting like the filter's ticks (n = 30, 6
// equalities, 40 rows, boxes), solved by one hot-started DAQP instance: every answer passes
// the KKT certificate (its active set's KKT point, multipliers ≥ 0), its equality rows hold
// to round-off, and it is never worse than a cold, tight ProxQP's answer nor different from a cold DAQP's.
TEST(DaqpAdapter, HotStartedAnswersOnADriftingSequenceOfRandomQpsAreCertifiedOptimal) {
  const int n = 30, n_eq = 6, n_in = 40;
  DriftingQp drifting(n, n_eq, n_in, 11);
  DenseQp& qp = drifting.qp;
  qp.x_lower.setConstant(-0.8);
  qp.x_upper.setConstant(0.8);
  auto daqp_solver = daqp::makeSolver(n, n_eq, n_in, QpSolverSettings{});
  int active_total = 0, hot_iterations = 0, cold_iterations = 0, proxqp_solved = 0;
  for (int k = 0; k < 40; ++k) {
    drifting.drift(0.02, 0.1);
    for (int i = 0; i < n_eq; ++i) qp.b[i] += 0.02 * drifting.draw();
    for (int i = 0; i < n_in; ++i) {
      qp.l[i] = i % 3 == 0 ? -kQpInfinity : -1.0 - 0.1 * std::abs(drifting.draw());
      qp.u[i] = 1.0 + 0.1 * std::abs(drifting.draw());
    }
    Eigen::VectorXd x(n), x_proxqp(n);
    const QpSolveInfo info = daqp_solver->solve(qp, x);
    ASSERT_EQ(info.status, QpSolveStatus::kSolved) << "tick " << k;
    hot_iterations += info.iterations;
    double distance = 0.0;
    const double min_multiplier = kktCertificate(qp, x, 1e-9, distance);
    EXPECT_LT(distance, 1e-9) << "tick " << k;
    EXPECT_GT(min_multiplier, -1e-9) << "tick " << k;
    EXPECT_LT((qp.A * x - qp.b).cwiseAbs().maxCoeff(), 1e-12) << "tick " << k;
    const Eigen::VectorXd cx = qp.C * x;
    for (int i = 0; i < n_in; ++i) {
      EXPECT_LE(cx[i], qp.u[i] + 1e-9);
      EXPECT_GE(cx[i], qp.l[i] - 1e-9);
      if (cx[i] > qp.u[i] - 1e-9 || cx[i] < qp.l[i] + 1e-9) ++active_total;
    }
    auto proxqp_solver = proxqp::makeSolver(n, n_eq, n_in, tightSettings());
    // ProxQP's answer, where it has one (its infeasibility test sometimes fires on these),
    // is never better.
    if (proxqp_solver->solve(qp, x_proxqp).status == QpSolveStatus::kSolved) {
      ++proxqp_solved;
      EXPECT_LE(objective(qp, x), objective(qp, x_proxqp) + 1e-9) << "tick " << k;
    }
    auto cold = daqp::makeSolver(n, n_eq, n_in, QpSolverSettings{});
    Eigen::VectorXd x_cold(n);
    cold_iterations += cold->solve(qp, x_cold).iterations;
    EXPECT_LT((x - x_cold).cwiseAbs().maxCoeff(), 1e-9) << "tick " << k;
  }
  RecordProperty("active_rows_total", active_total);
  RecordProperty("hot_iterations", hot_iterations);
  RecordProperty("cold_iterations", cold_iterations);
  EXPECT_GT(proxqp_solved, 20);
  EXPECT_GT(active_total, 40) << "the rows must bind for the certificate to mean anything";
  EXPECT_LT(hot_iterations, cold_iterations) << "the hot start saves working-set changes";
}

TEST(DaqpAdapter, InvalidDimensionsThrow) {
  EXPECT_THROW(daqp::makeSolver(0, 0, 0, QpSolverSettings{}), std::invalid_argument);
  EXPECT_THROW(daqp::makeSolver(3, -1, 0, QpSolverSettings{}), std::invalid_argument);
  QpSolverSettings bad;
  bad.eps_abs = 0.0;
  EXPECT_THROW(daqp::makeSolver(3, 1, 0, bad), std::invalid_argument);
}

TEST(QpEngines, NamesMakeTheirEnginesAndAnUnknownNameListsTheKnownOnes) {
  EXPECT_EQ(QpSolverSettings{}.engine, "daqp");
  for (const std::string name : {"daqp", "proxqp"}) {
    auto solver = qp_engines::factory(name)(3, 1, 2, QpSolverSettings{});
    EXPECT_EQ(std::string(solver->name()), name);
    Eigen::VectorXd x(3);
    ASSERT_EQ(solver->solve(projectionProblem(), x).status, QpSolveStatus::kSolved) << name;
    EXPECT_NEAR(x[1], 0.25, 1e-6) << name;
  }
  try {
    qp_engines::factory("qpoases");
    FAIL() << "an unknown engine must throw";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("qpoases"), std::string::npos) << what;
    EXPECT_NE(what.find("daqp"), std::string::npos) << what;
    EXPECT_NE(what.find("proxqp"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace dynfilter
