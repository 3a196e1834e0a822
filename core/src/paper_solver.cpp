#include "dynfilter/core/paper_solver.hpp"

#include <Eigen/Cholesky>

#include "dynfilter/core/filter_output.hpp"

namespace dynfilter {
namespace {

// Cholesky in place; returns false when S is numerically singular (condition number
// beyond ~1e10), after regularising it with a ridge of relative size 1e-10 (then 1e-8, ...)
// so that the caller still gets a bounded answer.
bool choleskyInPlace(Eigen::Ref<Eigen::MatrixXd> S, Eigen::Ref<Eigen::MatrixXd> backup) {
  backup = S;
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(S);
  if (llt.info() == Eigen::Success) {
    const auto diag = S.diagonal().cwiseAbs();
    if (diag.size() == 0 || diag.minCoeff() > 1e-5 * diag.maxCoeff()) return true;
  }
  const double scale = std::max(1e-300, backup.diagonal().cwiseAbs().maxCoeff());
  for (double ridge = 1e-10; ridge < 1.0; ridge *= 100.0) {
    S = backup;
    S.diagonal().array() += ridge * scale;
    Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> retry(S);
    if (retry.info() == Eigen::Success) return false;
  }
  return false;
}

// Solves L Lᵀ x = rhs in place, with L the lower triangle of S.
template <typename Vec>
void choleskySolve(const Eigen::Ref<const Eigen::MatrixXd>& S, Vec&& x) {
  S.triangularView<Eigen::Lower>().solveInPlace(x);
  S.triangularView<Eigen::Lower>().transpose().solveInPlace(x);
}

}  // namespace

PaperSolver::PaperSolver(int nv, int nb, int max_rows, const PaperSolverOptions& options)
    : nv_(nv), nb_(nb), options_(options) {
  const int m = nb + max_rows + kMaxTaskRows;
  Cv_.setZero(m, nv);
  G_.setZero(m, m);
  Ginv_.setZero(m, m);
  R_.setZero(m, m);
  RCv_.setZero(m, nv);
  M_.setZero(nv, nv);
  HbTHb_.setZero(nb, nb);
  GinvE_.setZero(m, nb);
  for (Eigen::VectorXd* vec : {&d_, &lambda_, &mu_, &t_}) vec->setZero(m);
  for (Eigen::VectorXd* vec : {&e_, &w_, &yv_, &zv_}) vec->setZero(nv);
  yc_.setZero(max_rows);
  empty_task_.setZero(0, nv);
  zc_.setZero(max_rows);
}

std::uint32_t PaperSolver::solve(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                 const Eigen::Ref<const Eigen::VectorXd>& b,
                                 const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                                 const Eigen::Ref<const Eigen::VectorXd>& u_C,
                                 const Eigen::Ref<const Eigen::VectorXd>& vdot_desired,
                                 Eigen::Ref<Eigen::VectorXd> vdot,
                                 Eigen::Ref<Eigen::VectorXd> tau_C,
                                 Eigen::Ref<Eigen::VectorXd> tau_J) {
  return solve(A, b, H_C, u_C, empty_task_, empty_task_rhs_, vdot_desired, vdot, tau_C, tau_J);
}

std::uint32_t PaperSolver::solve(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                 const Eigen::Ref<const Eigen::VectorXd>& b,
                                 const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                                 const Eigen::Ref<const Eigen::VectorXd>& u_C,
                                 const Eigen::Ref<const Eigen::MatrixXd>& J_task,
                                 const Eigen::Ref<const Eigen::VectorXd>& rhs_task,
                                 const Eigen::Ref<const Eigen::VectorXd>& vdot_desired,
                                 Eigen::Ref<Eigen::VectorXd> vdot,
                                 Eigen::Ref<Eigen::VectorXd> tau_C,
                                 Eigen::Ref<Eigen::VectorXd> tau_J) {
  std::uint32_t status = kStatusOk;
  const int nc = static_cast<int>(H_C.rows());
  const int nt = static_cast<int>(J_task.rows());
  const int nb = nb_, nv = nv_, nj = nv - nb, m = nb + nc + nt;
  const double wa = options_.accel_weight, wf = options_.force_weight;
  const double beta = (1.0 - wa / wf) / (wa * wa);

  // C_v = [A_b; H_C; J_task] and d = [−b_b; u_C; rhs_task]. C_c = [−H_bᵀ; 0; 0] is used
  // through H_b only.
  auto Cv = Cv_.topRows(m);
  Cv.topRows(nb) = A.topRows(nb);
  Cv.middleRows(nb, nc) = H_C;
  Cv.bottomRows(nt) = J_task;
  auto d = d_.head(m);
  d.head(nb) = -b.head(nb);
  d.segment(nb, nc) = u_C;
  d.tail(nt) = rhs_task;
  const auto Hb = H_C.leftCols(nb);
  HbTHb_.noalias() = Hb.transpose() * Hb;

  // G = C_v C_vᵀ / w_a + C_c C_cᵀ / w_f, factorised; explicit G⁻¹ for R.
  auto G = G_.topLeftCorner(m, m);
  G.noalias() = (1.0 / wa) * Cv * Cv.transpose();
  G.topLeftCorner(nb, nb) += HbTHb_ / wf;
  auto Ginv = Ginv_.topLeftCorner(m, m);
  if (!choleskyInPlace(G, Ginv)) status |= kStatusRankDeficient;
  Ginv.setIdentity();
  choleskySolve(G, Ginv);

  // Particular solution z⁰ = Q_z⁻¹ Cᵀ G⁻¹ d.
  auto lambda = lambda_.head(m);
  lambda.noalias() = Ginv * d;
  Eigen::VectorXd& vdot0 = zv_;
  vdot0.noalias() = (1.0 / wa) * Cv.transpose() * lambda;
  auto tauC0 = zc_.head(nc);
  tauC0.noalias() = (-1.0 / wf) * Hb * lambda.head(nb);

  // V_G V_Gᵀ + k I = (1 + k) I − C_vᵀ R C_v.
  auto R = R_.topLeftCorner(m, m);
  R = Ginv / wa;
  auto GinvE = GinvE_.topRows(m);
  GinvE = Ginv.leftCols(nb);
  auto GinvE_HbTHb = RCv_.topLeftCorner(m, nb);  // scratch, overwritten below
  GinvE_HbTHb.noalias() = GinvE * HbTHb_;
  R.noalias() -= beta * GinvE_HbTHb * GinvE.transpose();
  auto RCv = RCv_.topRows(m);
  RCv.noalias() = R * Cv;
  M_.noalias() = -Cv.transpose() * RCv;
  M_.diagonal().array() += 1.0 + options_.sr_damping;
  // M_ is SPD for k > 0; a failure here means non-finite input.
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt_M(M_);
  if (llt_M.info() != Eigen::Success) status |= kStatusRankDeficient;

  // w = (V_G V_Gᵀ + k I)⁻¹ (v̇ᵈ − v̇⁰); y = V_Gᵀ w; z = z⁰ + N_z y.
  e_ = vdot_desired - vdot0;
  w_ = e_;
  choleskySolve(M_, w_);
  // y = N_zᵀ [w; 0] = [w; 0] − Cᵀ G⁻¹ C_v w / w_a
  auto mu = mu_.head(m);
  auto t = t_.head(m);
  t.noalias() = Cv * w_;
  mu.noalias() = (1.0 / wa) * Ginv * t;
  yv_ = w_;
  yv_.noalias() -= Cv.transpose() * mu;
  auto yc = yc_.head(nc);
  yc.noalias() = Hb * mu.head(nb);  // −C_cᵀ μ = H_b μ_b
  // N_z y = y − Q_z⁻¹ Cᵀ G⁻¹ C y,  C y = C_v y_v + C_c y_c
  t.noalias() = Cv * yv_;
  t.head(nb).noalias() -= Hb.transpose() * yc;
  mu.noalias() = Ginv * t;
  vdot = vdot0 + yv_;
  vdot.noalias() -= (1.0 / wa) * Cv.transpose() * mu;
  tau_C = tauC0 + yc;
  tau_C.noalias() += (1.0 / wf) * Hb * mu.head(nb);

  // τ_J from the joint rows: τ_J = (A v̇ + b − H_Cᵀ τ_C)_joints.
  tau_J = b.tail(nj);
  tau_J.noalias() += A.bottomRows(nj) * vdot;
  tau_J.noalias() -= H_C.rightCols(nj).transpose() * tau_C;
  return status;
}

}  // namespace dynfilter
