#pragma once
/// @file
/// A primal-dual active-set step ahead of an engine's own solve (ProxQP, DAQP): the optimum
/// of a strictly convex QP is the solution of one linear system once its active set is
/// known, and between two ticks of the filter the active set mostly stays. Given a guess
/// (the previous solution's active constraints), solve() solves the equality-constrained
/// QP on that set and checks every KKT condition; a few guesses are corrected (violated
/// rows in, wrongly signed multipliers out) before it gives up and the caller runs the
/// engine.
/// Private to the engines of solvers/; allocates only at construction.

#include <vector>

#include <Eigen/Core>

#include "dynfilter/core/qp_solver.hpp"

namespace dynfilter::qp_active_set {

class ActiveSetStep {
 public:
  ActiveSetStep(int n, int n_eq, int n_in);

  /// Forgets the guess (the next solve() returns false at once).
  void clear() { has_guess_ = false; }
  /// Takes the guess from multipliers in ProxQP's convention (DAQP's reordered): z (n_in + n: the rows of C,
  /// then the box) > 0 at an upper bound, < 0 at a lower bound. Sides whose bound is
  /// infinite in @p p are left inactive.
  void guessFromMultipliers(const DenseQp& p, const Eigen::Ref<const Eigen::VectorXd>& z);

  /// Tries up to @p max_steps guesses. On success (every KKT condition within @p eps: rows
  /// and bounds within eps, multipliers of the right sign within eps) writes the optimum
  /// x (n), the multipliers y (n_eq) and z (n_in + n), keeps the active set as the next
  /// guess and returns the number of linear solves (≥ 1). Returns 0 when it fails
  /// (singular system, residual beyond eps, or no guess satisfied the conditions).
  int solve(const DenseQp& p, double eps, int max_steps, Eigen::Ref<Eigen::VectorXd> x,
            Eigen::Ref<Eigen::VectorXd> y, Eigen::Ref<Eigen::VectorXd> z);

  /// Largest equality / active-row residual of the last successful solve.
  double residual() const { return residual_; }

 private:
  // One equality-constrained solve on the current sides; false when singular.
  bool solveOnSides(const DenseQp& p, Eigen::Ref<Eigen::VectorXd> x, Eigen::Ref<Eigen::VectorXd> y,
                    Eigen::Ref<Eigen::VectorXd> z);

  int n_, n_eq_, n_in_;
  bool has_guess_ = false;
  double residual_ = 0.0;
  std::vector<signed char> side_;  // n_in + n: +1 upper, −1 lower, 0 inactive
  std::vector<int> free_, rows_;   // free variables; active rows of C
  Eigen::MatrixXd H_ff_;           // n × n: H on the free variables, then its Cholesky factor
  Eigen::MatrixXd W_;              // n × (n_eq + n_in): L⁻¹ G_Fᵀ
  Eigen::MatrixXd S_;              // (n_eq + n_in)²: WᵀW = G_F H_FF⁻¹ G_Fᵀ
  Eigen::VectorXd v_, h_, lambda_, stationarity_;
};

}  // namespace dynfilter::qp_active_set
