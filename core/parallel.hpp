#pragma once
/// @file
/// @brief The one thread pool of the project's precomputations: independent chunks of work shared
/// out to a few threads (the machine targets have 2 cores; std::thread, no OpenMP). Each chunk must
/// write only its own outputs, so the result does not depend on the number of threads.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace brainshift::core {

/// The machine's hardware threads, at least 1 and at most `most`.
inline int hardware_threads(int most) {
  return std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, std::max(most, 1));
}

/// @brief Runs job(c) for c = 0 .. chunks − 1 on min(threads, chunks) threads (the caller's
/// thread is one of them); chunks are taken in increasing order, so put the largest first.
/// The first exception thrown by a job stops the others at their next chunk and is rethrown here.
template <class Job>
void parallel_chunks(std::size_t chunks, int threads, const Job& job) {
  const std::size_t nt = std::min<std::size_t>(static_cast<std::size_t>(std::max(threads, 1)),
                                               std::max<std::size_t>(chunks, 1));
  std::atomic<std::size_t> next{0};
  std::vector<std::exception_ptr> failure(nt);
  const auto worker = [&](std::size_t w) {
    try {
      for (std::size_t c = next++; c < chunks; c = next++) job(c);
    } catch (...) {
      failure[w] = std::current_exception();
      next = chunks;  // the others stop at their next chunk
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t w = 1; w < nt; ++w) pool.emplace_back(worker, w);
  worker(0);
  for (auto& t : pool) t.join();
  for (const auto& e : failure)
    if (e) std::rethrow_exception(e);
}

/// @brief Runs job(begin, end) over [0, count) in fixed blocks of `block` items, on up to
/// hardware_threads(most) threads; serial (one call, no thread started) when count ≤ block. The
/// blocks do not depend on the number of threads, so a job that writes only items [begin, end)
/// gives the same result on any machine.
template <class Job>
void parallel_blocks(std::size_t count, std::size_t block, int most, const Job& job) {
  block = std::max<std::size_t>(block, 1);
  if (count <= block) {
    job(std::size_t{0}, count);
    return;
  }
  const std::size_t chunks = (count + block - 1) / block;
  parallel_chunks(chunks, hardware_threads(most),
                  [&](std::size_t c) { job(c * block, std::min(count, (c + 1) * block)); });
}

}  // namespace brainshift::core
