#include "imaging/io/vtk_read_checks.hpp"

#include "core/error.hpp"

#include <vtkAlgorithm.h>
#include <vtkCellArray.h>
#include <vtkDataArray.h>

#include <new>

namespace brainshift::imaging {

void update_reader(vtkAlgorithm* reader, const std::string& file) {
  try {
    reader->Update();
  } catch (const std::bad_alloc&) {
    BS_THROW(file << ": cannot read: its sizes or offsets ask for more memory than there is "
                     "(a corrupt file)");
  }
}

void verify_cells(vtkCellArray* cells, vtkIdType points, const std::string& file,
                  const char* what) {
  if (cells == nullptr) return;
  vtkDataArray* offsets = cells->GetOffsetsArray();
  vtkDataArray* connectivity = cells->GetConnectivityArray();
  BS_VERIFY(offsets != nullptr && connectivity != nullptr,
            file << ": " << what << " without offsets or connectivity");
  const vtkIdType ids = connectivity->GetNumberOfTuples();
  const vtkIdType count = offsets->GetNumberOfTuples();
  BS_VERIFY(count == 0 || vtkIdType(offsets->GetComponent(0, 0)) == 0,
            file << ": " << what << " offsets do not start at 0");
  for (vtkIdType c = 1; c < count; ++c) {
    const double a = offsets->GetComponent(c - 1, 0), b = offsets->GetComponent(c, 0);
    BS_VERIFY(b >= a && b <= double(ids), file << ": " << what << " cell " << c - 1
                                               << " has offsets " << a << " to " << b << " in "
                                               << ids << " ids");
  }
  BS_VERIFY(count == 0 || vtkIdType(offsets->GetComponent(count - 1, 0)) == ids,
            file << ": " << what << " offsets end before the " << ids << " point ids");
  for (vtkIdType i = 0; i < ids; ++i) {
    const double id = connectivity->GetComponent(i, 0);
    BS_VERIFY(id >= 0 && id < double(points),
              file << ": " << what << " point id " << id << " outside the " << points << " points");
  }
}

}  // namespace brainshift::imaging
