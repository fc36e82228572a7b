#pragma once
// Synthetic vessel trees and rigid offsets for the global start's tests (test_global_start.cpp,
// test_global_start_resect.cpp). Millimetres, one world frame.
#include "core/config.hpp"
#include "core/geometry/skeleton.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

namespace brainshift::constraints::test_trees {

inline constexpr double deg = std::numbers::pi / 180.0;

/// Appends a polyline (points joined in order) to a skeleton.
inline void add_polyline(core::Skeleton& s, const std::vector<Vector3d>& line) {
  const auto first = static_cast<index_t>(s.points.rows());
  s.points.conservativeResize(first + static_cast<Eigen::Index>(line.size()), 3);
  for (std::size_t k = 0; k < line.size(); ++k)
    s.points.row(first + static_cast<Eigen::Index>(k)) = line[k].transpose();
  for (std::size_t k = 1; k < line.size(); ++k)
    s.segments.push_back({first + static_cast<index_t>(k) - 1, first + static_cast<index_t>(k)});
}

/// A cortical-like tree on a 60 mm sphere (centre at the origin, cap around +z): 3 roots, two
/// generations of bifurcations, each branch a wiggly arc of 1 mm segments (≈ 20 branches).
inline core::Skeleton cortical_tree(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  core::Skeleton s;
  s.points.resize(0, 3);
  const double R = 60.0;
  auto on_sphere = [&](const Vector3d& d) { return Vector3d(R * d.normalized()); };
  struct Start {
    Vector3d at, dir;
    int gen;
  };
  std::vector<Start> todo;
  for (int r = 0; r < 3; ++r) {
    const double phi = 2 * std::numbers::pi * r / 3 + 0.3;
    todo.push_back({on_sphere(Vector3d(0.6 * std::cos(phi), 0.6 * std::sin(phi), 1)),
                    Vector3d(-std::cos(phi), -std::sin(phi), 0).normalized(), 0});
  }
  while (!todo.empty()) {
    const Start b = todo.back();
    todo.pop_back();
    const double len = 18.0 + 12.0 * u(rng), amp = 1.0 + u(rng), wave = 8.0 + 8.0 * u(rng);
    std::vector<Vector3d> line;
    Vector3d p = b.at, d = b.dir;
    for (double l = 0; l <= len; l += 1.0) {
      const Vector3d n = p.normalized();
      const Vector3d side = n.cross(d).normalized();
      line.push_back(on_sphere(p + amp * std::sin(2 * std::numbers::pi * l / wave) * side));
      d = (d - d.dot(n) * n).normalized();
      p = on_sphere(p + d);
    }
    add_polyline(s, line);
    if (b.gen < 2)
      for (const double turn : {-0.6, 0.6}) {
        const Vector3d n = line.back().normalized();
        const Vector3d dd = Eigen::AngleAxisd(turn, n) * d;
        todo.push_back({line.back(), dd, b.gen + 1});
      }
  }
  return s;
}

/// Parallel wavy vessels spaced `spacing` mm along y on a gently curved sheet (z ≈ 60 mm), each
/// with its own wavelength and phase, and one vessel crossing them: a dense tree.
inline core::Skeleton parallel_vessels(int count, double spacing) {
  core::Skeleton s;
  s.points.resize(0, 3);
  auto sheet = [](double x, double y) { return Vector3d(x, y, 60.0 - (x * x + y * y) / 120.0); };
  for (int k = 0; k < count; ++k) {
    const double y0 = (k - 0.5 * (count - 1)) * spacing, wave = 9.0 + 1.7 * k, phase = 0.9 * k;
    std::vector<Vector3d> line;
    for (double x = -30; x <= 30; x += 1.0)
      line.push_back(sheet(x, y0 + 0.8 * std::sin(2 * std::numbers::pi * x / wave + phase)));
    add_polyline(s, line);
  }
  std::vector<Vector3d> cross;
  for (double y = -0.5 * count * spacing; y <= 0.5 * count * spacing; y += 1.0)
    cross.push_back(sheet(-12.0 + 0.3 * y, y));
  add_polyline(s, cross);
  return s;
}

/// Points every `step` mm along the segments with N(0, σ²) noise per axis.
inline MatrixX3d sample(const core::Skeleton& s, double step, double sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<Vector3d> out;
  double carry = 0.0;
  for (const auto& e : s.segments) {
    const Vector3d a = s.points.row(e[0]).transpose(), b = s.points.row(e[1]).transpose();
    const double len = (b - a).norm();
    double at = carry;
    for (; at < len; at += step)
      out.push_back(a + (at / len) * (b - a) + Vector3d(noise(rng), noise(rng), noise(rng)));
    carry = at - len;
  }
  MatrixX3d m(static_cast<Eigen::Index>(out.size()), 3);
  for (std::size_t i = 0; i < out.size(); ++i)
    m.row(static_cast<Eigen::Index>(i)) = out[i].transpose();
  return m;
}

/// The tracking offset O (rotation `angle_deg` about a skew axis through `pivot`, then a
/// translation of `mm` along a skew direction): intra-operative points are O·p_model, so the
/// start must return O⁻¹.
inline Eigen::Isometry3d offset(double mm, double angle_deg, const Vector3d& pivot,
                                const Vector3d& dir = {0.5, 0.8, -0.33}) {
  Eigen::Isometry3d O = Eigen::Isometry3d::Identity();
  O.translate(pivot);
  O.rotate(Eigen::AngleAxisd(angle_deg * deg, Vector3d(1.0, -2.0, 0.5).normalized()));
  O.translate(-pivot);
  O.pretranslate(mm * dir.normalized());
  return O;
}

inline MatrixX3d apply(const Eigen::Isometry3d& T, const MatrixX3d& p) {
  return ((p * T.linear().transpose()).rowwise() + T.translation().transpose()).eval();
}

/// Largest distance between where the estimate and the truth put the model points (mm).
inline double max_error(const Eigen::Isometry3d& est, const Eigen::Isometry3d& truth,
                        const MatrixX3d& intra) {
  return (apply(est, intra) - apply(truth, intra)).rowwise().norm().maxCoeff();
}

}  // namespace brainshift::constraints::test_trees
