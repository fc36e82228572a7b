#include "core/mapping/barycentric_mapping.hpp"

#include "core/error.hpp"
#include "core/mapping/tet_locator.hpp"

#include <limits>
#include <sstream>
#include <string>

namespace brainshift::core {
namespace {

/// "(x, y, z)" for messages.
std::string format_point(const Vector3d& p) {
  std::ostringstream s;
  s << '(' << p.x() << ", " << p.y() << ", " << p.z() << ')';
  return s.str();
}

}  // namespace

BarycentricMapping::BarycentricMapping(const TetMesh& mesh, ConstRef<MatrixX3d> points,
                                       const MappingOptions& options) {
  BS_VERIFY(mesh.num_tets() > 0, "barycentric mapping: the mesh has no tetrahedra");
  BS_VERIFY(options.max_outside_distance >= 0.0, "barycentric mapping: max_outside_distance is "
                                                     << options.max_outside_distance
                                                     << " mm, expected >= 0");
  const index_t num_points = static_cast<index_t>(points.rows());
  const TetLocator locator(mesh.nodes(), mesh.tets());
  m_tet.resize(static_cast<std::size_t>(num_points));
  m_outside.resize(static_cast<std::size_t>(num_points));
  m_weights.resize(num_points, 4);
  std::vector<Triplet> triplets;
  triplets.reserve(static_cast<std::size_t>(4 * num_points));
  for (index_t i = 0; i < num_points; ++i) {
    const Vector3d p = points.row(i).transpose();
    BS_VERIFY(p.allFinite(),
              "barycentric mapping: point " << i << " at " << format_point(p) << " is not finite");
    const std::optional<TetLocation> loc = locator.locate(p, options.max_outside_distance);
    if (!loc) {
      // Error path only: search the whole mesh for the distance the message reports.
      const auto nearest = locator.locate(p, std::numeric_limits<double>::infinity());
      BS_THROW("barycentric mapping: point "
               << i << " at " << format_point(p) << " mm is "
               << (nearest ? nearest->distance : std::numeric_limits<double>::infinity())
               << " mm from the mesh, more than max_outside_distance = "
               << options.max_outside_distance << " mm");
    }
    const std::size_t si = static_cast<std::size_t>(i);
    m_tet[si] = loc->tet;
    m_outside[si] = loc->distance;
    m_weights.row(i) = loc->barycentric.transpose();
    for (int k = 0; k < 4; ++k) {
      if (loc->barycentric(k) != 0.0)
        triplets.emplace_back(i, mesh.tets()(loc->tet, k), loc->barycentric(k));
    }
  }
  m_matrix.resize(num_points, mesh.num_nodes());
  m_matrix.setFromTriplets(triplets.begin(), triplets.end());
}

MatrixX3d BarycentricMapping::apply(ConstRef<MatrixX3d> x) const {
  BS_VERIFY(x.rows() == m_matrix.cols(), "BarycentricMapping::apply: x has "
                                             << x.rows() << " rows, expected " << m_matrix.cols()
                                             << " (one per mesh node)");
  MatrixX3d result = m_matrix * x;
  return result;
}

MatrixX3d BarycentricMapping::apply_transposed(ConstRef<MatrixX3d> F) const {
  BS_VERIFY(F.rows() == m_matrix.rows(), "BarycentricMapping::apply_transposed: F has "
                                             << F.rows() << " rows, expected " << m_matrix.rows()
                                             << " (one per mapped point)");
  MatrixX3d result = m_matrix.transpose() * F;
  return result;
}

}  // namespace brainshift::core
