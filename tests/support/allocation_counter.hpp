#pragma once
// Heap-allocation counting for the allocation tests: link support/allocation_counter.cpp
// into the test executable (it replaces operator new and the malloc family there).
// While g_counting is set, each allocation counts in g_core_new (operator new) or
// g_core_malloc (malloc family), or in g_backend_allocations while g_in_backend is set.
#include <atomic>

namespace dynfilter::test::allocations {
/// False in AddressSanitizer builds: ASan owns malloc there, so nothing is interposed or
/// counted and the allocation tests skip (the normal build runs them).
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kCounting = false;
#else
inline constexpr bool kCounting = true;
#endif
extern std::atomic<bool> g_counting;
extern std::atomic<bool> g_in_backend;
extern std::atomic<long> g_core_new;
extern std::atomic<long> g_core_malloc;
extern std::atomic<long> g_backend_allocations;
void countAllocation(std::atomic<long>& core);
void resetCounts();
}  // namespace dynfilter::test::allocations
