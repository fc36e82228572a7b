#pragma once
/// @file
/// @brief A closed, 2-manifold, outward-oriented surface around any triangle soup by CGAL's
/// 3D alpha wrapping (Portaneri, Rouxel-Labbé, Hemmer, Cohen-Steiner, Alliez, "Alpha wrapping with
/// an offset", ACM TOG 41(4), 2022). Used when a mesh boundary is not a manifold (thin parts of a
/// real brain touching along an edge or at a vertex), which edge-collapse decimation cannot take.
/// Positions in mm, world frame.

#include "core/config.hpp"
#include "core/geometry/skeleton.hpp"

namespace brainshift::imaging {

/// Wraps the triangles of `soup` (any connectivity: non-manifold edges and vertices, duplicated
/// or inconsistently oriented triangles are all fine).
/// @param[in] soup    triangles, mm; vertices referenced by no triangle are ignored.
/// @param[in] alpha   mm, > 0: the wrap does not enter cavities or gaps narrower than about
///                    `alpha`; its triangles are about `alpha` wide where the input is curved.
/// @param[in] offset  mm, > 0: the wrap lies at about this distance outside the input.
/// @return a closed, 2-manifold, consistently oriented surface with outward normals (positive
/// enclosed volume), without self-intersections.
/// \throws brainshift::Error when alpha or offset is not a positive number, an index is out of
/// range, a vertex is not finite, or the soup has no triangle.
core::SurfaceMesh wrap_surface(const core::SurfaceMesh& soup, double alpha, double offset);

}  // namespace brainshift::imaging
