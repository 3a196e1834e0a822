#pragma once
/// @file
/// The clock the filter times its ticks and QP solves with (FilterOutput::tick_time_s,
/// solve_time_s, qp_solver_time_s). Internal to core.
#include <chrono>

namespace dynfilter::detail {

using TickClock = std::chrono::steady_clock;

/// Seconds from @p t0 to now.
inline double secondsSince(TickClock::time_point t0) {
  return std::chrono::duration<double>(TickClock::now() - t0).count();
}

}  // namespace dynfilter::detail
