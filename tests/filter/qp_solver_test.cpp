// The ProxQP adapter (dynfilter::proxqp::makeSolver) on small dense QPs whose answers are
// worked out by hand from the KKT conditions.
#include <memory>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include "dynfilter/core/qp_solver.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"

#include "filter/qp_test_problems.hpp"

namespace dynfilter {
namespace {

using test::projectionProblem;
using test::tightSettings;

TEST(ProxQpAdapter, ProjectionWithActiveBoxAndRowMatchesKkt) {
  auto solver = proxqp::makeSolver(3, 1, 2, tightSettings());
  ASSERT_NE(solver, nullptr);
  EXPECT_STREQ(solver->name(), "proxqp");
  const DenseQp qp = projectionProblem();
  Eigen::VectorXd x = Eigen::VectorXd::Constant(3, 99.0);
  const QpSolveInfo info = solver->solve(qp, x);
  EXPECT_EQ(info.status, QpSolveStatus::kSolved) << toString(info.status);
  EXPECT_NEAR(x[0], 1.0, 1e-8);
  EXPECT_NEAR(x[1], 0.25, 1e-8);
  EXPECT_NEAR(x[2], -0.25, 1e-8);
  EXPECT_LE(info.primal_residual, 1e-9);
  EXPECT_GT(info.iterations, 0);
}

TEST(ProxQpAdapter, WarmStartedResolveTakesNoMoreIterations) {
  auto solver = proxqp::makeSolver(3, 1, 2, tightSettings());
  const DenseQp qp = projectionProblem();
  Eigen::VectorXd x(3);
  const QpSolveInfo first = solver->solve(qp, x);
  ASSERT_EQ(first.status, QpSolveStatus::kSolved);
  const Eigen::VectorXd x_first = x;
  const QpSolveInfo second = solver->solve(qp, x);
  EXPECT_EQ(second.status, QpSolveStatus::kSolved);
  EXPECT_LE(second.iterations, first.iterations);
  EXPECT_LT((x - x_first).cwiseAbs().maxCoeff(), 1e-8);
  RecordProperty("cold_iterations", first.iterations);
  RecordProperty("warm_iterations", second.iterations);

  // After resetWarmStart the solve starts cold again: the same answer.
  solver->resetWarmStart();
  const QpSolveInfo cold = solver->solve(qp, x);
  EXPECT_EQ(cold.status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[0], 1.0, 1e-8);
  EXPECT_NEAR(x[1], 0.25, 1e-8);
  EXPECT_NEAR(x[2], -0.25, 1e-8);
}

TEST(ProxQpAdapter, AWarmSolveOnTheSameActiveSetIsOneExactLinearSolve) {
  // The box moved to x0 ≤ 0.9, the same bounds active: x = (0.9, 0.35, −0.25) with
  // λ = x1 − c1 = −0.65, μ = 2 − 0.9 − 0.65 = 0.45 ≥ 0, ν = −0.25 + 0.65 = 0.4 ≥ 0.
  // The active-set step solves it in one linear solve, to round-off (ProxQP would stop at
  // its tolerance after at least two Newton steps).
  auto solver = proxqp::makeSolver(3, 1, 2, tightSettings());
  DenseQp qp = projectionProblem();
  Eigen::VectorXd x(3);
  ASSERT_EQ(solver->solve(qp, x).status, QpSolveStatus::kSolved);
  qp.x_upper[0] = 0.9;
  const QpSolveInfo info = solver->solve(qp, x);
  EXPECT_EQ(info.status, QpSolveStatus::kSolved);
  EXPECT_EQ(info.iterations, 1);
  EXPECT_NEAR(x[0], 0.9, 1e-13);
  EXPECT_NEAR(x[1], 0.35, 1e-13);
  EXPECT_NEAR(x[2], -0.25, 1e-13);
  // A guess that is wrong in both bounds: for c = (2, 1, 1.5) the projection onto the
  // plane, c − (7/6)(1, 1, 1) = (5/6, −1/6, 1/3), is inside both. Corrected by the step or
  // left to ProxQP, the answer is that KKT point.
  qp.g = -Eigen::Vector3d(2.0, 1.0, 1.5);
  const QpSolveInfo moved = solver->solve(qp, x);
  EXPECT_EQ(moved.status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[0], 5.0 / 6.0, 1e-8);
  EXPECT_NEAR(x[1], -1.0 / 6.0, 1e-8);
  EXPECT_NEAR(x[2], 1.0 / 3.0, 1e-8);
}

TEST(ProxQpAdapter, ChangedDataOnTheSameInstanceIsSolvedAnew) {
  // A warm start from the previous answer must not leak it into a different problem:
  // moving c to (−2, 1, 0) makes the box inactive. Σx = 1 with x2 ≥ −0.25:
  // projection (−2, 1, 0) + λ(1,1,1), λ = 2/3 → (−4/3, 5/3, 2/3): feasible, so the answer.
  auto solver = proxqp::makeSolver(3, 1, 2, tightSettings());
  DenseQp qp = projectionProblem();
  Eigen::VectorXd x(3);
  ASSERT_EQ(solver->solve(qp, x).status, QpSolveStatus::kSolved);
  qp.g = -Eigen::Vector3d(-2.0, 1.0, 0.0);
  const QpSolveInfo info = solver->solve(qp, x);
  EXPECT_EQ(info.status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[0], -4.0 / 3.0, 1e-8);
  EXPECT_NEAR(x[1], 5.0 / 3.0, 1e-8);
  EXPECT_NEAR(x[2], 2.0 / 3.0, 1e-8);
}

TEST(ProxQpAdapter, InfiniteBoundsAreUnbounded) {
  // Every inequality side and box at ±kQpInfinity: only Σx = 1 binds, so the answer is the
  // projection (4/3, 1/3, −2/3). A bound taken as the finite 1e20 would enter ProxQP's
  // duality gap (z · 1e20) and keep it from converging.
  auto solver = proxqp::makeSolver(3, 1, 2, tightSettings());
  DenseQp qp = projectionProblem();
  qp.l.setConstant(-kQpInfinity);
  qp.u.setConstant(kQpInfinity);
  qp.x_lower.setConstant(-kQpInfinity);
  qp.x_upper.setConstant(kQpInfinity);
  Eigen::VectorXd x(3);
  const QpSolveInfo info = solver->solve(qp, x);
  EXPECT_EQ(info.status, QpSolveStatus::kSolved) << toString(info.status);
  EXPECT_NEAR(x[0], 4.0 / 3.0, 1e-8);
  EXPECT_NEAR(x[1], 1.0 / 3.0, 1e-8);
  EXPECT_NEAR(x[2], -2.0 / 3.0, 1e-8);
  EXPECT_LE(info.iterations, 20);

  // One-sided: x2 ≥ −0.25 with +∞ above, boxes −∞ below. Answer: x2 = −0.25 and
  // x0 − 2 = x1 − 1 = λ, x0 + x1 = 1.25 → λ = −0.875, x = (1.125, 0.125, −0.25).
  qp.l[0] = -0.25;
  solver->resetWarmStart();
  const QpSolveInfo one_sided = solver->solve(qp, x);
  EXPECT_EQ(one_sided.status, QpSolveStatus::kSolved) << toString(one_sided.status);
  EXPECT_NEAR(x[0], 1.125, 1e-8);
  EXPECT_NEAR(x[1], 0.125, 1e-8);
  EXPECT_NEAR(x[2], -0.25, 1e-8);
}

TEST(ProxQpAdapter, InfeasibleProblemIsNotReportedSolved) {
  // x ≥ 1 (box) and x ≤ 0 (row of C): no x satisfies both.
  QpSolverSettings settings;
  settings.max_iterations = 500;
  auto solver = proxqp::makeSolver(1, 0, 1, settings);
  DenseQp qp = test::boxAgainstRowProblem();
  Eigen::VectorXd x(1);
  const QpSolveInfo info = solver->solve(qp, x);
  RecordProperty("solve_status", toString(info.status));
  EXPECT_TRUE(info.status == QpSolveStatus::kPrimalInfeasible ||
              info.status == QpSolveStatus::kMaxIterations)
      << toString(info.status);
  // Whatever the iterate, it cannot satisfy both bounds.
  EXPECT_TRUE(x[0] < 1.0 - 1e-9 || x[0] > 1e-9) << x[0];
  // The next solve of the same instance (no warm start from a failure) fails the same way.
  const QpSolveInfo again = solver->solve(qp, x);
  EXPECT_NE(again.status, QpSolveStatus::kSolved);
}

// The cap bounds a solve's work: max_iterations outer iterations of at most 5 Newton steps
// (+1 for the step that finds the inner loop done) each, whatever the problem. Here a cold
// solve of 40 variables against 120 random half-spaces, many of them active, which takes
// ProxQP well over 12 Newton steps uncapped.
TEST(ProxQpAdapter, TheIterationCapBoundsTheNewtonStepsAndSaysSo) {
  const int n = 40, n_in = 120;
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  DenseQp qp(n, 1, n_in);
  qp.H.setIdentity();
  for (int i = 0; i < n; ++i) qp.g[i] = 10.0 * normal(rng);
  qp.A.setOnes();
  qp.b << 1.0;
  for (int r = 0; r < n_in; ++r)
    for (int i = 0; i < n; ++i) qp.C(r, i) = normal(rng);
  qp.l.setConstant(-kQpInfinity);
  qp.u.setConstant(1.0);
  qp.x_lower.setConstant(-kQpInfinity);
  qp.x_upper.setConstant(kQpInfinity);
  QpSolverSettings uncapped;
  uncapped.eps_abs = 1e-10;
  uncapped.max_iterations = 1000;
  auto reference = proxqp::makeSolver(n, 1, n_in, uncapped);
  Eigen::VectorXd x_ref(n);
  const QpSolveInfo full = reference->solve(qp, x_ref);
  ASSERT_EQ(full.status, QpSolveStatus::kSolved);
  RecordProperty("uncapped_iterations", full.iterations);
  ASSERT_GT(full.iterations, 12) << "the problem must need more than the caps allow";
  for (const int cap : {1, 2}) {
    QpSolverSettings capped = uncapped;
    capped.max_iterations = cap;
    auto solver = proxqp::makeSolver(n, 1, n_in, capped);
    Eigen::VectorXd x(n);
    const QpSolveInfo info = solver->solve(qp, x);
    EXPECT_LE(info.iterations, cap * 6) << "cap " << cap;
    EXPECT_EQ(info.status, QpSolveStatus::kMaxIterations) << "cap " << cap;
    EXPECT_TRUE(x.allFinite());
  }
}

TEST(ProxQpAdapter, InvalidDimensionsAndSettingsThrow) {
  EXPECT_THROW(proxqp::makeSolver(0, 0, 0, QpSolverSettings{}), std::invalid_argument);
  EXPECT_THROW(proxqp::makeSolver(3, -1, 0, QpSolverSettings{}), std::invalid_argument);
  QpSolverSettings bad;
  bad.eps_abs = 0.0;
  EXPECT_THROW(proxqp::makeSolver(3, 1, 0, bad), std::invalid_argument);
  bad = QpSolverSettings{};
  bad.max_iterations = 0;
  EXPECT_THROW(proxqp::makeSolver(3, 1, 0, bad), std::invalid_argument);
  // The factory builds the same engine.
  auto solver = proxqp::factory()(3, 1, 2, tightSettings());
  ASSERT_NE(solver, nullptr);
  Eigen::VectorXd x(3);
  EXPECT_EQ(solver->solve(projectionProblem(), x).status, QpSolveStatus::kSolved);
  EXPECT_NEAR(x[1], 0.25, 1e-8);
}

}  // namespace
}  // namespace dynfilter
