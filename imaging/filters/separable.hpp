#pragma once
/// @file
/// @brief One pass of a 1-D kernel along one axis of a 3-D array: the building block of every
/// separable filter of the project (gaussian_filter(), the footprint's low-pass on its ray grid,
/// the phantoms' blur), with an explicit missing-data policy.

#include "imaging/filters/missing_data.hpp"

#include <Eigen/Core>

#include <vector>

namespace brainshift::imaging::filters {

/// @brief Correlates every line of `data` along `axis` with `kernel`, in place:
/// out[t] = Σ_d kernel[d + r] · x[t + d], d ∈ [−r, r] (lines in parallel).
/// Missing samples — positions beyond the line's ends and non-finite values — by `missing`:
/// ZERO: they count as 0; CLAMP: beyond the ends the end value is repeated, non-finite values
/// propagate; NAN_RESULT: a window that reaches beyond an end gives NaN, non-finite values
/// propagate; RENORMALISE: they are left out and the sum divided by the weight of the samples
/// used, NaN when that is less than half the kernel weight within the line.
/// @param[in,out] data  n.x()·n.y()·n.z() values, x fastest.
/// @param[in] n  the array's size per axis (each ≥ 1).
/// @param[in] axis  0, 1 or 2.
/// @param[in] kernel  2r + 1 weights, centre at index r (odd size).
/// @param[in] missing  the missing-data policy.
/// \throws brainshift::Error when data.size() ≠ n.prod(), axis ∉ {0, 1, 2} or the kernel size is
/// even.
void filter_axis(std::vector<float>& data, const Eigen::Vector3i& n, int axis,
                 const std::vector<double>& kernel, MissingData missing);

}  // namespace brainshift::imaging::filters
