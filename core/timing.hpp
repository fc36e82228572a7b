#pragma once
/// @file
/// @brief The one timing helper of the project: wall-clock seconds on the monotonic clock
/// (std::chrono::steady_clock, never adjusted), for the `seconds` fields of results and reports.

#include <chrono>

namespace brainshift::core {

/// The monotonic clock every timing in brainshift uses.
using Clock = std::chrono::steady_clock;

/// @brief Seconds elapsed since `t0` (a time taken with Clock::now()).
/// @param[in] t0 start time.
/// @return elapsed wall-clock time in s (≥ 0).
[[nodiscard]] inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// @brief A running stopwatch: started at construction, read with seconds().
class Stopwatch {
 public:
  /// Starts now.
  Stopwatch() : m_start(Clock::now()) {}
  /// Seconds since construction or the last restart(), s.
  [[nodiscard]] double seconds() const { return seconds_since(m_start); }
  /// Starts again from now.
  void restart() { m_start = Clock::now(); }

 private:
  Clock::time_point m_start;
};

}  // namespace brainshift::core
