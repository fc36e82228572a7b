#include "core/process_memory.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>
#include <utility>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

// glibc's allocator serves malloc (a sanitizer replaces it: then only the call is checked).
#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
#define BS_GLIBC_MALLOC 1
#endif

namespace brainshift::core {
namespace {

#if !defined(BS_GLIBC_MALLOC) && defined(__GLIBC__)
/// Under a sanitizer: the call does no harm and a 64 MiB block can still be had.
void expect_the_call_and_a_large_block() {
  (void)keep_freed_memory_for_reuse();
  void* a = std::malloc(std::size_t(64) << 20);
  EXPECT_NE(a, nullptr);
  std::free(a);
}
#endif

TEST(ProcessMemory, ALargeBlockComesFromTheHeapAndStaysThereWhenFreed) {
#if defined(BS_GLIBC_MALLOC)
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
#elif defined(__GLIBC__)  // under a sanitizer, whose allocator ignores (or refuses) the settings
  expect_the_call_and_a_large_block();
#else
  EXPECT_FALSE(keep_freed_memory_for_reuse());
#endif
}

#if defined(BS_GLIBC_MALLOC)
/// The mapping of /proc/self/smaps that holds `address`: its header line (with the name, e.g.
/// "[heap]") and its VmFlags line; empty strings when not found.
std::pair<std::string, std::string> mapping_of(const void* address) {
  const auto a = reinterpret_cast<std::uintptr_t>(address);
  std::ifstream smaps("/proc/self/smaps");
  std::string line, header;
  bool inside = false;
  while (std::getline(smaps, line)) {
    std::uintptr_t lo = 0, hi = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> lo >> dash >> hi && dash == '-') {
      inside = lo <= a && a < hi;
      header = line;
    } else if (inside && line.rfind("VmFlags:", 0) == 0) {
      return {header, line};
    }
  }
  return {};
}
#endif

TEST(ProcessMemory, EveryThreadsVolumesAreInTheOneHeapMarkedForHugePages) {
#if defined(BS_GLIBC_MALLOC)
  ASSERT_TRUE(keep_freed_memory_for_reuse());
  // A 64 MiB volume allocated on another thread: one arena, so it is in the main heap ("[heap]",
  // grown by brk), not in a thread arena's own mapping.
  constexpr std::size_t bytes = std::size_t(64) << 20;
  void* a = nullptr;
  std::thread([&] { a = std::malloc(bytes); }).join();
  ASSERT_NE(a, nullptr);
  // Its middle (its first bytes may lie before the marked range's first 2 MiB boundary).
  const auto [header, flags] = mapping_of(static_cast<const char*>(a) + bytes / 2);
  EXPECT_NE(header.find("[heap]"), std::string::npos) << header;
  // Marked MADV_HUGEPAGE ("hg" in VmFlags) unless this kernel has transparent huge pages off.
  std::ifstream thp("/sys/kernel/mm/transparent_hugepage/enabled");
  const std::string mode((std::istreambuf_iterator<char>(thp)), std::istreambuf_iterator<char>());
  if (!mode.empty() && mode.find("[never]") == std::string::npos) {
    EXPECT_NE(flags.find(" hg"), std::string::npos) << header << "\n" << flags;
  }
  std::free(a);
#elif defined(__GLIBC__)  // under a sanitizer, whose allocator ignores (or refuses) the settings
  expect_the_call_and_a_large_block();
#else
  EXPECT_FALSE(keep_freed_memory_for_reuse());
#endif
}

}  // namespace
}  // namespace brainshift::core
