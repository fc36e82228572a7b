#pragma once
/// @file
/// @brief Synthetic arterial trees of the phantom: skeleton graphs (points, radii, edges) in
/// world RAS mm, grown deterministically from a seed (std::mt19937).
///
/// Cortical trees start on the brain surface around the craniotomy and run along the cortex at
/// a depth of 1–3 mm under the analytic brain ellipsoid (each step is projected onto the surface
/// offset inward by the branch's depth). Every branch ends in a bifurcation whose child radii
/// follow Murray's law r₀³ = r₁³ + r₂³ (Murray 1926, "The physiological principle of minimum
/// work", PNAS 12) with a random split ratio, until the generation cap or the minimum radius is
/// reached. Deep (penetrating) branches leave the cortical trees toward the tumour and then
/// branch over a shell a few mm around it.

#include "core/config.hpp"
#include "data_synth/geometry/brain_phantom.hpp"
#include "data_synth/geometry/brain_shape.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace brainshift::data_synth {

/// A vessel skeleton: a graph (usually a forest of trees) of centreline points with radii.
struct VesselTree {
  std::vector<Vector3d> points;               ///< #P centreline points, world RAS mm
  std::vector<double> radius;                 ///< #P vessel radius at each point, mm
  std::vector<int> generation;                ///< #P branch generation (1 = root branch)
  std::vector<std::array<index_t, 2>> edges;  ///< segments (parent point, child point)

  [[nodiscard]] index_t size() const { return static_cast<index_t>(points.size()); }
  /// Number of segments at each point.
  [[nodiscard]] std::vector<int> degrees() const;
  /// Points of degree ≥ 3 (bifurcations), increasing.
  [[nodiscard]] std::vector<index_t> bifurcations() const;
  /// Largest generation, 0 for an empty tree.
  [[nodiscard]] int max_generation() const;
  /// Throws brainshift::Error naming the first inconsistency (sizes, edge indices, radii ≤ 0,
  /// non-finite points).
  void verify() const;
};

/// How the synthetic trees grow. Lengths in mm.
struct VesselTreeOptions {
  std::uint32_t seed = 1;  ///< std::mt19937 seed: same seed and options ⇒ identical tree
  int cortical_trees = 3;  ///< trees rooted on the cortex around the craniotomy, ≥ 0
  /// Roots lie this far (mm, along the surface, roughly) from the craniotomy centre, in
  /// [0.4, 1] × root_spread; the trees grow toward the craniotomy.
  double root_spread = 40.0;
  /// Only roots in the half-plane (tangent to the cortex) on the +R side of the craniotomy
  /// centre are used ("vessels on one side").
  bool one_side = false;
  double root_radius_min = 2.0;  ///< mm
  double root_radius_max = 3.0;  ///< mm, ≤ max_radius
  double min_radius = 0.5;       ///< no vessel thinner than this, mm
  double max_radius = 3.0;       ///< no vessel thicker than this, mm
  int min_generations = 3;       ///< each tree's cap is drawn in [min, max], ≥ 1
  int max_generations = 5;
  double min_depth = 1.0;  ///< cortical branches run this deep under the surface at least, mm
  double max_depth = 3.0;  ///< and at most, mm
  double step = 1.5;       ///< centreline point spacing, mm, > 0
  /// Branch length = length_per_radius × r × U(0.7, 1.3) + 4 mm.
  double length_per_radius = 9.0;
  double wander_deg = 12.0;   ///< standard deviation of the per-step turn, degrees
  int deep_branches = 2;      ///< penetrating branches toward the tumour, ≥ 0
  double deep_radius = 1.2;   ///< radius of a penetrating branch, mm
  double tumour_shell = 4.0;  ///< deep branches spread this far outside the tumour, mm
  int deep_generations = 2;   ///< bifurcation levels of the deep branches around the tumour
  /// Empty when valid, else the reason (names the value).
  [[nodiscard]] std::string validate() const;
};

/// Grows the synthetic vessel trees of a phantom (cortical trees, then deep branches).
/// Every point lies inside the brain, outside the ventricles and at least 1 mm outside the
/// tumour; radii lie in [min_radius, max_radius].
/// \throws brainshift::Error on invalid geometry or options.
VesselTree make_vessel_tree(const PhantomGeometry& geometry, const VesselTreeOptions& options);

/// The same on any brain shape (e.g. one from a label volume): the cortical trees follow its
/// outer surface offset inward. \throws brainshift::Error on invalid options.
VesselTree make_vessel_tree(const BrainShape& shape, const VesselTreeOptions& options);

}  // namespace brainshift::data_synth
