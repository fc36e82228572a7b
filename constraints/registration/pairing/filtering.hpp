#pragma once
/// @file
/// @brief Filtering of pairings (seed 002 §3.4.2):
///  1. one intra-operative point per model feature (segment / triangle): the nearest is kept;
///  2. pairs farther than median + threshold, or nearer than a floor, are dropped;
///  3. vessel pairs whose directions disagree (skeleton tangent vs the local direction of the
///     intra-operative points around the point) are dropped;
///  4. subsampling so that no tetrahedron carries more than a set number of constraints of one kind
///     (antagonistic rows on one element stall the solver).

#include "constraints/registration/pairing/pairing.hpp"
#include "core/config.hpp"
#include "core/option_fields.hpp"

#include <string>
#include <vector>

namespace brainshift::constraints {

struct FilterOptions {
  bool one_per_feature = true;
  double median_threshold_mm = 5.0;  ///< drop pairs with distance > median + this
  double min_distance_mm = 0.0;      ///< drop pairs with distance < this (already matched)
  double max_angle_deg = 45.0;       ///< direction test for segment pairs; ≥ 90 disables it
  int max_per_tet = 1;               ///< per tetrahedron and kind; ≤ 0 disables subsampling
  [[nodiscard]] std::string validate() const;
};

/// The options' names, ranges and documentation (core/option_fields.hpp); in the scene under
/// filter.vessels and filter.footprint.
template <class V>
void visit_fields(FilterOptions& o, V&& v) {
  v("one_per_feature", o.one_per_feature, "keep one point per model feature (the nearest)");
  v("median_threshold_mm", o.median_threshold_mm, core::Range{0, 1e6},
    "drop pairs farther than the median distance + this");
  v("min_distance_mm", o.min_distance_mm, core::Range{0, 1e6}, "drop pairs nearer than this");
  v("max_angle_deg", o.max_angle_deg, core::Range{1e-6, 180},
    "largest angle between skeleton tangent and local point direction; >= 90 disables it");
  v("max_per_tet", o.max_per_tet, core::Range{0, 1000},
    "rows per tetrahedron and kind; 0 disables subsampling");
}

/// What the filter dropped, by reason.
struct FilterReport {
  index_t input = 0;
  index_t duplicate_feature = 0;
  index_t too_far = 0;
  index_t too_near = 0;
  index_t direction = 0;
  index_t subsampled = 0;
  index_t kept = 0;
  double median_distance = 0.0;  ///< mm, over the pairs entering step 2
};

/// Principal direction of the points within `radius` (mm) of each point (PCA of the
/// neighbourhood); zero where it is undetermined (fewer than 3 neighbours, or the largest
/// eigenvalue is less than twice the second: no dominant direction).
std::vector<Vector3d> local_directions(ConstRef<MatrixX3d> points, double radius);

/// Applies steps 1–4. `directions` are the local directions of the intra-operative points
/// (empty: skip step 3); `tet_of_pair` gives the tetrahedron each pair's model point lies in
/// (empty: skip step 4). Order of the kept pairs: by point index.
std::vector<Pair> filter_pairs(std::vector<Pair> pairs, const std::vector<Vector3d>& directions,
                               const std::vector<index_t>& tet_of_pair,
                               const FilterOptions& options, FilterReport* report = nullptr);

}  // namespace brainshift::constraints
