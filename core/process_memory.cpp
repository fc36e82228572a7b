#include "core/process_memory.hpp"

#include <cstdlib>  // first: defines __GLIBC__ on glibc

#if defined(__GLIBC__)
#include <climits>

#include <cstdint>
#include <malloc.h>
#include <sys/mman.h>
#endif

namespace brainshift::core {

bool keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  // No block from mmap (so large blocks come from the heap and return to it), no trimming of the
  // heap's top, the heap grown 256 MiB at a time (fewer brk calls; untouched pages cost nothing),
  // and one arena for every thread (so the second thread's volumes are in that heap too).
  const bool no_mmap = mallopt(M_MMAP_MAX, 0) == 1;
  const bool no_trim = mallopt(M_TRIM_THRESHOLD, INT_MAX) == 1;
  const bool pad = mallopt(M_TOP_PAD, 256 << 20) == 1;
  const bool one_arena = mallopt(M_ARENA_MAX, 1) == 1;
  // Transparent huge pages for the heap's first GiB: grown once, marked MADV_HUGEPAGE and given
  // back to the allocator (never trimmed: 1.25 GiB < INT_MAX), so the volumes allocated in it
  // fault in 2 MiB at a time. Address space only: untouched pages cost nothing. Where THP is off
  // or the block cannot be had, nothing changes.
  constexpr std::size_t reserve = std::size_t(1) << 30, huge = std::size_t(2) << 20;
  if (void* p = std::malloc(reserve)) {
    const auto b = reinterpret_cast<std::uintptr_t>(p);
    const std::uintptr_t first = (b + huge - 1) / huge * huge, last = (b + reserve) / huge * huge;
    if (last > first) (void)madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
    std::free(p);
  }
  return no_mmap && no_trim && pad && one_arena;
#else
  return false;
#endif
}

}  // namespace brainshift::core
