#pragma once
/// @file
/// @brief Reading VTK files as hostile input (found by fuzzing): a reader's Update()
/// whose allocations fail becomes a one-line error naming the file, and the cells of what it
/// returns are checked before anything walks them (VTK's XML readers accept offsets and point ids
/// that index beyond the arrays, and traversing such cells reads out of bounds).

#include <vtkType.h>

#include <string>

class vtkAlgorithm;
class vtkCellArray;

namespace brainshift::imaging {

/// reader->Update(); std::bad_alloc (counts or offsets in the file that ask for more memory than
/// there is) becomes brainshift::Error naming `file`.
void update_reader(vtkAlgorithm* reader, const std::string& file);

/// Offsets that start at 0, never decrease and end at the connectivity's size, and point ids in
/// [0, points).
/// \throws brainshift::Error, one line naming `file`, the cell kind `what` and the first bad cell.
void verify_cells(vtkCellArray* cells, vtkIdType points, const std::string& file, const char* what);

}  // namespace brainshift::imaging
