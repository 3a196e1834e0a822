#pragma once
// Internal: the clock the filter times its ticks and solves with.
#include <chrono>

namespace dynfilter::detail {

using TickClock = std::chrono::steady_clock;

/// Seconds from @p t0 to now.
inline double secondsSince(TickClock::time_point t0) {
  return std::chrono::duration<double>(TickClock::now() - t0).count();
}

}  // namespace dynfilter::detail
