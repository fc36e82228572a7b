#pragma once
/// @file
/// @brief Scan conversion of tetrahedra onto a voxel grid: every voxel centre inside a
/// tetrahedron is visited once with that tetrahedron and the voxel's barycentric coordinates.
/// Used to sample the truth field on the pre-operative grid (rest tetrahedra) and to render
/// intra-operative images in the deformed space (deformed tetrahedra).

#include "core/config.hpp"
#include "imaging/io/volume.hpp"

#include <cstdint>
#include <functional>

namespace brainshift::data_synth {

/// Called once per covered voxel: its linear index in the grid, its tetrahedron, and its
/// barycentric coordinates w.r.t. that tetrahedron's nodes (sum 1, all ≥ −1e-9).
using VoxelInTetVisitor =
    std::function<void(std::int64_t voxel, index_t tet, const Vector4d& barycentric)>;

/// Visits the voxels of `grid` whose centres lie inside the tetrahedra `tets` of `nodes`.
/// A voxel on a face shared by two tetrahedra is visited once (for the first one).
/// @param[in] nodes  #N×3 node positions (rest or deformed), world RAS mm.
/// @param[in] tets   #T×4 node indices (either orientation).
/// @return the number of voxels visited.
std::int64_t rasterize_tets(ConstRef<MatrixX3d> nodes, ConstRef<MatrixX4i> tets,
                            const imaging::ImageGeometry& grid, const VoxelInTetVisitor& visit);

}  // namespace brainshift::data_synth
