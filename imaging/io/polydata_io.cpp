#include "imaging/io/polydata_io.hpp"

#include "core/error.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/header_checks.hpp"
#include "imaging/io/vtk_error_capture.hpp"
#include "imaging/io/vtk_read_checks.hpp"

#include <vtkCellArray.h>
#include <vtkNew.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>

#include <string>
#include <system_error>

namespace brainshift::imaging {

vtkSmartPointer<vtkPolyData> read_polydata(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::error_code ec;
  BS_VERIFY(std::filesystem::exists(path, ec), file << ": no such file");
  BS_VERIFY(std::filesystem::is_regular_file(path, ec), file << ": not a regular file");
  const VtkErrorCapture errors;
  vtkNew<vtkXMLPolyDataReader> reader;
  BS_VERIFY(reader->CanReadFile(file.c_str()) != 0, file << ": not a VTK XML polydata (.vtp) file");
  verify_vtk_xml_header(file);
  reader->SetFileName(file.c_str());
  update_reader(reader, file);
  BS_VERIFY(!errors.failed(), file << ": cannot read: " << errors.message());
  vtkSmartPointer<vtkPolyData> poly = reader->GetOutput();
  BS_VERIFY(poly != nullptr, file << ": cannot read: no polydata");
  const vtkIdType points = poly->GetNumberOfPoints();
  verify_cells(poly->GetVerts(), points, file, "vertex");
  verify_cells(poly->GetLines(), points, file, "line");
  verify_cells(poly->GetPolys(), points, file, "polygon");
  verify_cells(poly->GetStrips(), points, file, "strip");
  return poly;
}

void write_polydata(const std::filesystem::path& path, vtkPolyData* poly) {
  write_atomically(path, [&](const std::filesystem::path& temporary) {
    const VtkErrorCapture errors;
    vtkNew<vtkXMLPolyDataWriter> writer;
    writer->SetInputData(poly);
    writer->SetDataModeToAppended();
    writer->EncodeAppendedDataOff();
    writer->SetFileName(temporary.string().c_str());
    BS_VERIFY(writer->Write() == 1 && !errors.failed(),
              path.string() << ": cannot write: " << errors.message());
  });
}

}  // namespace brainshift::imaging
