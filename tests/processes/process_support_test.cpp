// The real-time plumbing of the LCM processes (tools/processes/process_support.hpp): the
// bound on CPU wake-up latency is the machine's while a hold lives, and comes back after.
// Reading and writing /dev/cpu_dma_latency needs root: the tests skip without it.

#include <algorithm>

#include <gtest/gtest.h>

#include "process_support.hpp"

namespace dynfilter::processes {
namespace {

TEST(CpuWakeLatencyHold, TheBoundIsTheStrictestRequestWhileHeldAndComesBackAfter) {
  const long before = currentCpuWakeLatencyUs();
  if (before < 0) GTEST_SKIP() << "/dev/cpu_dma_latency cannot be read here (needs root)";
  {
    const CpuWakeLatencyHold hold(7);
    ASSERT_TRUE(hold.held()) << hold.note();
    EXPECT_STREQ(hold.note(), "CPU wake latency <= 7 us");
    EXPECT_EQ(currentCpuWakeLatencyUs(), std::min(before, 7L));
    {
      const CpuWakeLatencyHold strict(0);
      EXPECT_EQ(currentCpuWakeLatencyUs(), 0);
      const CpuWakeLatencyHold loose(1000);  // the kernel keeps the strictest request
      EXPECT_EQ(currentCpuWakeLatencyUs(), 0);
    }
    EXPECT_EQ(currentCpuWakeLatencyUs(), std::min(before, 7L));
  }
  EXPECT_EQ(currentCpuWakeLatencyUs(), before);
}

TEST(CpuWakeLatencyHold, ANegativeBoundRequestsNothing) {
  const long before = currentCpuWakeLatencyUs();
  const CpuWakeLatencyHold hold(-1);
  EXPECT_FALSE(hold.held());
  EXPECT_STREQ(hold.note(), "CPU wake latency left to the machine");
  EXPECT_EQ(currentCpuWakeLatencyUs(), before);
}

}  // namespace
}  // namespace dynfilter::processes
