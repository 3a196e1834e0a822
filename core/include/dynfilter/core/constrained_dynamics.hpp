#pragma once
/// @file
/// The constrained equation of motion used the other ways round: forward dynamics with
/// given torques (Eq. 14, the simulator mode), the plastic impact that starts a contact,
/// and the residual of Eq. 12 that defines "physically consistent".

#include <Eigen/Core>

namespace dynfilter {

/// Residual of Eq. 12, W x − u, for x = (v̇, τ_C, τ_J):
///   rows 0..nv−1:      A v̇ + b − H_Cᵀ τ_C − H_Jᵀ τ_J   (the first nb rows have no τ_J)
///   rows nv..nv+N_C−1: H_C v̇ − u_C
struct Eq12Residual {
  double max_abs = 0.0;       ///< over all rows
  double base_max_abs = 0.0;  ///< over the nb unactuated base rows (N, N m)
};

/// Evaluates the residual without allocating: @p scratch has at least nv entries.
Eq12Residual eq12Residual(const Eigen::Ref<const Eigen::MatrixXd>& A,
                          const Eigen::Ref<const Eigen::VectorXd>& b,
                          const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                          const Eigen::Ref<const Eigen::VectorXd>& u_C, int nb,
                          const Eigen::Ref<const Eigen::VectorXd>& vdot,
                          const Eigen::Ref<const Eigen::VectorXd>& tau_C,
                          const Eigen::Ref<const Eigen::VectorXd>& tau_J,
                          Eigen::Ref<Eigen::VectorXd> scratch);

/// Relative size below which a constraint row counts as dependent on others: the part of
/// the row outside their span, over the row's norm.
constexpr double kDependentRowTolerance = 1e-6;

/// Builds an orthonormal basis of constraint rows one row at a time (Gram-Schmidt,
/// orthogonalised twice for round-off): appends @p h (a row of length n) as column @p kept
/// of @p basis (n × capacity) when its part outside columns 0..kept−1 exceeds
/// kDependentRowTolerance of its norm, and increments @p kept. Returns whether it did;
/// false for a row that depends on those kept (or is zero). Does not allocate.
bool appendIndependentRow(Eigen::Ref<Eigen::MatrixXd> basis, int& kept,
                          const Eigen::Ref<const Eigen::RowVectorXd, 0, Eigen::InnerStride<>>& h);

/// Eq. 14 and the plastic impact, with buffers allocated once.
class ConstrainedDynamics {
 public:
  ConstrainedDynamics(int nv, int nb, int max_rows);

  /// Eq. 14: [A −H_Cᵀ; H_C 0] [v̇; τ_C] = [H_Jᵀ τ_J − b; u_C].
  /// @return false when H_C A⁻¹ H_Cᵀ is singular (dependent constraint rows).
  bool forward(const Eigen::Ref<const Eigen::MatrixXd>& A,
               const Eigen::Ref<const Eigen::VectorXd>& b,
               const Eigen::Ref<const Eigen::MatrixXd>& H_C,
               const Eigen::Ref<const Eigen::VectorXd>& u_C,
               const Eigen::Ref<const Eigen::VectorXd>& tau_J, Eigen::Ref<Eigen::VectorXd> vdot,
               Eigen::Ref<Eigen::VectorXd> tau_C);

  /// Plastic impact on every constrained axis: v⁺ = v − A⁻¹ H_Cᵀ (H_C A⁻¹ H_Cᵀ)⁻¹ H_C v,
  /// the velocity closest to v in the kinetic-energy metric with H_C v⁺ = 0. Writes the
  /// impulse (N s, N m s, per constrained axis) to @p impulse. Dependent rows (e.g. two
  /// touching bodies one joint apart) ask nothing the others do not: the impact is taken
  /// on the rows that are independent in order, the others get no impulse. Returns false
  /// if A is not positive definite.
  bool plasticImpact(const Eigen::Ref<const Eigen::MatrixXd>& A,
                     const Eigen::Ref<const Eigen::MatrixXd>& H_C, Eigen::Ref<Eigen::VectorXd> v,
                     Eigen::Ref<Eigen::VectorXd> impulse);

 private:
  // Factorises A and forms X = A⁻¹ H_Cᵀ and S = H_C X (factorised).
  bool factorise(const Eigen::Ref<const Eigen::MatrixXd>& A,
                 const Eigen::Ref<const Eigen::MatrixXd>& H_C);

  int nv_, nb_;
  Eigen::MatrixXd L_;  // nv × nv Cholesky of A
  Eigen::MatrixXd X_;  // nv × N_C
  Eigen::MatrixXd S_;  // N_C × N_C Cholesky of H_C A⁻¹ H_Cᵀ
  Eigen::VectorXd a0_, r_;
  Eigen::MatrixXd basis_;      // nv × max_rows: orthonormal basis of the rows kept
  Eigen::MatrixXd H_kept_;     // max_rows × nv: the independent rows of an impact
  Eigen::VectorXi kept_rows_;  // max_rows: their indices in H_C
};

}  // namespace dynfilter
