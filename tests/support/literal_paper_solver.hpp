#pragma once
// The paper's Eq. 21–23 written literally with dense matrices: the test oracle for the
// structured PaperSolver. x = (v̇, τ_C, τ_J), W x = u as in Eq. 12, W^# the pseudo-inverse
// weighted by Q = diag(w_a I, w_f I, 0), computed from the KKT system of
// min ½ xᵀ Q x s.t. W x = u; N = E − W^# W; V_G the v̇ rows of N;
// y = V_Gᵀ (V_G V_Gᵀ + k I)⁻¹ (v̇ᵈ − v̇⁰); x = W^# u + N y.

#include <Eigen/Core>

#include "dynfilter/core/filter_options.hpp"

namespace dynfilter::test {

struct LiteralSolution {
  Eigen::VectorXd vdot, tau_C, tau_J;
};

/// Eq. 12, or Eq. 16 when task rows J_task v̇ = rhs_task are given.
LiteralSolution literalPaperSolve(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                  const Eigen::MatrixXd& H_C, const Eigen::VectorXd& u_C, int nb,
                                  const Eigen::VectorXd& vdot_desired,
                                  const PaperSolverOptions& options,
                                  const Eigen::MatrixXd& J_task = Eigen::MatrixXd(),
                                  const Eigen::VectorXd& rhs_task = Eigen::VectorXd());

}  // namespace dynfilter::test
