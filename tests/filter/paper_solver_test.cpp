// The structured PaperSolver against the literal dense Eq. 21–23, and the properties
// every solution must have.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "dynfilter/core/constrained_dynamics.hpp"
#include "dynfilter/core/paper_solver.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/literal_paper_solver.hpp"
#include "support/reference_motions.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

struct Instance {
  Eigen::MatrixXd A, H_C;
  Eigen::VectorXd b, u_C, vdot_desired;
};

Instance randomInstance(std::mt19937& rng, int nv, int nc) {
  std::normal_distribution<double> g(0.0, 1.0);
  auto randn = [&](int r, int c) {
    Eigen::MatrixXd M(r, c);
    for (int i = 0; i < r; ++i)
      for (int j = 0; j < c; ++j) M(i, j) = g(rng);
    return M;
  };
  Instance in;
  const Eigen::MatrixXd L = randn(nv, nv);
  in.A = L * L.transpose() + nv * Eigen::MatrixXd::Identity(nv, nv);  // SPD, like a mass matrix
  in.H_C = randn(nc, nv);
  in.b = 10.0 * randn(nv, 1);
  in.u_C = randn(nc, 1);
  in.vdot_desired = 3.0 * randn(nv, 1);
  return in;
}

double relative(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

void expectMatchesLiteral(const Instance& in, int nb, const PaperSolverOptions& options) {
  const int nv = static_cast<int>(in.A.rows()), nc = static_cast<int>(in.H_C.rows());
  PaperSolver solver(nv, nb, 48, options);
  Eigen::VectorXd vdot(nv), tau_C(nc), tau_J(nv - nb);
  solver.solve(in.A, in.b, in.H_C, in.u_C, in.vdot_desired, vdot, tau_C, tau_J);
  const auto literal =
      test::literalPaperSolve(in.A, in.b, in.H_C, in.u_C, nb, in.vdot_desired, options);
  EXPECT_LT(relative(vdot, literal.vdot), 1e-9)
      << "nv " << nv << " nc " << nc << " w_a " << options.accel_weight << " w_f "
      << options.force_weight << " k " << options.sr_damping;
  if (nc > 0) {
    EXPECT_LT(relative(tau_C, literal.tau_C), 1e-9);
  }
  EXPECT_LT(relative(tau_J, literal.tau_J), 1e-9);
  // And it solves Eq. 12 with no force on the unactuated base rows.
  Eigen::VectorXd scratch(nv);
  const Eq12Residual r =
      eq12Residual(in.A, in.b, in.H_C, in.u_C, nb, vdot, tau_C, tau_J, scratch);
  EXPECT_LT(r.max_abs, 1e-9 * std::max(1.0, in.b.cwiseAbs().maxCoeff()));
}

TEST(PaperSolver, MatchesTheLiteralDenseFormulationOnRandomFloatingBaseInstances) {
  // The regime the filter runs in: at most as many contact rows as joints (N_C <= nj), and
  // contact forces weighted no more than accelerations (w_f <= w_a), SR damping k >= 1e-5
  // (a smaller k amplifies rounding in both formulations alike). Outside it G is
  // ill-conditioned and the structured solve loses digits (measured: 1e-5 relative with
  // N_C = 10 > nj = 5 and w_f / w_a = 300).
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 60; ++trial) {
    const int nv = 8 + trial % 31;
    const int nc = (trial * 5) % (nv - 6 + 1);  // includes 0 (flight) and N_C = nj
    PaperSolverOptions options;
    options.accel_weight = std::pow(10.0, 2.0 * unit(rng));
    options.force_weight = options.accel_weight * std::pow(10.0, -6.0 * unit(rng));
    options.sr_damping = std::pow(10.0, -5.0 + 3.0 * unit(rng));  // [1e-5, 1e-2]
    expectMatchesLiteral(randomInstance(rng, nv, nc), 6, options);
  }
}

TEST(PaperSolver, WithTaskRowsMatchesTheLiteralEq16) {
  std::mt19937 rng(404);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const int nv = 14 + trial % 20, nc = (trial * 3) % 13, nt = 6;
    Instance in = randomInstance(rng, nv, nc);
    Eigen::MatrixXd J_task(nt, nv);
    Eigen::VectorXd rhs(nt);
    for (int i = 0; i < nt; ++i) {
      rhs[i] = g(rng);
      for (int j = 0; j < nv; ++j) J_task(i, j) = g(rng);
    }
    PaperSolverOptions options;
    PaperSolver solver(nv, 6, 48, options);
    Eigen::VectorXd vdot(nv), tau_C(nc), tau_J(nv - 6);
    solver.solve(in.A, in.b, in.H_C, in.u_C, J_task, rhs, in.vdot_desired, vdot, tau_C, tau_J);
    const auto literal = test::literalPaperSolve(in.A, in.b, in.H_C, in.u_C, 6, in.vdot_desired,
                                                 options, J_task, rhs);
    EXPECT_LT(relative(vdot, literal.vdot), 1e-9);
    EXPECT_LT(relative(tau_J, literal.tau_J), 1e-9);
    EXPECT_LT((J_task * vdot - rhs).cwiseAbs().maxCoeff(), 1e-9) << "task rows hold";
  }
}

TEST(PaperSolver, MatchesTheLiteralDenseFormulationForAFixedBase) {
  std::mt19937 rng(99);
  for (int nc : {0, 2, 5}) expectMatchesLiteral(randomInstance(rng, 7, nc), 0, PaperSolverOptions{});
}

TEST(PaperSolver, MatchesTheLiteralDenseFormulationOnTheHumanFigureStanding) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  Eigen::VectorXd q = model->info().neutralConfiguration();
  q[2] = test::humanFigureStandingHeight() - 1e-3;
  std::mt19937 rng(5);
  Eigen::VectorXd qq, v;
  test::randomState(*model, rng, 0.5, qq, v);
  model->setState(q, v);
  Instance in;
  const int nv = model->nv();
  in.A.resize(nv, nv);
  in.b.resize(nv);
  model->massMatrix(in.A);
  model->bias(in.b);
  // Both soles as 6-axis face links (12 rows), world-aligned.
  in.H_C.resize(12, nv);
  Matrix6Xd J(6, nv);
  int row = 0;
  for (const char* foot : {"l_foot", "r_foot"}) {
    model->pointJacobian(model->info().findBody(foot), Eigen::Vector3d(0.07, 0, -0.068), J);
    in.H_C.middleRows(row, 6) = J;
    row += 6;
  }
  in.u_C = Eigen::VectorXd::Zero(12);
  in.vdot_desired = Eigen::VectorXd::Random(nv);
  expectMatchesLiteral(in, 6, PaperSolverOptions{});
}

TEST(PaperSolver, ReachesAFeasibleDesiredAccelerationAlmostExactly) {
  // When v̇ᵈ satisfies the constraint rows, the result differs from it only by the SR
  // damping (relative size about k).
  std::mt19937 rng(17);
  Instance in = randomInstance(rng, 14, 9);
  in.u_C = in.H_C * in.vdot_desired;  // feasible: contacts agree with v̇ᵈ
  PaperSolverOptions options;
  options.sr_damping = 1e-8;
  PaperSolver solver(14, 6, 48, options);
  Eigen::VectorXd vdot(14), tau_C(9), tau_J(8);
  solver.solve(in.A, in.b, in.H_C, in.u_C, in.vdot_desired, vdot, tau_C, tau_J);
  EXPECT_LT(relative(vdot, in.vdot_desired), 1e-6);
}

TEST(PaperSolver, InFlightTheBaseFollowsGravityWhateverTheDesiredAcceleration) {
  // No contacts: the six base rows alone fix the momentum rate; asking the base to hover
  // must not change that it falls. Check on the free box: v̇_lin = Rᵀ g, ω̇ from Euler.
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::testModelPath("floating_box.urdf")),
                               ModelOptions{});
  Eigen::VectorXd q(7), v = Eigen::VectorXd::Zero(6);
  q << 0, 0, 1, 1, 0, 0, 0;
  model->setState(q, v);
  Eigen::MatrixXd A(6, 6);
  Eigen::VectorXd b(6);
  model->massMatrix(A);
  model->bias(b);
  PaperSolver solver(6, 6, 48, PaperSolverOptions{});
  Eigen::VectorXd vdot(6), tau_C(0), tau_J(0);
  const Eigen::VectorXd hover = Eigen::VectorXd::Zero(6);
  solver.solve(A, b, Eigen::MatrixXd(0, 6), Eigen::VectorXd(0), hover, vdot, tau_C, tau_J);
  EXPECT_NEAR(vdot[2], -9.81, 1e-12);
  EXPECT_LT(vdot.tail<3>().norm(), 1e-12);
}

}  // namespace
}  // namespace dynfilter
