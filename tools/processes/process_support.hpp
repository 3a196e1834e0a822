#pragma once
// Plumbing shared by the LCM processes: clocks, a fixed-rate ticker, stop signals.

#include <atomic>
#include <cstdint>
#include <ctime>

namespace CLI {
class App;
}

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

/// Keeps every CPU out of idle states that take longer than a bound to leave, through the
/// kernel's PM QoS request file /dev/cpu_dma_latency, for the holder's lifetime (as
/// real-time test tools such as cyclictest do). A halted CPU wakes slowly — on a virtual
/// machine a halted vCPU costs a VM exit — and delays both the delivery of a message to a
/// thread that waits for it and the tick that follows (BENCHMARKS.md, real-time loop).
class CpuWakeLatencyHold {
 public:
  /// @p max_us: the longest wake-up allowed (µs; 0: CPUs only poll when idle); negative:
  /// no request, the machine's setting stays. Best effort: without permission (the file
  /// is root's) nothing is held, and note() says so.
  explicit CpuWakeLatencyHold(int max_us);
  ~CpuWakeLatencyHold();
  CpuWakeLatencyHold(const CpuWakeLatencyHold&) = delete;
  CpuWakeLatencyHold& operator=(const CpuWakeLatencyHold&) = delete;
  bool held() const { return fd_ >= 0; }
  const char* note() const { return note_; }

 private:
  int fd_ = -1;
  char note_[96] = {};
};

/// The machine's current bound on CPU wake-up latency (µs), read from /dev/cpu_dma_latency;
/// -1 when it cannot be read.
long currentCpuWakeLatencyUs();

/// What every real-time process (dynfilter, dynfilter-sim) takes on its command line.
struct RealtimeProcessOptions {
  int cpu = -1;                 ///< --cpu: run the whole process on this CPU (-1: any)
  int cpu_wake_latency_us = 0;  ///< --cpu-wake-latency-us: CpuWakeLatencyHold's bound (µs)
};
/// Adds --cpu and --cpu-wake-latency-us to @p app, parsed into @p options.
void addRealtimeProcessOptions(CLI::App& app, RealtimeProcessOptions& options);
/// Applies @p options: pins the process to its CPU (call it before any thread starts,
/// LCM's too) and returns the wake-latency hold, to be kept for the process's lifetime.
/// Throws as pinProcessToCpu does.
CpuWakeLatencyHold applyRealtimeProcessOptions(const RealtimeProcessOptions& options);

/// Restricts the whole process (the calling thread and every thread started after) to CPU
/// @p cpu. Throws std::runtime_error naming the CPU when that is not possible.
void pinProcessToCpu(int cpu);

}  // namespace dynfilter::processes
