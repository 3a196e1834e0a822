#pragma once
/// @file
/// IQpSolver on ProxQP (proxsuite's dense backend): a maintained proximal augmented-
/// Lagrangian QP solver, header-only, built on Eigen. Warm-started from the previous
/// solution of the same instance; the workspace is allocated at construction.

#include <memory>

#include "dynfilter/core/qp_solver.hpp"

namespace dynfilter::proxqp {

/// A ProxQP dense instance for problems of dimension (n, n_eq, n_in) with box bounds.
/// Throws std::invalid_argument on negative dimensions or invalid settings.
std::unique_ptr<IQpSolver> makeSolver(int n, int n_eq, int n_in, const QpSolverSettings& settings);

/// The factory the filter's QP mode takes (FilterMode::kQp).
QpSolverFactory factory();

}  // namespace dynfilter::proxqp
