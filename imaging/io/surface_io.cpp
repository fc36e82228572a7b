#include "imaging/io/surface_io.hpp"

#include "core/error.hpp"
#include "imaging/io/polydata_io.hpp"

#include <vtkCellArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkTriangleFilter.h>

namespace brainshift::imaging {

void write_surface_vtp(const std::filesystem::path& path, const core::SurfaceMesh& surface) {
  const auto nv = surface.vertices.rows();
  BS_VERIFY(surface.triangles.size() == 0 ||
                (surface.triangles.minCoeff() >= 0 && surface.triangles.maxCoeff() < nv),
            path.string() << ": a triangle indexes a vertex outside 0.." << nv - 1);
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(nv);
  for (Eigen::Index v = 0; v < nv; ++v)
    points->SetPoint(v, surface.vertices(v, 0), surface.vertices(v, 1), surface.vertices(v, 2));
  vtkNew<vtkCellArray> polys;
  for (Eigen::Index f = 0; f < surface.triangles.rows(); ++f) {
    const vtkIdType ids[3] = {surface.triangles(f, 0), surface.triangles(f, 1),
                              surface.triangles(f, 2)};
    polys->InsertNextCell(3, ids);
  }
  vtkNew<vtkPolyData> poly;
  poly->SetPoints(points);
  poly->SetPolys(polys);
  write_polydata(path, poly);
}

core::SurfaceMesh read_surface_vtp(const std::filesystem::path& path) {
  const std::string file = path.string();
  const vtkSmartPointer<vtkPolyData> poly = read_polydata(path);
  BS_VERIFY(poly != nullptr && poly->GetNumberOfPolys() + poly->GetNumberOfStrips() > 0,
            file << ": no triangles (a surface needs polygon cells)");
  vtkPolyData* source = poly;
  vtkNew<vtkTriangleFilter> strips;  // only for triangle strips; polygons are checked below
  if (poly->GetNumberOfStrips() > 0) {
    strips->SetInputData(poly);
    strips->PassLinesOff();
    strips->PassVertsOff();
    strips->Update();
    source = strips->GetOutput();
  }
  core::SurfaceMesh s;
  s.vertices.resize(source->GetNumberOfPoints(), 3);
  for (vtkIdType v = 0; v < source->GetNumberOfPoints(); ++v) {
    double p[3];
    source->GetPoint(v, p);
    s.vertices.row(v) << p[0], p[1], p[2];
  }
  BS_VERIFY(s.vertices.allFinite(), file << ": a vertex has a NaN or infinite coordinate");
  vtkCellArray* polys = source->GetPolys();
  s.triangles.resize(polys->GetNumberOfCells(), 3);
  vtkNew<vtkIdList> ids;
  polys->InitTraversal();
  for (vtkIdType c = 0; polys->GetNextCell(ids); ++c) {
    BS_VERIFY(ids->GetNumberOfIds() == 3, file << ": polygon " << c << " has "
                                               << ids->GetNumberOfIds()
                                               << " points, expected a triangle");
    for (int k = 0; k < 3; ++k) s.triangles(c, k) = static_cast<index_t>(ids->GetId(k));
  }
  return s;
}

}  // namespace brainshift::imaging
