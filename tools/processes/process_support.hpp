#pragma once
// Plumbing shared by the LCM processes: clocks, a fixed-rate ticker, stop signals.

#include <atomic>
#include <cstdint>
#include <ctime>

namespace dynfilter::processes {

/// Set by SIGINT / SIGTERM once installStopHandlers() ran.
extern std::atomic<bool> g_stop;
void installStopHandlers();

/// CLOCK_MONOTONIC in seconds and in microseconds (the processes' utime clock).
double nowSeconds();
std::int64_t nowMicros();

/// Sleeps until fixed deadlines at @p rate_hz (absolute, no drift). wait() returns the
/// number of whole periods that were missed (0 when on time) and skips past them.
class Ticker {
 public:
  explicit Ticker(double rate_hz);
  long wait();
  double period() const { return period_s_; }

 private:
  double period_s_;
  timespec next_{};
};

/// Best effort: real-time priority @p priority (SCHED_FIFO) for the calling thread and
/// locked memory when permitted; returns a note.
const char* tryRealtimeScheduling(int priority = 50);

/// Restricts the whole process (the calling thread and every thread started after) to CPU
/// @p cpu. Throws std::runtime_error naming the CPU when that is not possible.
void pinProcessToCpu(int cpu);

}  // namespace dynfilter::processes
