// The direct NIfTI voxel read (imaging/io/nifti_voxels.hpp) against VTK's reader on every NIfTI
// file of the real data: RESECT's 17 intra-operative B-mode volumes (float32, .nii.gz) and
// ICBM152's T1 and label volume (uint8, .nii.gz). Skips where ../shared/data is absent.

#include "tests/config.hpp"

#include "imaging/io/image_io.hpp"
#include "imaging/io/nifti_voxels.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

namespace brainshift::imaging {
namespace {

TEST(NiftiReal, EveryRealVolumeReadsToTheBitAsVtkReadsIt) {
  const std::filesystem::path root(tests::shared_data_dir);
  if (!std::filesystem::is_directory(root)) GTEST_SKIP() << "shared data absent: " << root;
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::recursive_directory_iterator(root)) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file() && (name.ends_with(".nii") || name.ends_with(".nii.gz")))
      files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  // 17 RESECT volumes and ICBM152's two: a data set that lost its files must not pass empty.
  ASSERT_GE(files.size(), 19U) << root;
  for (const auto& f : files) {
    SCOPED_TRACE(f.string());
    const VolumeF direct = read_volume(f);
    const VolumeF vtk = read_nifti_by_vtk(f);
    EXPECT_EQ(direct.geometry.size, vtk.geometry.size);
    EXPECT_EQ(direct.geometry.spacing, vtk.geometry.spacing);
    EXPECT_EQ(direct.geometry.origin, vtk.geometry.origin);
    EXPECT_EQ(direct.geometry.direction, vtk.geometry.direction);
    ASSERT_EQ(direct.data.size(), vtk.data.size());
    EXPECT_TRUE(direct.data == vtk.data) << "voxel values differ";  // the same floats, bit for bit
  }
}

}  // namespace
}  // namespace brainshift::imaging
