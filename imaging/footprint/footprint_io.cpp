#include "imaging/footprint/footprint_io.hpp"

#include "core/error.hpp"
#include "imaging/io/polydata_io.hpp"

#include <vtkCellArray.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>

namespace brainshift::imaging {

void write_footprint_vtp(const std::filesystem::path& path, const MatrixX3d& points,
                         const MatrixX3d& normals) {
  BS_VERIFY(points.rows() == normals.rows(), path.string() << ": " << points.rows()
                                                           << " footprint points but "
                                                           << normals.rows() << " normals");
  BS_VERIFY(points.allFinite() && normals.allFinite(),
            path.string() << ": non-finite footprint points or normals");
  vtkNew<vtkPoints> pts;
  pts->SetDataTypeToDouble();
  vtkNew<vtkDoubleArray> n;
  n->SetName("normals");
  n->SetNumberOfComponents(3);
  vtkNew<vtkCellArray> verts;
  for (Eigen::Index p = 0; p < points.rows(); ++p) {
    const Vector3d x = points.row(p).transpose();
    const Vector3d m = normals.row(p).transpose();
    verts->InsertNextCell(1);
    verts->InsertCellPoint(pts->InsertNextPoint(x.data()));
    n->InsertNextTuple(m.data());
  }
  vtkNew<vtkPolyData> poly;
  poly->SetPoints(pts);
  poly->SetVerts(verts);
  poly->GetPointData()->AddArray(n);
  poly->GetPointData()->SetNormals(n);
  write_polydata(path, poly);
}

FootprintPoints read_footprint_vtp(const std::filesystem::path& path) {
  const std::string file = path.string();
  const vtkSmartPointer<vtkPolyData> poly = read_polydata(path);
  vtkDataArray* n = poly->GetPointData()->GetArray("normals");
  BS_VERIFY(n != nullptr && n->GetNumberOfComponents() == 3 &&
                n->GetNumberOfTuples() == poly->GetNumberOfPoints(),
            file << ": no 3-component point array 'normals' with one tuple per point");
  FootprintPoints f;
  const auto count = Eigen::Index(poly->GetNumberOfPoints());
  f.points.resize(count, 3);
  f.normals.resize(count, 3);
  for (Eigen::Index p = 0; p < count; ++p) {
    double x[3];
    poly->GetPoint(vtkIdType(p), x);
    f.points.row(p) << x[0], x[1], x[2];
    const double* m = n->GetTuple3(vtkIdType(p));
    f.normals.row(p) << m[0], m[1], m[2];
  }
  return f;
}

}  // namespace brainshift::imaging
