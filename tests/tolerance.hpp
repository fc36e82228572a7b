#pragma once
/// @file
/// @brief The one tolerance helper of the tests: |a − b| ≤ abs + rel·max(|a|, |b|), with named
/// constants. Each use states why its tolerance is what it is.

#include <Eigen/Core>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace brainshift::tests {

/// Machine epsilon of double.
inline constexpr double eps = std::numeric_limits<double>::epsilon();

/// Relative difference ‖a − b‖ / max(‖b‖, floor) of two Eigen objects (Frobenius norms).
template <typename A, typename B>
double relative_difference(const A& a, const B& b, double floor = 1e-300) {
  return (a - b).norm() / std::max(b.norm(), floor);
}

/// gtest predicate: |a − b| ≤ abs + rel·max(|a|, |b|).
inline ::testing::AssertionResult near(double a, double b, double abs_tol, double rel_tol) {
  const double tol = abs_tol + rel_tol * std::max(std::abs(a), std::abs(b));
  if (std::abs(a - b) <= tol) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << a << " vs " << b << ": |diff| " << std::abs(a - b) << " > tol " << tol;
}

}  // namespace brainshift::tests
