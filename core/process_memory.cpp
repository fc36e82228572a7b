#include "core/process_memory.hpp"

#include <cstdlib>  // first: defines __GLIBC__ on glibc

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace brainshift::core {

bool keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  // No block from mmap (so large blocks come from the heap and return to it), no trimming of the
  // heap's top, and the heap grown 256 MiB at a time (fewer brk calls; untouched pages cost
  // nothing).
  const bool no_mmap = mallopt(M_MMAP_MAX, 0) == 1;
  const bool no_trim = mallopt(M_TRIM_THRESHOLD, 1 << 30) == 1;
  const bool pad = mallopt(M_TOP_PAD, 256 << 20) == 1;
  return no_mmap && no_trim && pad;
#else
  return false;
#endif
}

}  // namespace brainshift::core
