#include "dynfilter/core/qp_solver.hpp"

namespace dynfilter {

DenseQp::DenseQp(int n, int n_eq, int n_in)
    : H(Eigen::MatrixXd::Zero(n, n)),
      g(Eigen::VectorXd::Zero(n)),
      A(Eigen::MatrixXd::Zero(n_eq, n)),
      b(Eigen::VectorXd::Zero(n_eq)),
      C(Eigen::MatrixXd::Zero(n_in, n)),
      l(Eigen::VectorXd::Constant(n_in, -kQpInfinity)),
      u(Eigen::VectorXd::Constant(n_in, kQpInfinity)),
      x_lower(Eigen::VectorXd::Constant(n, -kQpInfinity)),
      x_upper(Eigen::VectorXd::Constant(n, kQpInfinity)) {}

const char* toString(QpSolveStatus status) {
  switch (status) {
    case QpSolveStatus::kSolved: return "solved";
    case QpSolveStatus::kMaxIterations: return "max_iterations";
    case QpSolveStatus::kPrimalInfeasible: return "primal_infeasible";
    case QpSolveStatus::kDualInfeasible: return "dual_infeasible";
    case QpSolveStatus::kNotFinite: return "not_finite";
  }
  return "unknown";
}

}  // namespace dynfilter
