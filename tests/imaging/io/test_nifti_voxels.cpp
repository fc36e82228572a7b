// The direct NIfTI voxel read (imaging/io/nifti_voxels.hpp) against VTK's reader on files made
// by hand: every datatype it reads, scaled or not, .nii and .nii.gz, and the files it leaves to
// VTK. Real files: test_nifti_real.cpp.

#include "expect_error.hpp"
#include "temp_folder.hpp"

#include "imaging/io/image_io.hpp"
#include "imaging/io/nifti_voxels.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include <zlib.h>

namespace brainshift::imaging {
namespace {

using tests::expect_error;

void write_bytes(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

/// A NIfTI-1 file made by hand: a 5×4×3 grid of `datatype` voxels (values from `values`, cast
/// to the type) with an sform, scl_slope / scl_inter, pixdim[0] = qfac, and every field in the
/// other byte order when `swapped`.
struct HandNifti {
  std::int16_t datatype = 16;
  float slope = 0.0F, inter = 0.0F, qfac = 1.0F;
  bool swapped = false;
};

/// Calls f(T{}) with the C++ type of a NIfTI datatype code (the eight the tests write).
template <class F>
void with_type(std::int16_t datatype, F&& f) {
  switch (datatype) {
    case 2:
      return f(std::uint8_t{});
    case 256:
      return f(std::int8_t{});
    case 4:
      return f(std::int16_t{});
    case 512:
      return f(std::uint16_t{});
    case 8:
      return f(std::int32_t{});
    case 768:
      return f(std::uint32_t{});
    case 16:
      return f(float{});
    default:
      return f(double{});
  }
}

std::string hand_nifti(const HandNifti& f, const std::vector<double>& values) {
  const auto bytes_of = [&](auto v) {  // in the file's byte order
    std::string b(sizeof v, '\0');
    std::memcpy(b.data(), &v, sizeof v);
    if (f.swapped) std::reverse(b.begin(), b.end());
    return b;
  };
  std::string h(352, '\0');
  const auto put = [&](int at, auto v) {
    std::memcpy(h.data() + at, bytes_of(v).data(), sizeof v);
  };
  const std::array<std::int16_t, 3> dims = {5, 4, 3};
  put(0, std::int32_t(348));
  put(40, std::int16_t(3));
  for (int a = 0; a < 3; ++a) put(42 + 2 * a, dims[std::size_t(a)]);
  for (int a = 4; a < 8; ++a) put(40 + 2 * a, std::int16_t(1));
  put(70, f.datatype);
  with_type(f.datatype, [&](auto t) { put(72, std::int16_t(8 * sizeof t)); });  // bitpix
  put(76, f.qfac);
  const std::array<float, 3> spacing = {0.8F, 0.9F, 1.2F};
  for (int a = 0; a < 3; ++a) put(80 + 4 * a, spacing[std::size_t(a)]);
  put(108, 352.0F);  // vox_offset
  put(112, f.slope);
  put(116, f.inter);
  put(254, std::int16_t(1));  // sform_code: scanner
  const float srow[3][4] = {{0.8F, 0, 0, -10}, {0, 0.9F, 0, 5}, {0, 0, 1.2F, 3}};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) put(280 + 16 * r + 4 * c, srow[r][c]);
  std::memcpy(h.data() + 344, "n+1", 4);
  with_type(f.datatype, [&](auto t) {
    for (double v : values) h += bytes_of(static_cast<decltype(t)>(v));
  });
  return h;
}

void write_gzip(const std::filesystem::path& path, const std::string& bytes) {
  gzFile z = gzopen(path.c_str(), "wb");
  ASSERT_NE(z, nullptr);
  ASSERT_EQ(gzwrite(z, bytes.data(), unsigned(bytes.size())), int(bytes.size()));
  gzclose(z);
}

/// read_volume() reads the voxels of a single-file NIfTI itself (nifti_voxels.hpp); VTK's reader
/// is the independent answer. Every datatype it reads, scaled or not, .nii and .nii.gz, and the
/// files it leaves to VTK (qfac −1: VTK reverses the slices; the other byte order): the same
/// geometry and the same floats, to the bit.
TEST(ImageIo, NiftiVoxelsReadDirectlyAreVtksToTheBit) {
  const tests::TempFolder dir;
  // Values each type holds exactly: 0…100 for the unsigned, −20…80 for the signed, quarters
  // for the floating types.
  const auto values_of = [](std::int16_t dt) {
    const bool is_unsigned = dt == 2 || dt == 512 || dt == 768, is_float = dt == 16 || dt == 64;
    std::vector<double> v(60);
    for (std::size_t i = 0; i < v.size(); ++i)
      v[i] = double((i * 37) % 101) - (is_unsigned ? 0.0 : 20.0) - (is_float ? 0.25 : 0.0);
    return v;
  };
  std::vector<HandNifti> files;
  for (std::int16_t dt : {2, 256, 4, 512, 8, 768, 16, 64}) files.push_back({dt});
  files.push_back({4, 2.5F, -10.0F});       // scaled int16
  files.push_back({16, 0.5F, 1.0F});        // scaled float32
  files.push_back({4, 0.0F, 0.0F, -1.0F});  // qfac −1: VTK's slice order is the file's reversed
  files.push_back({16, 0.0F, 0.0F, 1.0F, true});  // the other byte order
  for (const HandNifti& f : files)
    for (const bool gz : {false, true}) {
      const std::string name =
          "dt" + std::to_string(f.datatype) + "_s" + std::to_string(int(f.slope * 10)) + "_q" +
          std::to_string(int(f.qfac)) + (f.swapped ? "_swap" : "") + (gz ? ".nii.gz" : ".nii");
      SCOPED_TRACE(name);
      const std::vector<double> values = values_of(f.datatype);
      const std::string bytes = hand_nifti(f, values);
      if (gz)
        write_gzip(dir / name, bytes);
      else
        write_bytes(dir / name, bytes);
      const VolumeF direct = read_volume(dir / name);
      const VolumeF vtk = read_nifti_by_vtk(dir / name);
      EXPECT_EQ(direct.geometry.size, vtk.geometry.size);
      EXPECT_EQ(direct.geometry.spacing, vtk.geometry.spacing);
      EXPECT_EQ(direct.geometry.origin, vtk.geometry.origin);
      EXPECT_EQ(direct.geometry.direction, vtk.geometry.direction);
      EXPECT_EQ(direct.components, vtk.components);
      EXPECT_EQ(direct.data, vtk.data);
      // The direct read is what read_volume() took where it could (not VTK's fallback twice).
      std::vector<float> raw;
      EXPECT_EQ(read_nifti_voxels(dir / name, {352, f.datatype, values.size()}, raw), !f.swapped);
      if (!f.swapped && f.slope == 0.0F && f.qfac == 1.0F) {
        EXPECT_EQ(raw, direct.data);
      }
      // And both are the values written (unscaled, file order: the flipped file aside).
      if (f.slope == 0.0F && f.qfac == 1.0F) {
        for (std::size_t i = 0; i < values.size(); ++i)
          ASSERT_EQ(direct.data[i], static_cast<float>(values[i])) << "voxel " << i;
      }
    }
}

TEST(ImageIoErrors, ACompressedNiftiEndingBeforeItsVoxelsIsNamedTruncated) {
  const tests::TempFolder dir;
  const std::vector<double> values(60, 1.0);
  const std::string bytes = hand_nifti({}, values);
  // A whole gzip stream of the header and half the voxels, and a stream cut in its middle.
  write_gzip(dir / "short.nii.gz", bytes.substr(0, 352 + 120));
  expect_error([&] { read_volume(dir / "short.nii.gz"); }, {"short.nii.gz", "truncated"});
  write_gzip(dir / "whole.nii.gz", bytes);
  const auto size = std::filesystem::file_size(dir / "whole.nii.gz");
  std::filesystem::copy_file(dir / "whole.nii.gz", dir / "cut.nii.gz");
  std::filesystem::resize_file(dir / "cut.nii.gz", size - 12);
  expect_error([&] { read_volume(dir / "cut.nii.gz"); }, {"cut.nii.gz"});
  // A vox_offset of 10¹² bytes in a small .nii.gz: left to VTK, which finds the file too short
  // (no terabyte buffer for the header's bytes).
  std::string far = bytes;
  const float offset = 1e12F;
  std::memcpy(far.data() + 108, &offset, 4);
  write_gzip(dir / "far.nii.gz", far);
  std::vector<float> raw;
  EXPECT_FALSE(read_nifti_voxels(dir / "far.nii.gz", {std::int64_t(1e12), 16, 60}, raw));
  expect_error([&] { read_volume(dir / "far.nii.gz"); }, {"far.nii.gz", "truncated"});
}

}  // namespace
}  // namespace brainshift::imaging
