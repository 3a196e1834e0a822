#pragma once
/// @file
/// The paper's solve of the constrained equation of motion (Eq. 12) by weighted
/// pseudo-inverse, null space and singularity-robust inverse (Eq. 21–23).
///
/// Unknowns x = (v̇ (nv), τ_C (N_C), τ_J (nj)); W x = u is
///   A v̇ − H_Cᵀ τ_C − H_Jᵀ τ_J = −b      (nv rows: nb base rows without τ_J, nj joint rows)
///   H_C v̇                      = u_C     (N_C rows; u_C = θ̈_C,desired − Ḣ_C v)
/// with H_J = [0 | I]. The paper's algorithm:
///   x⁰ = W^# u, N = E − W^# W, V_G = rows of N for v̇, y = V_G^* (v̇ᵈ − v̇⁰), x = x⁰ + N y,
/// with W^# the pseudo-inverse weighted by Q = diag(w_a I, w_f I, 0) — τ_J is not weighted:
/// it is whatever the joint rows require — and V_G^* = V_Gᵀ (V_G V_Gᵀ + k I)⁻¹.
///
/// Fast equivalent (what this class computes): the joint rows only define τ_J, so with
/// z = (v̇, τ_C) the real constraints are the nb base rows and the N_C contact rows,
/// C z = d with C = [A_b, −H_bᵀ; H_C, 0] ((nb + N_C) × (nv + N_C)). Then
///   G = C Q_z⁻¹ Cᵀ, z⁰ = Q_z⁻¹ Cᵀ G⁻¹ d, N_z = I − Q_z⁻¹ Cᵀ G⁻¹ C,
///   V_G V_Gᵀ = I − C_vᵀ R C_v with R = G⁻¹/w_a − β G⁻¹ C_c C_cᵀ G⁻¹, β = (1 − w_a/w_f)/w_a²,
/// so only (nb + N_C)-sized factorizations and one nv × nv Cholesky are needed. The test
/// suite checks that x equals the literal dense formulation to 1e-9 on random instances
/// with N_C ≤ nj and w_f ≤ w_a (the regime of a robot on its feet). With more contact
/// rows than joints G becomes ill-conditioned and the structured solve loses digits.

#include <cstdint>

#include <Eigen/Core>

#include "dynfilter/core/filter_options.hpp"

namespace dynfilter {

class PaperSolver {
 public:
  /// @param nv        generalized velocities (N_G)
  /// @param nb        unactuated base coordinates: 6 (floating base) or 0
  /// @param max_rows  largest N_C to be solved
  PaperSolver(int nv, int nb, int max_rows, const PaperSolverOptions& options);

  /// Solves Eq. 12 as above. No heap allocation.
  /// @param A nv × nv; @param b nv; @param H_C N_C × nv; @param u_C N_C;
  /// @param vdot_desired nv (v̇ᵈ); outputs vdot (nv), tau_C (N_C), tau_J (nv − nb).
  /// @return status bits (kStatusRankDeficient when the constraint rows were regularised).
  std::uint32_t solve(const Eigen::Ref<const Eigen::MatrixXd>& A,
                      const Eigen::Ref<const Eigen::VectorXd>& b,
                      const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                      const Eigen::Ref<const Eigen::VectorXd>& u_C,
                      const Eigen::Ref<const Eigen::VectorXd>& vdot_desired,
                      Eigen::Ref<Eigen::VectorXd> vdot, Eigen::Ref<Eigen::VectorXd> tau_C,
                      Eigen::Ref<Eigen::VectorXd> tau_J);

  /// Eq. 16: Eq. 12 with task rows J_P v̇ = r̈_Pᵈ − J̇_P v appended (no force acts along
  /// them). @param J_task N_P × nv (N_P ≤ 6); @param rhs_task N_P.
  std::uint32_t solve(const Eigen::Ref<const Eigen::MatrixXd>& A,
                      const Eigen::Ref<const Eigen::VectorXd>& b,
                      const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                      const Eigen::Ref<const Eigen::VectorXd>& u_C,
                      const Eigen::Ref<const Eigen::MatrixXd>& J_task,
                      const Eigen::Ref<const Eigen::VectorXd>& rhs_task,
                      const Eigen::Ref<const Eigen::VectorXd>& vdot_desired,
                      Eigen::Ref<Eigen::VectorXd> vdot, Eigen::Ref<Eigen::VectorXd> tau_C,
                      Eigen::Ref<Eigen::VectorXd> tau_J);

  const PaperSolverOptions& options() const { return options_; }

 private:
  static constexpr int kMaxTaskRows = 6;
  int nv_, nb_;
  PaperSolverOptions options_;
  Eigen::MatrixXd Cv_;     // (nb + N_C) × nv
  Eigen::MatrixXd G_;      // m × m, factorised in place
  Eigen::MatrixXd Ginv_;   // m × m
  Eigen::MatrixXd R_;      // m × m
  Eigen::MatrixXd RCv_;    // m × nv
  Eigen::MatrixXd M_;      // nv × nv: V_G V_Gᵀ + k I, factorised in place
  Eigen::MatrixXd HbTHb_;  // nb × nb
  Eigen::MatrixXd GinvE_;  // m × nb
  Eigen::VectorXd d_, lambda_, mu_, e_, w_, yv_, yc_, zv_, zc_, t_;
  Eigen::MatrixXd empty_task_;      // 0 × nv
  Eigen::VectorXd empty_task_rhs_;  // 0
};

}  // namespace dynfilter
