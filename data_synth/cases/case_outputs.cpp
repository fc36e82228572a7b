#include "data_synth/cases/case_outputs.hpp"

#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>
#include <string>

#include "core/error.hpp"
#include "imaging/io/atomic_write.hpp"

namespace brainshift::data_synth {

void write_landmarks_csv(const std::filesystem::path& path, const std::vector<Vector3d>& points) {
  imaging::write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp);
    BS_VERIFY(out, "cannot open " << tmp.string() << " for writing");
    out << std::setprecision(std::numeric_limits<double>::max_digits10) << "id,x,y,z\n";
    for (std::size_t i = 0; i < points.size(); ++i)
      out << i << ',' << points[i].x() << ',' << points[i].y() << ',' << points[i].z() << '\n';
    out.flush();
    BS_VERIFY(out, "write to " << tmp.string() << " failed");
  });
}

std::vector<Vector3d> read_landmarks_csv(const std::filesystem::path& path) {
  std::ifstream in(path);
  BS_VERIFY(in, "cannot open landmark file " << path.string());
  std::string line;
  BS_VERIFY(std::getline(in, line) && line.rfind("id,x,y,z", 0) == 0,
            path.string() << ": expected the header 'id,x,y,z'");
  std::vector<Vector3d> points;
  for (int number = 2; std::getline(in, line); ++number) {
    if (line.empty() || line == "\r") continue;
    std::istringstream s(line);
    std::string field[4];
    for (auto& f : field) std::getline(s, f, ',');
    try {
      points.emplace_back(std::stod(field[1]), std::stod(field[2]), std::stod(field[3]));
    } catch (const std::exception&) {
      BS_THROW(path.string() << ":" << number << ": expected id,x,y,z numbers, got '" << line << "'");
    }
  }
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
  imaging::write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp);
    BS_VERIFY(out, "cannot open " << tmp.string() << " for writing");
    out << std::setprecision(std::numeric_limits<double>::max_digits10);
    out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" "
           "byte_order=\"LittleEndian\">\n<PolyData>\n<Piece NumberOfPoints=\""
        << vertices.rows() << "\" NumberOfPolys=\"" << faces.rows() << "\">\n"
        << "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n";
    for (index_t v = 0; v < vertices.rows(); ++v)
      out << vertices(v, 0) << ' ' << vertices(v, 1) << ' ' << vertices(v, 2) << '\n';
    out << "</DataArray>\n</Points>\n<Polys>\n"
        << "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
    for (index_t f = 0; f < faces.rows(); ++f)
      out << faces(f, 0) << ' ' << faces(f, 1) << ' ' << faces(f, 2) << '\n';
    out << "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
    for (index_t f = 0; f < faces.rows(); ++f) out << 3 * (f + 1) << '\n';
    out << "</DataArray>\n</Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n";
    out.flush();
    BS_VERIFY(out, "write to " << tmp.string() << " failed");
  });
}

}  // namespace brainshift::data_synth
