#include "imaging/io/mesh_io.hpp"

#include "core/error.hpp"
#include "core/units.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/header_checks.hpp"
#include "imaging/io/vtk_error_capture.hpp"
#include "imaging/io/vtk_read_checks.hpp"

#include <climits>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCellType.h>
#include <vtkCellTypes.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkSmartPointer.h>
#include <vtkUnsignedCharArray.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include <sstream>
#include <string>
#include <system_error>

namespace brainshift::imaging {
namespace {

/// A per-cell material array, or `fallback` for every cell when the file lacks it.
Eigen::VectorXd read_cell_array(vtkUnstructuredGrid* grid, const char* name, double fallback,
                                const std::string& file) {
  const vtkIdType n = grid->GetNumberOfCells();
  vtkDataArray* array = grid->GetCellData()->GetArray(name);
  if (array == nullptr) return Eigen::VectorXd::Constant(n, fallback);
  BS_VERIFY(array->GetNumberOfComponents() == 1 && array->GetNumberOfTuples() == n,
            file << ": cell array '" << name << "' has " << array->GetNumberOfTuples() << "×"
                 << array->GetNumberOfComponents() << " values, expected " << n
                 << "×1 (one per cell)");
  Eigen::VectorXd values(n);
  for (vtkIdType i = 0; i < n; ++i) values(i) = array->GetComponent(i, 0);
  return values;
}

vtkSmartPointer<vtkDoubleArray> to_vtk_array(const char* name, const double* data, vtkIdType tuples,
                                             int components) {
  auto array = vtkSmartPointer<vtkDoubleArray>::New();
  array->SetName(name);
  array->SetNumberOfComponents(components);
  array->SetNumberOfTuples(tuples);
  for (vtkIdType i = 0; i < tuples * components; ++i) array->SetValue(i, data[i]);
  return array;
}

/// Reads a .vtu file; errors name the file.
vtkSmartPointer<vtkUnstructuredGrid> read_grid(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::error_code ec;
  BS_VERIFY(std::filesystem::exists(path, ec), file << ": no such file");
  BS_VERIFY(std::filesystem::is_regular_file(path, ec), file << ": not a regular file");
  const VtkErrorCapture errors;
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  BS_VERIFY(reader->CanReadFile(file.c_str()) != 0,
            file << ": not a VTK XML unstructured grid (.vtu) file");
  verify_vtk_xml_header(file);
  reader->SetFileName(file.c_str());
  update_reader(reader, file);
  BS_VERIFY(!errors.failed(), file << ": cannot read: " << errors.message());
  vtkSmartPointer<vtkUnstructuredGrid> grid = reader->GetOutput();
  BS_VERIFY(grid != nullptr, file << ": cannot read the unstructured grid");
  verify_cells(grid->GetCells(), grid->GetNumberOfPoints(), file, "cell");
  const vtkUnsignedCharArray* types = grid->GetCellTypesArray();
  BS_VERIFY(grid->GetCells() == nullptr ||
                (types != nullptr && types->GetNumberOfTuples() == grid->GetNumberOfCells()),
            file << ": " << grid->GetNumberOfCells() << " cells but not as many cell types");
  return grid;
}

}  // namespace

core::TetMesh read_tet_mesh(const std::filesystem::path& path) {
  const std::string file = path.string();
  const vtkSmartPointer<vtkUnstructuredGrid> grid = read_grid(path);

  const vtkIdType num_points = grid->GetNumberOfPoints();
  const vtkIdType num_cells = grid->GetNumberOfCells();
  BS_VERIFY(num_cells > 0, file << ": the mesh has no cells");
  BS_VERIFY(num_points < INT_MAX && num_cells < INT_MAX,
            file << ": " << num_points << " points and " << num_cells
                 << " cells exceed the index range of brainshift");

  MatrixX3d nodes(num_points, 3);
  for (vtkIdType i = 0; i < num_points; ++i) grid->GetPoint(i, &nodes(i, 0));

  MatrixX4i tets(num_cells, 4);
  vtkNew<vtkIdList> ids;
  for (vtkIdType c = 0; c < num_cells; ++c) {
    const int type = grid->GetCellType(c);
    BS_VERIFY(type == VTK_TETRA, file << ": cell " << c << " is a "
                                      << vtkCellTypes::GetClassNameFromTypeId(type) << " (VTK type "
                                      << type << "); only tetrahedra (VTK_TETRA = " << VTK_TETRA
                                      << ") are supported");
    grid->GetCellPoints(c, ids);
    BS_VERIFY(ids->GetNumberOfIds() == 4,
              file << ": tetrahedron " << c << " has " << ids->GetNumberOfIds() << " points");
    for (int k = 0; k < 4; ++k) tets(c, k) = static_cast<index_t>(ids->GetId(k));
  }
  core::TetMesh mesh(std::move(nodes), std::move(tets),
                     read_cell_array(grid, "youngs_modulus", units::brain_youngs_modulus, file),
                     read_cell_array(grid, "poisson_ratio", units::default_poisson_ratio, file));
  core::validate(mesh, file);
  return mesh;
}

MatrixX3d read_displacement(const std::filesystem::path& path) {
  const vtkSmartPointer<vtkUnstructuredGrid> grid = read_grid(path);
  vtkDataArray* array = grid->GetPointData()->GetArray("displacement");
  BS_VERIFY(array != nullptr, path.string() << ": no point array 'displacement'");
  BS_VERIFY(array->GetNumberOfComponents() == 3 &&
                array->GetNumberOfTuples() == grid->GetNumberOfPoints(),
            path.string() << ": point array 'displacement' has " << array->GetNumberOfTuples()
                          << "×" << array->GetNumberOfComponents() << " values, expected "
                          << grid->GetNumberOfPoints() << "×3");
  MatrixX3d u(grid->GetNumberOfPoints(), 3);
  for (vtkIdType i = 0; i < u.rows(); ++i)
    for (int k = 0; k < 3; ++k) u(i, k) = array->GetComponent(i, k);
  return u;
}

void write_tet_mesh(const std::filesystem::path& path, const core::TetMesh& mesh,
                    const MatrixX3d* displacement) {
  const std::string file = path.string();
  BS_VERIFY(displacement == nullptr || displacement->rows() == mesh.num_nodes(),
            "cannot write " << file << ": displacement has " << displacement->rows() << " rows for "
                            << mesh.num_nodes() << " nodes");

  vtkNew<vtkUnstructuredGrid> grid;
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(mesh.num_nodes());
  for (index_t i = 0; i < mesh.num_nodes(); ++i) points->SetPoint(i, &mesh.nodes()(i, 0));
  grid->SetPoints(points);
  grid->Allocate(mesh.num_tets());
  for (index_t t = 0; t < mesh.num_tets(); ++t) {
    const vtkIdType ids[4] = {mesh.tets()(t, 0), mesh.tets()(t, 1), mesh.tets()(t, 2),
                              mesh.tets()(t, 3)};
    grid->InsertNextCell(VTK_TETRA, 4, ids);
  }
  grid->GetCellData()->AddArray(
      to_vtk_array("youngs_modulus", mesh.youngs_modulus().data(), mesh.num_tets(), 1));
  grid->GetCellData()->AddArray(
      to_vtk_array("poisson_ratio", mesh.poisson_ratio().data(), mesh.num_tets(), 1));
  if (displacement != nullptr) {
    grid->GetPointData()->AddArray(
        to_vtk_array("displacement", displacement->data(), mesh.num_nodes(), 3));
  }

  write_atomically(path, [&](const std::filesystem::path& temporary) {
    const VtkErrorCapture errors;
    vtkNew<vtkXMLUnstructuredGridWriter> writer;
    writer->SetInputData(grid);
    writer->SetFileName(temporary.string().c_str());
    writer->SetDataModeToAppended();
    writer->EncodeAppendedDataOff();  // raw binary: exact round trip
    const int ok = writer->Write();
    BS_VERIFY(ok == 1 && !errors.failed(),
              "cannot write " << file << ": "
                              << (errors.failed() ? errors.message() : "VTK writer failed"));
  });
}

}  // namespace brainshift::imaging
