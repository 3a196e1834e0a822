// Counts heap allocations of the executable it is linked into: replaces the global
// operator new and interposes glibc's malloc family (Eigen's matrices and temporaries
// allocate with std::malloc, which counting operator new alone never sees).
#include "support/allocation_counter.hpp"

#include <cerrno>
#include <cstdlib>
#include <new>

namespace dynfilter::test::allocations {
std::atomic<bool> g_counting{false};
std::atomic<bool> g_in_backend{false};
std::atomic<long> g_core_new{0};      // operator new outside backend calls
std::atomic<long> g_core_malloc{0};   // malloc family called directly (Eigen) outside them
std::atomic<long> g_backend_allocations{0};

void countAllocation(std::atomic<long>& core) {
  if (g_counting.load(std::memory_order_relaxed))
    (g_in_backend.load(std::memory_order_relaxed) ? g_backend_allocations : core)++;
}
void resetCounts() {
  g_core_new = 0;
  g_core_malloc = 0;
  g_backend_allocations = 0;
}
}  // namespace dynfilter::test::allocations

#if !defined(__SANITIZE_ADDRESS__)  // ASan owns malloc: nothing is interposed there
using dynfilter::test::allocations::countAllocation;
using dynfilter::test::allocations::g_core_malloc;
using dynfilter::test::allocations::g_core_new;

// glibc's own entry points, exported for exactly this kind of interposition.
extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t n, std::size_t size);
void* __libc_realloc(void* p, std::size_t size);
void* __libc_memalign(std::size_t alignment, std::size_t size);
void __libc_free(void* p);

void* malloc(std::size_t size) {
  countAllocation(g_core_malloc);
  return __libc_malloc(size);
}
void* calloc(std::size_t n, std::size_t size) {
  countAllocation(g_core_malloc);
  return __libc_calloc(n, size);
}
void* realloc(void* p, std::size_t size) {
  countAllocation(g_core_malloc);
  return __libc_realloc(p, size);
}
void* aligned_alloc(std::size_t alignment, std::size_t size) {
  countAllocation(g_core_malloc);
  return __libc_memalign(alignment, size);
}
void* memalign(std::size_t alignment, std::size_t size) {
  countAllocation(g_core_malloc);
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, std::size_t alignment, std::size_t size) {
  if (alignment < sizeof(void*) || (alignment & (alignment - 1)) != 0) return EINVAL;
  countAllocation(g_core_malloc);
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}
}  // extern "C"

void* operator new(std::size_t size) {
  countAllocation(g_core_new);
  if (void* p = __libc_malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { __libc_free(p); }
void operator delete(void* p, std::size_t) noexcept { __libc_free(p); }
#endif  // !__SANITIZE_ADDRESS__
