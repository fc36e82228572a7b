#pragma once
/// @file
/// @brief VTK XML polydata (.vtp) files, shared by the skeleton and surface readers/writers:
/// one-line errors naming the file, binary appended data, atomic writes.

#include <vtkPolyData.h>
#include <vtkSmartPointer.h>

#include <filesystem>

namespace brainshift::imaging {

/// Reads a .vtp file. \throws brainshift::Error naming the file: missing, not a regular file,
/// not VTK XML polydata, or VTK's own read error.
vtkSmartPointer<vtkPolyData> read_polydata(const std::filesystem::path& path);

/// Writes `poly` to a .vtp file atomically. \throws brainshift::Error naming the path.
void write_polydata(const std::filesystem::path& path, vtkPolyData* poly);

}  // namespace brainshift::imaging
