#include "process_support.hpp"

#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>

#include <CLI/CLI.hpp>
#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

namespace dynfilter::processes {

std::atomic<bool> g_stop{false};

namespace {
void onSignal(int) { g_stop = true; }

constexpr const char* kCpuLatencyFile = "/dev/cpu_dma_latency";

timespec toTimespec(double s) {
  timespec t;
  t.tv_sec = static_cast<time_t>(std::floor(s));
  t.tv_nsec = static_cast<long>((s - std::floor(s)) * 1e9);
  return t;
}
double toSeconds(const timespec& t) { return static_cast<double>(t.tv_sec) + 1e-9 * t.tv_nsec; }
}  // namespace

void installStopHandlers() {
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
}

double nowSeconds() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return toSeconds(t);
}

std::int64_t nowMicros() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1000000 + t.tv_nsec / 1000;
}

Ticker::Ticker(double rate_hz) : period_s_(1.0 / rate_hz) {
  clock_gettime(CLOCK_MONOTONIC, &next_);
}

long Ticker::wait() {
  double next = toSeconds(next_) + period_s_;
  long missed = 0;
  const double now = nowSeconds();
  if (now > next + period_s_) {  // late by more than a period: skip, don't burst
    missed = static_cast<long>(std::floor((now - next) / period_s_));
    next += static_cast<double>(missed) * period_s_;
  }
  next_ = toTimespec(next);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next_, nullptr) != 0 && !g_stop) {
  }
  return missed;
}

CpuWakeLatencyHold::CpuWakeLatencyHold(int max_us) {
  if (max_us < 0) {
    std::snprintf(note_, sizeof note_, "CPU wake latency left to the machine");
    return;
  }
  fd_ = ::open(kCpuLatencyFile, O_WRONLY | O_CLOEXEC);
  // The kernel takes the request as a binary 32-bit value and holds it while the file is open.
  const std::int32_t value = max_us;
  if (fd_ >= 0 && ::write(fd_, &value, sizeof value) != static_cast<ssize_t>(sizeof value)) {
    ::close(fd_);
    fd_ = -1;
  }
  if (fd_ >= 0)
    std::snprintf(note_, sizeof note_, "CPU wake latency <= %d us", max_us);
  else
    std::snprintf(note_, sizeof note_, "CPU wake latency not held (%s: %s)", kCpuLatencyFile,
                  std::strerror(errno));
}

CpuWakeLatencyHold::~CpuWakeLatencyHold() {
  if (fd_ >= 0) ::close(fd_);
}

long currentCpuWakeLatencyUs() {
  const int fd = ::open(kCpuLatencyFile, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  std::int32_t value = -1;
  const bool ok = ::read(fd, &value, sizeof value) == static_cast<ssize_t>(sizeof value);
  ::close(fd);
  return ok ? value : -1;
}

void addRealtimeProcessOptions(CLI::App& app, RealtimeProcessOptions& options) {
  app.add_option("--cpu", options.cpu, "run the whole process on this CPU only (e.g. one of its own: "
                 "BENCHMARKS.md, real-time loop)");
  app.add_option("--cpu-wake-latency-us", options.cpu_wake_latency_us,
                 "while running, keep CPUs out of idle states slower than this to leave "
                 "(/dev/cpu_dma_latency, needs root; negative: the machine's setting)");
}

CpuWakeLatencyHold applyRealtimeProcessOptions(const RealtimeProcessOptions& options) {
  if (options.cpu >= 0) pinProcessToCpu(options.cpu);
  return CpuWakeLatencyHold(options.cpu_wake_latency_us);
}

void pinProcessToCpu(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (cpu < 0 || cpu >= CPU_SETSIZE) throw std::runtime_error("--cpu " + std::to_string(cpu) + ": no such CPU");
  CPU_SET(cpu, &set);
  if (sched_setaffinity(0, sizeof set, &set) != 0)
    throw std::runtime_error("--cpu " + std::to_string(cpu) + ": " + std::strerror(errno));
}

const char* tryRealtimeScheduling(int priority) {
  sched_param p{};
  p.sched_priority = priority;
  const bool fifo = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0;
  const bool locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;
  if (fifo && locked) return "SCHED_FIFO, memory locked";
  if (fifo) return "SCHED_FIFO (memory not locked)";
  return "normal scheduling (no permission for SCHED_FIFO)";
}

}  // namespace dynfilter::processes
