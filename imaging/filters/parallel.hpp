#pragma once
/// @file
/// @brief A minimal parallel loop for the voxel filters: [0, n) split into contiguous chunks,
/// one per hardware thread (at most 8), the calling thread taking the first.

#include "core/parallel.hpp"

#include <algorithm>
#include <thread>
#include <vector>

namespace brainshift::imaging::filters {

/// Calls body(begin, end) on disjoint chunks covering [0, n), concurrently. `body` must only
/// write data owned by its chunk. Single-threaded when n is small or one thread is available.
template <typename F>
void parallel_for(int n, F&& body) {
  const int threads = std::min(core::hardware_threads(8), std::max(1, n / 4));
  if (threads <= 1) {
    body(0, n);
    return;
  }
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t)
    pool.emplace_back([&body, n, t, threads] {
      body(int(std::int64_t(n) * t / threads), int(std::int64_t(n) * (t + 1) / threads));
    });
  body(0, int(std::int64_t(n) / threads));
  for (auto& th : pool) th.join();
}

}  // namespace brainshift::imaging::filters
