#include "imaging/io/skeleton_io.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"
#include "imaging/io/polydata_io.hpp"

#include <vtkCellArray.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>

#include <cmath>
#include <map>
#include <string>

namespace brainshift::imaging {

void write_skeleton_vtp(const std::filesystem::path& path, const VesselGraph& graph) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  vtkNew<vtkDoubleArray> radius;
  radius->SetName("radius");
  for (const auto& node : graph.nodes) {
    points->InsertNextPoint(node.position.data());
    radius->InsertNextValue(node.radius);
  }
  vtkNew<vtkCellArray> lines;
  for (const auto& b : graph.branches) {
    BS_VERIFY(b.points.size() >= 2 && b.radius.size() == b.points.size(),
              path.string() << ": a branch needs ≥ 2 points and one radius per point");
    lines->InsertNextCell(vtkIdType(b.points.size()));
    lines->InsertCellPoint(b.from);
    for (std::size_t i = 1; i + 1 < b.points.size(); ++i) {
      lines->InsertCellPoint(points->InsertNextPoint(b.points[i].data()));
      radius->InsertNextValue(b.radius[i]);
    }
    lines->InsertCellPoint(b.to);
  }
  vtkNew<vtkPolyData> poly;
  poly->SetPoints(points);
  poly->SetLines(lines);
  poly->GetPointData()->AddArray(radius);
  write_polydata(path, poly);
}

VesselGraph read_skeleton_vtp(const std::filesystem::path& path) {
  const std::string file = path.string();
  const vtkSmartPointer<vtkPolyData> poly = read_polydata(path);
  BS_VERIFY(poly != nullptr && poly->GetNumberOfLines() > 0, file << ": no line cells");

  vtkDataArray* radius = poly->GetPointData()->GetArray("radius");
  if (radius == nullptr) radius = poly->GetPointData()->GetArray("MaximumInscribedSphereRadius");
  if (radius == nullptr) logger().warn("{}: no 'radius' point array; radii set to 0", file);
  BS_VERIFY(radius == nullptr || (radius->GetNumberOfComponents() == 1 &&
                                  radius->GetNumberOfTuples() == poly->GetNumberOfPoints()),
            file << ": the radius array has " << (radius ? radius->GetNumberOfTuples() : 0) << "×"
                 << (radius ? radius->GetNumberOfComponents() : 0) << " values, expected "
                 << poly->GetNumberOfPoints() << "×1");
  const auto point = [&](vtkIdType id) {
    Vector3d p;
    poly->GetPoint(id, p.data());
    BS_VERIFY(p.allFinite(), file << ": point " << id << " has non-finite coordinates");
    return p;
  };
  const auto r = [&](vtkIdType id) { return radius ? radius->GetComponent(id, 0) : 0.0; };

  VesselGraph graph;
  std::map<vtkIdType, index_t> node_of_point;
  const auto node = [&](vtkIdType id) {
    const auto [it, added] = node_of_point.emplace(id, index_t(graph.nodes.size()));
    if (added) graph.nodes.push_back({point(id), r(id)});
    return it->second;
  };
  vtkCellArray* lines = poly->GetLines();
  vtkNew<vtkIdList> ids;
  lines->InitTraversal();
  for (vtkIdType cell = 0; lines->GetNextCell(ids) != 0; ++cell) {
    const vtkIdType n = ids->GetNumberOfIds();
    BS_VERIFY(n >= 2, file << ": line cell " << cell << " has " << n << " point(s), expected ≥ 2");
    VesselGraph::Branch b;
    b.from = node(ids->GetId(0));
    b.to = node(ids->GetId(n - 1));
    for (vtkIdType i = 0; i < n; ++i) {
      b.points.push_back(point(ids->GetId(i)));
      b.radius.push_back(r(ids->GetId(i)));
    }
    graph.branches.push_back(std::move(b));
  }
  return graph;
}

}  // namespace brainshift::imaging
