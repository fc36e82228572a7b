#include "data_synth/cases/case_outputs.hpp"

#include "core/error.hpp"
#include "imaging/io/csv.hpp"
#include "imaging/io/surface_io.hpp"

#include <string>

namespace brainshift::data_synth {

void write_landmarks_csv(const std::filesystem::path& path, const std::vector<Vector3d>& points) {
  imaging::Landmarks l;
  l.points.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (std::size_t i = 0; i < points.size(); ++i) {
    l.ids.push_back(std::to_string(i));
    l.points.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
  }
  imaging::write_landmarks(path, l);
}

std::vector<Vector3d> read_landmarks_csv(const std::filesystem::path& path) {
  const imaging::Landmarks l = imaging::read_landmarks(path);
  std::vector<Vector3d> points;
  for (Eigen::Index i = 0; i < l.points.rows(); ++i)
    points.emplace_back(l.points.row(i).transpose());
  return points;
}

core::BoundarySurface region_surface(const core::TetMesh& mesh,
                                     const std::vector<std::uint8_t>& tet_labels,
                                     std::uint8_t label) {
  BS_VERIFY(tet_labels.size() == std::size_t(mesh.num_tets()),
            tet_labels.size() << " tetrahedron labels for " << mesh.num_tets() << " tetrahedra");
  std::vector<index_t> keep;
  for (index_t t = 0; t < mesh.num_tets(); ++t)
    if (tet_labels[std::size_t(t)] == label) keep.push_back(t);
  MatrixX4i tets(index_t(keep.size()), 4);
  for (std::size_t r = 0; r < keep.size(); ++r) tets.row(index_t(r)) = mesh.tets().row(keep[r]);
  return core::boundary_surface(core::TetMesh(mesh.nodes(), tets));
}

void write_surface_vtp(const std::filesystem::path& path, ConstRef<MatrixX3d> vertices,
                       const core::TriangleMatrix& faces) {
  imaging::write_surface_vtp(path, core::SurfaceMesh{vertices, faces});
}

}  // namespace brainshift::data_synth
