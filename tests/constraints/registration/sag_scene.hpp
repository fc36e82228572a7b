#pragma once
/// @file
/// @brief The registration tests' analytic scene: an ellipsoid brain (semi-axes 40, 35, 30 mm)
/// fixed below z = −22 mm, six curved vessel branches in its upper half, and a smooth sag (10 mm
/// at the top) that is the truth. Intra-operative vessel points are sampled along the deformed
/// skeleton every 2.5 mm with Gaussian noise. Not built from the registration model.

#include "constraints/registration/registration.hpp"
#include "core/mesh/boundary.hpp"
#include "data_synth/geometry/structured_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

namespace brainshift::constraints {
namespace {

/// The loop tests' options (test_registration_loop.cpp, test_registration_trust.cpp): the
/// defaults, at most 60 iterations.
inline RegistrationOptions loop_options() {
  RegistrationOptions o;
  o.start = RigidStart::IDENTITY;  // the loop from the tracked frame (the scene's own frame)
  o.max_iterations = 60;
  return o;
}

/// Truth displacement (mm): a sag that grows towards the top of the ellipsoid (10 mm at the
/// top, 0 below z = −30) and bends sideways.
Vector3d truth(const Vector3d& X) {
  const double w = std::pow(std::clamp((X.z() + 30.0) / 60.0, 0.0, 1.0), 2.0);
  return Vector3d(2.0 * w * std::sin(X.y() / 20.0), 1.0 * w, -10.0 * w);
}

/// Vessels: curved branches in the upper half of the ellipsoid (semi-axes 40, 35, 30 mm).
core::Skeleton make_skeleton() {
  core::Skeleton s;
  std::vector<Vector3d> pts;
  for (int b = 0; b < 6; ++b) {
    const double phi = b * std::numbers::pi / 3.0;
    const int first = static_cast<int>(pts.size());
    for (int k = 0; k <= 12; ++k) {
      const double r = 3.0 + 2.2 * k;
      const Vector3d p(r * std::cos(phi + 0.25 * std::sin(0.6 * k + b)),
                       r * std::sin(phi + 0.25 * std::sin(0.6 * k + b)),
                       12.0 - 0.012 * r * r + 4.0 * std::sin(0.3 * k + b));
      pts.push_back(p);
      if (k > 0) s.segments.push_back({first + k - 1, first + k});
    }
  }
  s.points.resize(static_cast<Eigen::Index>(pts.size()), 3);
  for (std::size_t i = 0; i < pts.size(); ++i)
    s.points.row(static_cast<Eigen::Index>(i)) = pts[i].transpose();
  return s;
}

/// Intra-operative points every 2.5 mm along the deformed skeleton, with Gaussian noise.
inline MatrixX3d sample_deformed(const core::Skeleton& s, double noise, unsigned seed,
                                 double shift_scale = 1.0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, noise);
  std::vector<Vector3d> out;
  for (const auto& seg : s.segments) {
    const Vector3d a = s.points.row(seg[0]).transpose(), b = s.points.row(seg[1]).transpose();
    const int n = std::max(1, static_cast<int>((b - a).norm() / 2.5));
    for (int k = 0; k < n; ++k) {
      const Vector3d X = a + (b - a) * (k + 0.5) / n;
      out.push_back(X + shift_scale * truth(X) + Vector3d(g(rng), g(rng), g(rng)));
    }
  }
  MatrixX3d m(static_cast<Eigen::Index>(out.size()), 3);
  for (std::size_t i = 0; i < out.size(); ++i)
    m.row(static_cast<Eigen::Index>(i)) = out[i].transpose();
  return m;
}

struct Scene {
  core::TetMesh mesh = data_synth::make_ellipsoid_mesh({40, 35, 30}, 10);
  core::Skeleton skeleton = make_skeleton();
  std::unique_ptr<RegistrationModel> model;
  explicit Scene(core::Skeleton s = make_skeleton()) : skeleton(std::move(s)) {
    std::vector<index_t> fixed;
    for (index_t i = 0; i < mesh.num_nodes(); ++i)
      if (mesh.nodes()(i, 2) < -22) fixed.push_back(i);
    const core::BoundarySurface b = core::boundary_surface(mesh);
    model = std::make_unique<RegistrationModel>(mesh, fixed, skeleton,
                                                core::SurfaceMesh{b.vertices, b.faces});
  }
  /// Mean and max error (mm) at the skeleton points (vessel landmarks).
  std::pair<double, double> landmark_error(const MatrixX3d& x) const {
    const MatrixX3d p = model->skeleton_mapping().apply(x);
    double sum = 0, mx = 0;
    for (Eigen::Index i = 0; i < p.rows(); ++i) {
      const Vector3d X = skeleton.points.row(i).transpose();
      const double e = (p.row(i).transpose() - (X + truth(X))).norm();
      sum += e;
      mx = std::max(mx, e);
    }
    return {sum / static_cast<double>(p.rows()), mx};
  }
};

/// The free node farthest from the vessels (the pairing does not feel it) and its distance (mm);
/// node −1 when every node is fixed.
inline std::pair<index_t, double> farthest_free_node(const Scene& s) {
  const MatrixX3d& rest = s.mesh.nodes();
  index_t node = -1;
  double farthest = 0.0;
  for (index_t i = 0; i < s.mesh.num_nodes(); ++i) {
    if (rest(i, 2) < -22) continue;  // fixed
    const double dist = (s.skeleton.points.rowwise() - rest.row(i)).rowwise().norm().minCoeff();
    if (dist > farthest) {
      farthest = dist;
      node = i;
    }
  }
  return {node, farthest};
}

/// Fault injection: the node pushed ±a (mm, along z) after each of the first `steps` steps,
/// whatever the step (after the trust limit and DAMP's share), the steps after it left clean.
inline std::function<void(StepResult&)> push_back_and_forth(const Scene& s, index_t node, double a,
                                                            int steps) {
  return [node, a, steps, k = 0, x_before = MatrixX3d(s.mesh.nodes())](StepResult& step) mutable {
    if (++k > steps) return;
    step.x(node, 2) += (k % 2 == 0 ? a : -a);
    step.max_increment = (step.x - x_before).rowwise().norm().maxCoeff();
    x_before = step.x;
  };
}

}  // namespace
}  // namespace brainshift::constraints
