#pragma once
// Small QPs with answers worked out by hand, shared by the tests of each QP engine
// (qp_solver_test.cpp: ProxQP, daqp_solver_test.cpp: DAQP).

#include <Eigen/Core>

#include "dynfilter/core/qp_solver.hpp"

namespace dynfilter::test {

// min ½‖x − c‖², c = (2, 1, 0), s.t. x0 + x1 + x2 = 1, x0 ≤ 1 (box), x2 ≥ −0.25 (row of C),
// plus one unbounded row of C and unbounded boxes on x1, x2.
// KKT with L = ½‖x − c‖² − λ (Σx − 1) + μ (x0 − 1) − ν (x2 + 0.25), both bounds active:
//   x = (1, 0.25, −0.25): x1 − c1 = λ → λ = −0.75; x0: 1 − 2 + 0.75 + μ = 0 → μ = 0.25 ≥ 0;
//   x2: −0.25 − 0 + 0.75 − ν = 0 → ν = 0.5 ≥ 0. (Without the bounds the projection onto the
//   plane would be (4/3, 1/3, −2/3), which violates both.)
inline DenseQp projectionProblem() {
  DenseQp qp(3, 1, 2);
  qp.H.setIdentity();
  qp.g = -Eigen::Vector3d(2.0, 1.0, 0.0);
  qp.A << 1.0, 1.0, 1.0;
  qp.b << 1.0;
  qp.C << 0.0, 0.0, 1.0,  //
      1.0, -1.0, 0.5;     // unbounded on both sides
  qp.l << -0.25, -kQpInfinity;
  qp.u << kQpInfinity, kQpInfinity;
  qp.x_lower.setConstant(-kQpInfinity);
  qp.x_upper << 1.0, kQpInfinity, kQpInfinity;
  return qp;
}

// x ≥ 1 (box) and x ≤ 0 (row of C): no x satisfies both.
inline DenseQp boxAgainstRowProblem() {
  DenseQp qp(1, 0, 1);
  qp.H(0, 0) = 1.0;
  qp.g[0] = 0.0;
  qp.C(0, 0) = 1.0;
  qp.l[0] = -kQpInfinity;
  qp.u[0] = 0.0;
  qp.x_lower[0] = 1.0;
  qp.x_upper[0] = kQpInfinity;
  return qp;
}

// Tolerance and cap tight enough for the closed forms above.
inline QpSolverSettings tightSettings() {
  QpSolverSettings s;
  s.eps_abs = 1e-10;
  s.max_iterations = 1000;
  return s;
}

}  // namespace dynfilter::test
