#include "dynfilter/core/constrained_dynamics.hpp"

#include <Eigen/Cholesky>

namespace dynfilter {

Eq12Residual eq12Residual(const Eigen::Ref<const Eigen::MatrixXd>& A,
                          const Eigen::Ref<const Eigen::VectorXd>& b,
                          const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                          const Eigen::Ref<const Eigen::VectorXd>& u_C, int nb,
                          const Eigen::Ref<const Eigen::VectorXd>& vdot,
                          const Eigen::Ref<const Eigen::VectorXd>& tau_C,
                          const Eigen::Ref<const Eigen::VectorXd>& tau_J,
                          Eigen::Ref<Eigen::VectorXd> scratch) {
  const int nv = static_cast<int>(A.rows());
  auto r = scratch.head(nv);
  r = b;
  r.noalias() += A * vdot;
  r.noalias() -= H_C.transpose() * tau_C;
  r.tail(nv - nb) -= tau_J;
  Eq12Residual out;
  out.base_max_abs = nb > 0 ? r.head(nb).cwiseAbs().maxCoeff() : 0.0;
  out.max_abs = r.cwiseAbs().maxCoeff();
  for (int i = 0; i < H_C.rows(); ++i)
    out.max_abs = std::max(out.max_abs, std::abs(H_C.row(i).dot(vdot) - u_C[i]));
  return out;
}

ConstrainedDynamics::ConstrainedDynamics(int nv, int nb, int max_rows)
    : nv_(nv),
      nb_(nb),
      L_(Eigen::MatrixXd::Zero(nv, nv)),
      X_(Eigen::MatrixXd::Zero(nv, max_rows)),
      S_(Eigen::MatrixXd::Zero(max_rows, max_rows)),
      a0_(Eigen::VectorXd::Zero(nv)),
      r_(Eigen::VectorXd::Zero(max_rows)),
      basis_(Eigen::MatrixXd::Zero(nv, max_rows)),
      H_kept_(Eigen::MatrixXd::Zero(max_rows, nv)),
      kept_rows_(Eigen::VectorXi::Zero(max_rows)) {}

bool appendIndependentRow(Eigen::Ref<Eigen::MatrixXd> basis, int& kept,
                          const Eigen::Ref<const Eigen::RowVectorXd, 0, Eigen::InnerStride<>>& h) {
  if (kept >= basis.cols()) return false;
  auto w = basis.col(kept);
  w = h.transpose();
  const double norm = w.norm();
  for (int pass = 0; pass < 2; ++pass)
    for (int k = 0; k < kept; ++k) w -= basis.col(k).dot(w) * basis.col(k);
  const double outside = w.norm();
  if (!(outside > kDependentRowTolerance * norm)) return false;
  w /= outside;
  ++kept;
  return true;
}

bool ConstrainedDynamics::factorise(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                    const Eigen::Ref<const Eigen::MatrixXd>& H_C) {
  const int nc = static_cast<int>(H_C.rows());
  L_ = A;
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt_A(L_);
  if (llt_A.info() != Eigen::Success) return false;
  auto X = X_.leftCols(nc);
  X = H_C.transpose();
  L_.triangularView<Eigen::Lower>().solveInPlace(X);
  L_.triangularView<Eigen::Lower>().transpose().solveInPlace(X);
  auto S = S_.topLeftCorner(nc, nc);
  S.noalias() = H_C * X;
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt_S(S);
  return llt_S.info() == Eigen::Success;
}

bool ConstrainedDynamics::forward(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                  const Eigen::Ref<const Eigen::VectorXd>& b,
                                  const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                                  const Eigen::Ref<const Eigen::VectorXd>& u_C,
                                  const Eigen::Ref<const Eigen::VectorXd>& tau_J,
                                  Eigen::Ref<Eigen::VectorXd> vdot,
                                  Eigen::Ref<Eigen::VectorXd> tau_C) {
  const int nc = static_cast<int>(H_C.rows());
  if (!factorise(A, H_C)) return false;
  // a0 = A⁻¹ (H_Jᵀ τ_J − b)
  a0_ = -b;
  a0_.tail(nv_ - nb_) += tau_J;
  L_.triangularView<Eigen::Lower>().solveInPlace(a0_);
  L_.triangularView<Eigen::Lower>().transpose().solveInPlace(a0_);
  // (H_C A⁻¹ H_Cᵀ) τ_C = u_C − H_C a0
  auto r = r_.head(nc);
  r = u_C;
  r.noalias() -= H_C * a0_;
  const auto S = S_.topLeftCorner(nc, nc);
  S.triangularView<Eigen::Lower>().solveInPlace(r);
  S.triangularView<Eigen::Lower>().transpose().solveInPlace(r);
  tau_C = r;
  vdot = a0_;
  vdot.noalias() += X_.leftCols(nc) * r;
  return true;
}

bool ConstrainedDynamics::plasticImpact(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                        const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                                        Eigen::Ref<Eigen::VectorXd> v,
                                        Eigen::Ref<Eigen::VectorXd> impulse) {
  const int nc = static_cast<int>(H_C.rows());
  if (nc == 0) return true;
  int kept = 0;
  for (int i = 0; i < nc; ++i)
    if (appendIndependentRow(basis_, kept, H_C.row(i))) {
      kept_rows_[kept - 1] = i;
      H_kept_.row(kept - 1) = H_C.row(i);
    }
  if (kept == 0) return false;
  const auto H = H_kept_.topRows(kept);
  if (!factorise(A, H)) return false;
  auto r = r_.head(kept);
  r.noalias() = -H * v;
  const auto S = S_.topLeftCorner(kept, kept);
  S.triangularView<Eigen::Lower>().solveInPlace(r);
  S.triangularView<Eigen::Lower>().transpose().solveInPlace(r);
  impulse.setZero();
  for (int k = 0; k < kept; ++k) impulse[kept_rows_[k]] = r[k];
  v.noalias() += X_.leftCols(kept) * r;
  return true;
}

}  // namespace dynfilter
