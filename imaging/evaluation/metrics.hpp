#pragma once
/// @file
/// @brief Evaluation metrics of `brainshift evaluate`: error statistics, landmark
/// target registration errors (TRE), surface-to-surface distance percentiles (the H95, H75, H50,
/// H25 of seeds 001/004) and the percentage of brain shift corrected. Pure functions, no I/O.
/// Positions in world RAS mm, distances in mm.

#include "core/config.hpp"
#include "core/geometry/skeleton.hpp"

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::imaging {

/// The p-th percentile of `values` by linear interpolation between order statistics (the
/// "type 7" rule of Hyndman & Fan 1996, R's and NumPy's default): with x₀ ≤ … ≤ x_{n−1} sorted
/// and h = (n − 1)·p/100, P_p = x_⌊h⌋ + (h − ⌊h⌋)(x_⌊h⌋+1 − x_⌊h⌋). So P₀ = min, P₁₀₀ = max,
/// P₅₀ = the usual median.
/// @param[in] values  n ≥ 1 finite values (any order; copied; O(n) by selection, no sort).
/// @param[in] p  percent in [0, 100].
/// \throws brainshift::Error when `values` is empty, a value is not finite, or p ∉ [0, 100].
double percentile(std::vector<double> values, double p);

/// Summary of a set of non-negative errors (mm).
struct ErrorStats {
  double mean = 0.0;    ///< mm
  double median = 0.0;  ///< percentile(·, 50), mm
  double p95 = 0.0;     ///< percentile(·, 95) (type 7, see percentile()), mm
  double max = 0.0;     ///< mm
  std::size_t count = 0;
  bool empty = true;  ///< no errors: every field above is 0 (never NaN)
};

/// Mean, median, 95th percentile (see percentile()) and maximum of `errors_mm`.
/// @param[in] errors_mm  finite values ≥ 0, mm; may be empty (then `empty` is set).
/// \throws brainshift::Error naming the first negative or non-finite value and its index.
ErrorStats error_stats(const std::vector<double>& errors_mm);

/// Row-wise Euclidean distances ‖predicted_i − truth_i‖ (mm), e.g. the landmark TRE.
/// @param[in] predicted, truth  #L×3 positions, mm, world RAS, same row order.
/// \throws brainshift::Error naming both row counts when they differ, or the first non-finite
/// row.
std::vector<double> landmark_errors(ConstRef<MatrixX3d> predicted, ConstRef<MatrixX3d> truth);

/// Two landmark sets paired by id.
struct LandmarkPairs {
  std::vector<std::string> ids;        ///< the ids present on both sides, in the order of side A
  MatrixX3d a;                         ///< #ids×3 positions from side A, mm
  MatrixX3d b;                         ///< #ids×3 positions from side B, same rows, mm
  std::vector<std::string> only_in_a;  ///< ids of A with no partner in B (A's order)
  std::vector<std::string> only_in_b;  ///< ids of B with no partner in A (B's order)
  /// One line per unpaired id ("landmark '7' is in A only"), for the report; empty when every
  /// id was paired.
  std::vector<std::string> warnings;
};

/// Pairs two landmark sets by id (exact string comparison: "7" and "07" differ). Unpaired ids
/// are listed in the result, never paired with something else.
/// @param[in] ids_a, pts_a  side A: one id per row of the #A×3 positions (mm).
/// @param[in] ids_b, pts_b  side B: one id per row of the #B×3 positions (mm).
/// \throws brainshift::Error when a side's id count differs from its row count, or an id is
/// repeated within one side (naming the id): the pairing would be ambiguous.
LandmarkPairs match_landmarks_by_id(const std::vector<std::string>& ids_a,
                                    ConstRef<MatrixX3d> pts_a,
                                    const std::vector<std::string>& ids_b,
                                    ConstRef<MatrixX3d> pts_b);

/// Directed distances from each vertex of `from` to the surface `to` (the nearest point on any
/// triangle of `to`, Ericson's closest_point_on_triangle()), mm. Exact up to rounding: a
/// uniform grid of triangle bounding boxes prunes the search, it does not approximate it.
/// @param[in] from  #V vertices are queried (its triangles are not used).
/// @param[in] to  a triangle surface with ≥ 1 triangle; ≤ ~50k vertices is the intended size.
/// @return #V distances ≥ 0, in vertex order.
/// \throws brainshift::Error when `to` has no triangle, a triangle index is out of range, or a
/// vertex of either surface is not finite.
std::vector<double> surface_distances(const core::SurfaceMesh& from, const core::SurfaceMesh& to);

/// Symmetric surface-distance statistics: the directed distances A → B and B → A pooled into one
/// sample of #V_A + #V_B values; Hxx is its xx-th percentile (percentile(), type 7).
struct SurfaceDistanceStats {
  double h95 = 0.0;   ///< mm
  double h75 = 0.0;   ///< mm
  double h50 = 0.0;   ///< mm
  double h25 = 0.0;   ///< mm
  double max = 0.0;   ///< the (symmetric) Hausdorff distance of the vertex sets to the surfaces, mm
  double mean = 0.0;  ///< mm
  std::size_t count = 0;  ///< #V_A + #V_B
};

/// Hausdorff percentiles between two triangle surfaces (see SurfaceDistanceStats).
/// \throws brainshift::Error as surface_distances(), for either direction.
SurfaceDistanceStats hausdorff_percentiles(const core::SurfaceMesh& a, const core::SurfaceMesh& b);

/// Percentage of brain shift corrected: 100 · (1 − after / before), from the mean TRE before
/// (no correction) and after the correction. 100 = perfect, 0 = no better, < 0 = worse.
/// @param[in] tre_before_mean_mm, tre_after_mean_mm  ≥ 0, finite, mm.
/// @param[in] min_before_mm  guard: below it there was no shift to correct and the ratio means
/// nothing; default 1 µm.
/// @return nothing when tre_before_mean_mm < min_before_mm.
/// \throws brainshift::Error for a negative or non-finite input.
std::optional<double> percent_shift_corrected(double tre_before_mean_mm, double tre_after_mean_mm,
                                              double min_before_mm = 1e-3);

}  // namespace brainshift::imaging
