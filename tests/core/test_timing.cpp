#include "core/timing.hpp"

#include <gtest/gtest.h>

namespace brainshift::core {
namespace {

// No assertion on how long anything takes (tests/README.md): only the clock's contract.
TEST(Timing, SecondsAreNonNegativeAndNeverDecrease) {
  const Clock::time_point t0 = Clock::now();
  const double a = seconds_since(t0);
  const double b = seconds_since(t0);
  EXPECT_GE(a, 0.0);  // steady_clock is monotonic: elapsed time cannot be negative
  EXPECT_GE(b, a);    // a later reading of the same start is never smaller
}

TEST(Timing, StopwatchRestartsFromNow) {
  Stopwatch w;
  const double before = w.seconds();
  EXPECT_GE(before, 0.0);  // monotonic clock
  const Clock::time_point outer = Clock::now();
  w.restart();
  const double since_restart = w.seconds();
  const double since_outer = seconds_since(outer);  // read after: its clock reading is later
  // The watch restarted after `outer` and was read before it, so it cannot show more time.
  EXPECT_LE(since_restart, since_outer);
}

}  // namespace
}  // namespace brainshift::core
