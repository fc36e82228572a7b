#pragma once
/// @file
/// @brief Separable Gaussian filtering of voxel volumes (smoothing and Gaussian derivatives),
/// the one implementation used by vessel extraction and vesselness.
///
/// Along index axis a the kernel is the sampled Gaussian g(t) = exp(−t²/2s²), s = σ/spacing_a
/// (σ in mm, t in voxels), truncated at ±⌈3s⌉; its first and second derivatives are
/// g′(t) = −t/s² · g(t) and g″(t) = (t²/s⁴ − 1/s²) · g(t) (T. Lindeberg, "Scale-Space Theory in
/// Computer Vision", 1994). Smoothing weights are renormalised at the volume's faces (a voxel near
/// a face is the mean of the voxels that exist); derivative passes repeat the face voxel
/// (Neumann boundary). Derivatives are taken along the index axes in image units per mm^order;
/// with an orthonormal direction matrix the Hessian eigenvalues are those of the world frame.

#include "imaging/io/volume.hpp"

#include <array>
#include <vector>

namespace brainshift::imaging::filters {

/// Sampled 1-D Gaussian (order 0), first (1) or second (2) derivative kernel, scale `s` voxels.
/// Order 0 sums to 1; order 1 has Σ t·k(t) = −1 (so it differentiates a ramp exactly); order 2
/// has zero sum and Σ t²·k(t)/2 = 1. Nothing (an empty vector) when s < 0.05 voxel (the identity).
/// @return 2r + 1 weights, centre at index r.
std::vector<double> gaussian_kernel(double s, int order);

/// Filters `image` with a separable Gaussian of standard deviation `sigma_mm` (mm, the same along
/// every axis), differentiated `order[a]` ∈ {0, 1, 2} times along index axis a.
/// Non-finite voxels enter as 0 and stay non-finite in the output. An axis of one voxel, or where
/// σ is below 1/20 voxel, is left unfiltered for order 0 (and differentiated by central
/// differences for orders 1 and 2, zero on a one-voxel axis).
/// @param[in] image  one component.
/// @param[in] sigma_mm  ≥ 0, mm.
/// @param[in] order  derivative order per index axis.
/// \throws brainshift::Error for a multi-component volume, a negative or non-finite σ, or an
/// order outside {0, 1, 2}.
VolumeF gaussian_filter(const VolumeF& image, double sigma_mm,
                        const std::array<int, 3>& order = {0, 0, 0});

/// The factor by which gaussian_filter() (order 0) scales the standard deviation of white noise
/// on grid `g`: the product over the filtered axes of √(Σ w²) of the normalised kernel.
double gaussian_noise_gain(const ImageGeometry& g, double sigma_mm);

/// Block-downsamples `image` by integer factors along i, j, k: each output voxel is the mean
/// (or, with `maximum`, the largest value) of the finite input voxels of its block (blocks at the
/// far faces may be smaller), 0 when none is finite. The output grid keeps the direction; its
/// voxel centres are the block centres.
/// @param[in] factor  ≥ 1 per axis.
VolumeF downsample(const VolumeF& image, const Eigen::Vector3i& factor, bool maximum = false);

}  // namespace brainshift::imaging::filters
