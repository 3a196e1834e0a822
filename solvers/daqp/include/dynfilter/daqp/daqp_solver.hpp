#pragma once
/// @file
/// IQpSolver on DAQP (Arnström, Bemporad and Axehill, "A dual active-set solver for
/// embedded quadratic programming using recursive LDLᵀ updates", IEEE TAC 2022): a
/// maintained dense dual active-set solver in C, built for real-time MPC, compiled from its
/// PyPI source distribution (solvers/daqp/CMakeLists.txt). A warm solve first tries the
/// last answer's active set (one KKT solve, every condition checked; solvers/active_set);
/// when that fails DAQP runs, hot-started from its last working set and capped at
/// kMaxWorkingSetChanges (or the share IQpSolver::limitNextSolve asked for), so a solve's
/// work is bounded. A solve whose H and g equal the last solve's keeps DAQP's factor of H
/// and forms only the rows' images again. Equality rows are always in the
/// working set: they hold to round-off in DAQP's answers (to eps_abs in the step's).
/// Memory is allocated at construction and on the first solve (DAQP's setup) only.

#include <memory>

#include "dynfilter/core/qp_solver.hpp"

namespace dynfilter::daqp {

/// Working-set changes per solve before it stops (QpSolveStatus::kMaxIterations), ~5 µs
/// each on the human figure. On every tick of the four CMU clips a solve that succeeds
/// needs at most 99; the proofs of infeasibility that start the relaxations took up to 290.
/// QpSolverSettings::max_iterations counts ProxQP's outer iterations and is not used.
constexpr int kMaxWorkingSetChanges = 150;

/// A DAQP instance for problems of dimension (n, n_eq, n_in) with box bounds.
/// H must be positive definite. Throws std::invalid_argument on invalid dimensions or
/// settings, std::runtime_error when DAQP cannot be set up.
std::unique_ptr<IQpSolver> makeSolver(int n, int n_eq, int n_in, const QpSolverSettings& settings);

/// The factory the filter's QP mode takes (FilterMode::kQp).
QpSolverFactory factory();

}  // namespace dynfilter::daqp
