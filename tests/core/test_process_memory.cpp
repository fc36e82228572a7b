#include "core/process_memory.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace brainshift::core {
namespace {

TEST(ProcessMemory, ALargeBlockComesFromTheHeapAndStaysThereWhenFreed) {
#if defined(__GLIBC__)
  ASSERT_TRUE(keep_freed_memory_for_reuse());
  // 64 MiB, above glibc's largest mmap threshold (32 MiB): by default a mapping of its own
  // (mallinfo2().hblks + 1), unmapped when freed. Kept for reuse: no mapping, and once freed its
  // bytes stay in the heap's free space (fordblks) for the next allocation.
  constexpr std::size_t bytes = std::size_t(64) << 20;
  const std::size_t mapped_before = mallinfo2().hblks;
  void* a = std::malloc(bytes);
  ASSERT_NE(a, nullptr);
  std::memset(a, 1, bytes);
  EXPECT_EQ(mallinfo2().hblks, mapped_before);
  std::free(a);
  EXPECT_GE(mallinfo2().fordblks, bytes);
#else
  EXPECT_FALSE(keep_freed_memory_for_reuse());
#endif
}

}  // namespace
}  // namespace brainshift::core
