#include "active_set_step.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

namespace dynfilter::qp_active_set {
namespace {

bool finite(double bound) { return std::abs(bound) < kQpInfinity; }

}  // namespace

ActiveSetStep::ActiveSetStep(int n, int n_eq, int n_in)
    : n_(n),
      n_eq_(n_eq),
      n_in_(n_in),
      side_(static_cast<std::size_t>(n_in + n), 0),
      H_ff_(n, n),
      W_(n, n_eq + n_in),
      S_(n_eq + n_in, n_eq + n_in),
      v_(n),
      h_(n_eq + n_in),
      lambda_(n_eq + n_in),
      stationarity_(n) {
  free_.reserve(static_cast<std::size_t>(n));
  rows_.reserve(static_cast<std::size_t>(n_in));
}

void ActiveSetStep::guessFromMultipliers(const DenseQp& p, const Eigen::Ref<const Eigen::VectorXd>& z) {
  for (int r = 0; r < n_in_; ++r)
    side_[static_cast<std::size_t>(r)] = z[r] > 0.0 && finite(p.u[r]) ? 1 : z[r] < 0.0 && finite(p.l[r]) ? -1 : 0;
  for (int i = 0; i < n_; ++i)
    side_[static_cast<std::size_t>(n_in_ + i)] =
        z[n_in_ + i] > 0.0 && finite(p.x_upper[i]) ? 1 : z[n_in_ + i] < 0.0 && finite(p.x_lower[i]) ? -1 : 0;
  has_guess_ = true;
}

bool ActiveSetStep::solveOnSides(const DenseQp& p, Eigen::Ref<Eigen::VectorXd> x,
                                 Eigen::Ref<Eigen::VectorXd> y, Eigen::Ref<Eigen::VectorXd> z) {
  free_.clear();
  rows_.clear();
  for (int i = 0; i < n_; ++i) {
    const signed char s = side_[static_cast<std::size_t>(n_in_ + i)];
    if (s == 0) free_.push_back(i);
    x[i] = s > 0 ? p.x_upper[i] : s < 0 ? p.x_lower[i] : 0.0;  // free ones 0 for now
  }
  for (int r = 0; r < n_in_; ++r)
    if (side_[static_cast<std::size_t>(r)] != 0) rows_.push_back(r);
  const int nf = static_cast<int>(free_.size());
  const int m = n_eq_ + static_cast<int>(rows_.size());
  if (m > nf || nf == 0) return false;

  // Reduced problem on the free variables (x holds the fixed ones, 0 elsewhere):
  // min ½ x_Fᵀ H_FF x_F + v_Fᵀ x_F  s.t.  G_F x_F = h,  v_F = g_F + H_FB x_B.
  auto H = H_ff_.topLeftCorner(nf, nf);
  auto v = v_.head(nf);
  for (int a = 0; a < nf; ++a) {
    const int fa = free_[static_cast<std::size_t>(a)];
    for (int b = a; b < nf; ++b) H(b, a) = p.H(free_[static_cast<std::size_t>(b)], fa);
    v[a] = p.g[fa] + p.H.col(fa).dot(x);
  }
  auto W = W_.topLeftCorner(nf, m);  // G_Fᵀ, then L⁻¹ G_Fᵀ
  auto h = h_.head(m);
  for (int k = 0; k < m; ++k) {
    const bool eq = k < n_eq_;
    const int r = eq ? k : rows_[static_cast<std::size_t>(k - n_eq_)];
    const auto row = eq ? p.A.row(r) : p.C.row(r);
    const double rhs = eq ? p.b[r] : side_[static_cast<std::size_t>(r)] > 0 ? p.u[r] : p.l[r];
    h[k] = rhs - row.dot(x);
    for (int a = 0; a < nf; ++a) W(a, k) = row[free_[static_cast<std::size_t>(a)]];
  }
  Eigen::Ref<Eigen::MatrixXd> H_ref(H);
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt_H(H_ref);  // in place
  if (llt_H.info() != Eigen::Success) return false;
  llt_H.matrixL().solveInPlace(W);
  llt_H.matrixL().solveInPlace(v);
  // Multipliers: (G H⁻¹ Gᵀ) λ = −(h + G H⁻¹ v_F); then x_F = −H⁻¹ (v_F + G_Fᵀ λ).
  auto S = S_.topLeftCorner(m, m);
  auto lambda = lambda_.head(m);
  if (m > 0) {
    S.setZero();
    S.selfadjointView<Eigen::Lower>().rankUpdate(W.transpose());
    lambda = -h;
    lambda.noalias() -= W.transpose() * v;
    Eigen::Ref<Eigen::MatrixXd> S_ref(S);
    Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt_S(S_ref);
    if (llt_S.info() != Eigen::Success) return false;
    llt_S.solveInPlace(lambda);
    v.noalias() += W * lambda;
  }
  llt_H.matrixU().solveInPlace(v);
  for (int a = 0; a < nf; ++a) x[free_[static_cast<std::size_t>(a)]] = -v[a];

  // Multipliers in ProxQP's convention (H x + g + Aᵀ y + Cᵀ z = 0); the box's from the
  // stationarity rows of the fixed variables.
  y = lambda.head(n_eq_);
  z.setZero();
  for (int k = n_eq_; k < m; ++k) z[rows_[static_cast<std::size_t>(k - n_eq_)]] = lambda[k];
  stationarity_ = p.g;
  stationarity_.noalias() += p.H * x;
  stationarity_.noalias() += p.A.transpose() * y;
  stationarity_.noalias() += p.C.transpose() * z.head(n_in_);
  for (int i = 0; i < n_; ++i)
    if (side_[static_cast<std::size_t>(n_in_ + i)] != 0) z[n_in_ + i] = -stationarity_[i];
  return x.allFinite() && z.allFinite();
}

int ActiveSetStep::solve(const DenseQp& p, double eps, int max_steps, Eigen::Ref<Eigen::VectorXd> x,
                         Eigen::Ref<Eigen::VectorXd> y, Eigen::Ref<Eigen::VectorXd> z) {
  if (!has_guess_) return 0;
  // Bounds that are gone (a relaxation dropped them) leave the guess.
  for (int r = 0; r < n_in_; ++r) {
    signed char& s = side_[static_cast<std::size_t>(r)];
    if ((s > 0 && !finite(p.u[r])) || (s < 0 && !finite(p.l[r]))) s = 0;
  }
  for (int i = 0; i < n_; ++i) {
    signed char& s = side_[static_cast<std::size_t>(n_in_ + i)];
    if ((s > 0 && !finite(p.x_upper[i])) || (s < 0 && !finite(p.x_lower[i]))) s = 0;
  }
  for (int step = 1; step <= max_steps; ++step) {
    if (!solveOnSides(p, x, y, z)) break;
    // The equality and active rows hold, and stationarity on the free variables, to eps:
    // else the system was too ill-conditioned for this shortcut.
    double residual = 0.0;
    for (int k = 0; k < n_eq_; ++k) residual = std::max(residual, std::abs(p.A.row(k).dot(x) - p.b[k]));
    for (const int r : rows_)
      residual = std::max(residual, std::abs(p.C.row(r).dot(x) - (side_[static_cast<std::size_t>(r)] > 0 ? p.u[r] : p.l[r])));
    double dual = 0.0;
    for (const int i : free_) dual = std::max(dual, std::abs(stationarity_[i]));
    if (!(residual <= eps) || !(dual <= eps)) break;
    // Primal feasibility of the inactive sides, dual feasibility of the active ones; a
    // violated condition corrects the guess for the next step.
    bool optimal = true;
    auto check = [&](int k, double value, double lower, double upper) {
      signed char& s = side_[static_cast<std::size_t>(k)];
      if (s == 0) {
        if (value > upper + eps) s = 1, optimal = false;
        else if (value < lower - eps) s = -1, optimal = false;
      } else if ((s > 0 && z[k] < -eps) || (s < 0 && z[k] > eps)) {
        s = 0;
        optimal = false;
      }
    };
    for (int r = 0; r < n_in_; ++r) check(r, p.C.row(r).dot(x), p.l[r], p.u[r]);
    for (int i = 0; i < n_; ++i) check(n_in_ + i, x[i], p.x_lower[i], p.x_upper[i]);
    if (optimal) {
      residual_ = residual;
      return step;
    }
  }
  has_guess_ = false;
  return 0;
}

}  // namespace dynfilter::qp_active_set
