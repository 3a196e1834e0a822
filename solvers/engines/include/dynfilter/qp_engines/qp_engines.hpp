#pragma once
/// @file
/// The QP engines built into dynfilter, by name, for tools and bindings that let the user
/// choose (configuration key qp.solver.engine, QpSolverSettings::engine).

#include <string>

#include "dynfilter/core/qp_solver.hpp"

namespace dynfilter::qp_engines {

/// The filter's QP engines: "daqp" (the default: dual active set, hot-started, bounded
/// work per solve) and "proxqp" (proximal augmented Lagrangian). Throws
/// std::invalid_argument naming the known engines when @p name is none of them.
QpSolverFactory factory(const std::string& name);

}  // namespace dynfilter::qp_engines
