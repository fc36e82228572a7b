#pragma once
/// @file
/// @brief Drawing vessel tubes into a volume with partial-volume edges, and the small filters the
/// synthetic images share (separable Gaussian blur, seeded noise).

#include "core/config.hpp"
#include "data_synth/vessels/vessel_tree.hpp"
#include "imaging/io/volume.hpp"

#include <functional>
#include <random>
#include <vector>

namespace brainshift::data_synth {

/// A conical tube segment between two centreline points (world RAS mm, radii mm).
struct TubeSegment {
  Vector3d a, b;
  double radius_a = 1.0, radius_b = 1.0;
};

/// The segments of a tree (its edges), radii r·scale + add (mm), e.g. thickened for Doppler.
std::vector<TubeSegment> tube_segments(const VesselTree& tree, double scale = 1.0,
                                       double add = 0.0);

/// For every voxel near a segment: coverage c = clamp(0.5 + (r(t) − d)/h, 0, 1), with d the
/// distance from the voxel centre to the segment, r(t) the radius interpolated at the closest
/// point and h the mean voxel spacing; the voxel becomes max(voxel, c · peak(r(t))).
/// @param[in,out] volume  one component.
/// @param[in] peak  intensity of a fully covered voxel as a function of the radius (mm).
void draw_tubes(imaging::VolumeF& volume, const std::vector<TubeSegment>& segments,
                const std::function<double(double radius_mm)>& peak);

/// Separable Gaussian blur of a one-component volume, sigma in mm (per axis through spacing).
void gaussian_blur(imaging::VolumeF& volume, double sigma_mm);

/// Adds N(0, sigma²) to every voxel.
void add_gaussian_noise(imaging::VolumeF& volume, double sigma, std::mt19937& rng);

}  // namespace brainshift::data_synth
