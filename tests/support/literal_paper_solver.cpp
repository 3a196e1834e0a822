#include "support/literal_paper_solver.hpp"

#include <Eigen/LU>

namespace dynfilter::test {

LiteralSolution literalPaperSolve(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                  const Eigen::MatrixXd& H_C, const Eigen::VectorXd& u_C, int nb,
                                  const Eigen::VectorXd& vdot_desired,
                                  const PaperSolverOptions& options,
                                  const Eigen::MatrixXd& J_task,
                                  const Eigen::VectorXd& rhs_task) {
  const int nv = static_cast<int>(A.rows());
  const int nc = static_cast<int>(H_C.rows());
  const int nj = nv - nb;
  const int nx = nv + nc + nj;
  const int nt = static_cast<int>(rhs_task.size());
  const int nw = nv + nc + nt;
  // W = [A, −H_Cᵀ, −H_Jᵀ; H_C, 0, 0; J_task, 0, 0], H_J = [0 | I]
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(nw, nx);
  W.topLeftCorner(nv, nv) = A;
  W.block(0, nv, nv, nc) = -H_C.transpose();
  W.block(nb, nv + nc, nj, nj) = -Eigen::MatrixXd::Identity(nj, nj);
  W.block(nv, 0, nc, nv) = H_C;
  if (nt > 0) W.bottomLeftCorner(nt, nv) = J_task;
  Eigen::VectorXd u(nw);
  u << -b, u_C, rhs_task;
  Eigen::VectorXd q_diag = Eigen::VectorXd::Zero(nx);
  q_diag.head(nv).setConstant(options.accel_weight);
  q_diag.segment(nv, nc).setConstant(options.force_weight);

  // W^# from the KKT system [Q Wᵀ; W 0] [X; Λ] = [0; I].
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(nx + nw, nx + nw);
  K.topLeftCorner(nx, nx) = q_diag.asDiagonal();
  K.topRightCorner(nx, nw) = W.transpose();
  K.bottomLeftCorner(nw, nx) = W;
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(nx + nw, nw);
  rhs.bottomRows(nw).setIdentity();
  const Eigen::MatrixXd W_sharp = K.fullPivLu().solve(rhs).topRows(nx);

  const Eigen::VectorXd x0 = W_sharp * u;                                         // Eq. 21
  const Eigen::MatrixXd N = Eigen::MatrixXd::Identity(nx, nx) - W_sharp * W;
  const Eigen::MatrixXd V_G = N.topRows(nv);                                     // Eq. 22
  const Eigen::MatrixXd VVt =
      V_G * V_G.transpose() + options.sr_damping * Eigen::MatrixXd::Identity(nv, nv);
  const Eigen::VectorXd y =
      V_G.transpose() * VVt.fullPivLu().solve(vdot_desired - x0.head(nv));        // Eq. 23
  const Eigen::VectorXd x = x0 + N * y;
  return {x.head(nv), x.segment(nv, nc), x.tail(nj)};
}

}  // namespace dynfilter::test
