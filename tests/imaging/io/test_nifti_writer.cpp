// write_volume()'s NIfTI files against vtkNIFTIImageWriter's (imaging/io/image_io.cpp builds the
// header itself instead of having VTK write the whole volume and reading it back).

#include "file_bytes.hpp"
#include "temp_folder.hpp"

#include "imaging/io/gzip_file.hpp"
#include "imaging/io/image_io.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkMatrix4x4.h>
#include <vtkNIFTIImageWriter.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnsignedCharArray.h>

#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <type_traits>
#include <vector>
#include <zlib.h>

namespace brainshift::imaging {
namespace {

using tests::file_bytes;
using tests::gunzip;

/// What write_volume() wrote before it built the header itself: VTK's writer with the volume's
/// voxels (packed components), no image origin, the world matrix as qform and sform.
template <typename T>
void write_with_vtk(const std::filesystem::path& path, const Volume<T>& volume) {
  const ImageGeometry& g = volume.geometry;
  vtkNew<vtkImageData> image;
  image->SetDimensions(g.size[0], g.size[1], g.size[2]);
  image->SetSpacing(g.spacing[0], g.spacing[1], g.spacing[2]);
  using Array = std::conditional_t<std::is_same_v<T, float>, vtkFloatArray, vtkUnsignedCharArray>;
  vtkNew<Array> array;
  array->SetNumberOfComponents(volume.components);
  array->SetNumberOfTuples(g.voxel_count());
  std::copy(volume.data.begin(), volume.data.end(), array->GetPointer(0));
  image->GetPointData()->SetScalars(array);
  vtkNew<vtkMatrix4x4> m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m->SetElement(r, c, g.direction(r, c));
    m->SetElement(r, 3, g.origin[r]);
  }
  vtkNew<vtkNIFTIImageWriter> writer;
  writer->SetInputData(image);
  writer->SetSFormMatrix(m);
  writer->SetQFormMatrix(m);
  writer->SetFileName(path.string().c_str());
  writer->Write();
}

/// write_volume()'s .nii is VTK's file for `v` byte for byte, and its .nii.gz decompresses to it.
void expect_vtks_bytes(const tests::TempFolder& dir, const VolumeF& v) {
  write_with_vtk(dir / "vtk.nii", v);
  write_volume(dir / "ours.nii", v);
  write_volume(dir / "ours.nii.gz", v);
  const std::vector<char> reference = file_bytes(dir / "vtk.nii");
  ASSERT_EQ(reference.size(), 352 + v.data.size() * sizeof(float));
  EXPECT_TRUE(file_bytes(dir / "ours.nii") == reference);
  EXPECT_TRUE(gunzip(dir / "ours.nii.gz") == reference);
}

ImageGeometry geometry(int variant) {
  ImageGeometry g;
  g.size = {7, 5, variant == 3 ? 1 : 4};  // variant 3: one slice (NIfTI dim[0] 2)
  g.spacing = {0.8, 1.1, 2.5};
  g.origin = {-31.5, 12.25, 70.0};
  if (variant >= 1)  // oblique
    g.direction = (Eigen::AngleAxisd(0.3, Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(-0.2, Vector3d(1, 1, 0).normalized()))
                      .toRotationMatrix();
  if (variant == 2) g.direction.col(2) *= -1.0;  // left-handed
  if (variant == 4)  // rotated by more than π/2: a negative quaternion w
    g.direction = Eigen::AngleAxisd(2.9, Vector3d(0.2, -1, 0.4).normalized()).toRotationMatrix();
  return g;
}

TEST(NiftiWriter, HeaderAndVoxelsAreVtksByteForByte) {
  // Axis-aligned, oblique, left-handed, one-slice and strongly rotated grids; float with 1 and 3
  // components (the latter stored component by component) and unsigned char labels: the .nii
  // must be VTK's file exactly, and the .nii.gz decompress to it.
  const tests::TempFolder dir;
  std::mt19937 rng(16);
  std::uniform_real_distribution<float> u(-100.0F, 100.0F);
  for (int variant = 0; variant <= 4; ++variant) {
    const ImageGeometry g = geometry(variant);
    for (const int components : {1, 3}) {
      SCOPED_TRACE("variant " + std::to_string(variant) + ", float, components " +
                   std::to_string(components));
      VolumeF v(g, components);
      for (float& x : v.data) x = u(rng);
      expect_vtks_bytes(dir, v);
    }
    SCOPED_TRACE("variant " + std::to_string(variant) + ", labels");
    LabelVolume labels(g);
    for (std::size_t i = 0; i < labels.data.size(); ++i) labels.data[i] = std::uint8_t(i % 4);
    write_with_vtk(dir / "vtk.nii", labels);
    write_labels(dir / "ours.nii", labels);
    EXPECT_TRUE(file_bytes(dir / "ours.nii") == file_bytes(dir / "vtk.nii"));
  }
}

TEST(NiftiWriter, VectorVolumeAcrossManyBlocksIsVtksByteForByte) {
  // A displacement-field-like volume of 2.5 MB: written block by block (1 MiB), its blocks start
  // and end inside a component's plane and across the planes' boundaries; the file must still be
  // VTK's exactly, uncompressed and gzipped.
  const tests::TempFolder dir;
  ImageGeometry g = geometry(1);
  g.size = {70, 61, 50};
  VolumeF v(g, 3);
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(-20.0F, 20.0F);
  for (float& x : v.data) x = u(rng);
  ASSERT_GT(352 + v.data.size() * sizeof(float), 2 * kGzipBlockBytes);
  expect_vtks_bytes(dir, v);
}

}  // namespace
}  // namespace brainshift::imaging
