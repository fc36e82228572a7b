#include "expect_error.hpp"
#include "temp_folder.hpp"
#include "tests/imaging/io/oblique_grid.hpp"

#include "imaging/io/image_frame.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/mesh_io.hpp"
#include "imaging/io/skeleton_io.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>
#include <zlib.h>

namespace brainshift::imaging {
namespace {

using tests::expect_error;

/// NIfTI stores its sform in float32: ~1e-7 relative, so 1e-5 mm on coordinates ≲ 100 mm.
constexpr double header_tolerance = 1e-5;

using test_grids::oblique_geometry;

VolumeF random_volume(const ImageGeometry& g, int components, unsigned seed = 1) {
  VolumeF v(g, components);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-100.0f, 100.0f);
  for (float& x : v.data) x = u(rng);
  return v;
}

/// World position of voxel (i, j, k) compared between two geometries.
void expect_same_world(const ImageGeometry& a, const ImageGeometry& b) {
  ASSERT_EQ(a.size, b.size);
  for (const Vector3d& ijk : {Vector3d(0, 0, 0), Vector3d(a.size[0] - 1, 0, 0),
                              Vector3d(0, a.size[1] - 1, 0), Vector3d(0, 0, a.size[2] - 1)})
    EXPECT_LT((a.index_to_world(ijk) - b.index_to_world(ijk)).norm(), header_tolerance)
        << "voxel " << ijk.transpose();
}

/// Value of `volume` at world point `p` of voxel (i, j, k) of `reference` (resolved by world
/// position, so a reader that reorders axes but keeps the world mapping still passes).
float value_at_world(const VolumeF& volume, const Vector3d& p, int c) {
  const Vector3d ijk = volume.geometry.world_to_index(p);
  const Eigen::Vector3i n = ijk.array().round().cast<int>();
  EXPECT_TRUE(volume.geometry.contains_index(n[0], n[1], n[2])) << p.transpose();
  return volume.at(n[0], n[1], n[2], c);
}

void expect_same_volume(const VolumeF& written, const VolumeF& read) {
  ASSERT_EQ(read.components, written.components);
  ASSERT_EQ(read.geometry.voxel_count(), written.geometry.voxel_count());
  const ImageGeometry& g = written.geometry;
  if (read.geometry.size == g.size) expect_same_world(g, read.geometry);
  int mismatches = 0;
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        for (int c = 0; c < written.components; ++c)
          if (value_at_world(read, g.index_to_world(Vector3d(i, j, k)), c) !=
              written.at(i, j, k, c))
            ++mismatches;
  EXPECT_EQ(mismatches, 0) << "float32 voxel values must round-trip exactly";
}

class ImageIoRoundTrip : public ::testing::TestWithParam<std::string> {};

TEST_P(ImageIoRoundTrip, ScalarVolumeKeepsValuesAndWorldGeometry) {
  SCOPED_TRACE(GetParam());
  const tests::TempFolder dir;
  const VolumeF volume = random_volume(oblique_geometry(), 1);
  write_volume(dir / ("scalar" + GetParam()), volume);
  EXPECT_EQ(dir.count(), 1u) << "no temporary file may be left behind";
  expect_same_volume(volume, read_volume(dir / ("scalar" + GetParam())));
}

TEST_P(ImageIoRoundTrip, LeftHandedGridKeepsItsWorldPositions) {
  SCOPED_TRACE(GetParam());
  const tests::TempFolder dir;
  const VolumeF volume = random_volume(oblique_geometry(/*left_handed=*/true), 1, 2);
  write_volume(dir / ("left" + GetParam()), volume);
  expect_same_volume(volume, read_volume(dir / ("left" + GetParam())));
}

TEST_P(ImageIoRoundTrip, VectorVolumeKeepsRasVectors) {
  SCOPED_TRACE(GetParam());
  const tests::TempFolder dir;
  const VolumeF volume = random_volume(oblique_geometry(), 3, 3);
  write_volume(dir / ("vector" + GetParam()), volume);
  expect_same_volume(volume, read_volume(dir / ("vector" + GetParam())));
}

TEST_P(ImageIoRoundTrip, VectorVolumeOfManyWriteBlocksKeepsRasVectors) {
  // 2.5 MB of vectors: the NIfTI and NRRD writers stream 1 MiB blocks (no copy of the volume), so
  // blocks end inside vectors' planes and across them; every value must still come back.
  SCOPED_TRACE(GetParam());
  const tests::TempFolder dir;
  ImageGeometry g = oblique_geometry();
  g.size = {70, 61, 50};
  const VolumeF volume = random_volume(g, 3, 4);
  write_volume(dir / ("vector" + GetParam()), volume);
  expect_same_volume(volume, read_volume(dir / ("vector" + GetParam())));
}

TEST_P(ImageIoRoundTrip, LabelsRoundTrip) {
  SCOPED_TRACE(GetParam());
  const tests::TempFolder dir;
  LabelVolume labels(oblique_geometry());
  for (std::size_t v = 0; v < labels.data.size(); ++v) labels.data[v] = std::uint8_t(v % 4);
  write_labels(dir / ("labels" + GetParam()), labels);
  const LabelVolume read = read_labels(dir / ("labels" + GetParam()));
  ASSERT_EQ(read.geometry.size, labels.geometry.size);
  expect_same_world(labels.geometry, read.geometry);
  EXPECT_EQ(read.data, labels.data);
}

INSTANTIATE_TEST_SUITE_P(Formats, ImageIoRoundTrip,
                         ::testing::Values(".nii", ".nii.gz", ".mha", ".nrrd", ".vti"),
                         [](const auto& param_info) {
                           std::string name = param_info.param.substr(1);
                           for (char& c : name)
                             if (c == '.') c = '_';
                           return name;
                         });

void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

TEST(ImageIo, MetaImageIsReadAsLpsAndConvertedToRas) {
  // A 2×1×1 float MetaImage, LPS physical frame with flipped i and j axes like the VMTK aorta.
  const tests::TempFolder dir;
  const float values[2] = {5.0f, 7.0f};
  std::string text =
      "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
      "CompressedData = False\nTransformMatrix = -1 0 0 0 -1 0 0 0 1\nOffset = -156 -24 3\n"
      "AnatomicalOrientation = LPI\nElementSpacing = 0.5 0.75 1.5\nDimSize = 2 1 1\n"
      "ElementType = MET_FLOAT\nElementDataFile = LOCAL\n";
  text.append(reinterpret_cast<const char*>(values), sizeof(values));
  write_text(dir / "lps.mha", text);
  const VolumeF v = read_volume(dir / "lps.mha");
  // ITK physical (LPS) of voxel i: Offset + D·(0.5 i, 0, 0) = (−156 − 0.5 i, −24, 3);
  // RAS = (156 + 0.5 i, 24, 3).
  EXPECT_LT((v.geometry.index_to_world({0, 0, 0}) - Vector3d(156, 24, 3)).norm(), 1e-12);
  EXPECT_LT((v.geometry.index_to_world({1, 0, 0}) - Vector3d(156.5, 24, 3)).norm(), 1e-12);
  EXPECT_EQ(v.at(1, 0, 0), 7.0f);
}

TEST(ImageIo, NrrdInLpsIsConvertedToRasWithItsVectors) {
  const tests::TempFolder dir;
  const float values[3] = {1.0f, 2.0f, 3.0f};
  std::string text =
      "NRRD0004\ntype: float\ndimension: 4\nspace: left-posterior-superior\nsizes: 3 1 1 1\n"
      "space directions: none (0,-2,0) (1,0,0) (0,0,3)\nkinds: vector domain domain domain\n"
      "endian: little\nencoding: raw\nspace origin: (10,20,30)\n\n";
  text.append(reinterpret_cast<const char*>(values), sizeof(values));
  write_text(dir / "lps.nrrd", text);
  const VolumeF v = read_volume(dir / "lps.nrrd");
  ASSERT_EQ(v.components, 3);
  EXPECT_LT((v.geometry.origin - Vector3d(-10, -20, 30)).norm(), 1e-12);
  EXPECT_LT((v.geometry.direction.col(0) - Vector3d(0, 1, 0)).norm(), 1e-12);  // −(0,−1,0)
  EXPECT_LT((v.geometry.spacing - Vector3d(2, 1, 3)).norm(), 1e-12);
  EXPECT_EQ(v.at(0, 0, 0, 0), -1.0f);
  EXPECT_EQ(v.at(0, 0, 0, 1), -2.0f);
  EXPECT_EQ(v.at(0, 0, 0, 2), 3.0f);
}

/// The header text of a NRRD file (up to the blank line) and its raw float payload.
std::pair<std::string, std::vector<float>> split_nrrd(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string header, line;
  while (std::getline(in, line) && !line.empty()) header += line + "\n";
  std::vector<float> data;
  for (float f; in.read(reinterpret_cast<char*>(&f), sizeof f);) data.push_back(f);
  return {header, data};
}

TEST(SlicerDisplacement, TranslationIsWrittenInLpsWithFlippedVectorsAndGeometry) {
  const tests::TempFolder dir;
  const ImageGeometry g = oblique_geometry();
  VolumeF u(g, 3);
  const Vector3d t_ras(1.5, -2.0, 3.25);  // mm, a rigid translation
  for (std::size_t v = 0; v < u.data.size(); v += 3)
    for (int c = 0; c < 3; ++c) u.data[v + c] = float(t_ras[c]);
  write_displacement_for_slicer(dir / "u.nrrd", u);

  const auto [header, data] = split_nrrd(dir / "u.nrrd");
  EXPECT_NE(header.find("space: left-posterior-superior\n"), std::string::npos) << header;
  EXPECT_NE(header.find("kinds: vector domain domain domain\n"), std::string::npos) << header;
  EXPECT_NE(header.find("type: float\n"), std::string::npos) << header;
  EXPECT_NE(header.find("sizes: 3 7 5 4\n"), std::string::npos) << header;
  // What current Slicer reads without asking: a displacement field, resampling sense, its
  // vectors in the file's space.
  EXPECT_NE(header.find("intent_code:=1006\n"), std::string::npos) << header;
  EXPECT_NE(header.find("displacement field type:=resampling\n"), std::string::npos) << header;
  EXPECT_NE(header.find("measurement frame: (1,0,0) (0,1,0) (0,0,1)\n"), std::string::npos)
      << header;
  // space origin in LPS: (−x, −y, z) of the RAS origin.
  std::istringstream origin_line(header.substr(header.find("space origin: (") + 15));
  double ox = 0, oy = 0, oz = 0;
  char comma = 0;
  origin_line >> ox >> comma >> oy >> comma >> oz;
  EXPECT_DOUBLE_EQ(ox, -g.origin.x());
  EXPECT_DOUBLE_EQ(oy, -g.origin.y());
  EXPECT_DOUBLE_EQ(oz, g.origin.z());
  // First axis direction in LPS: flip of direction·spacing.
  std::istringstream dir_line(header.substr(header.find("space directions: none (") + 24));
  double d0 = 0, d1 = 0, d2 = 0;
  dir_line >> d0 >> comma >> d1 >> comma >> d2;
  const Vector3d axis0 = g.direction.col(0) * g.spacing[0];
  EXPECT_DOUBLE_EQ(d0, -axis0.x());
  EXPECT_DOUBLE_EQ(d1, -axis0.y());
  EXPECT_DOUBLE_EQ(d2, axis0.z());
  // Vectors: u_LPS = (−1.5, 2.0, 3.25) at every voxel.
  ASSERT_EQ(data.size(), u.data.size());
  int wrong = 0;
  for (std::size_t v = 0; v < data.size(); v += 3)
    if (data[v] != -1.5f || data[v + 1] != 2.0f || data[v + 2] != 3.25f) ++wrong;
  EXPECT_EQ(wrong, 0);
  // And our reader takes it back to RAS.
  expect_same_volume(u, read_volume(dir / "u.nrrd"));
}

TEST(SlicerDisplacement, AFieldOfManyWriteBlocksIsFlippedVectorByVector) {
  // 2.5 MB: written in 1 MiB blocks of whole vectors, each negated in x and y on its way out.
  // Every stored vector must be the RAS one with x, y negated, and the reader must take it back.
  const tests::TempFolder dir;
  ImageGeometry g = oblique_geometry();
  g.size = {70, 61, 50};
  const VolumeF u = random_volume(g, 3, 5);
  write_displacement_for_slicer(dir / "u.nrrd", u);
  const auto [header, data] = split_nrrd(dir / "u.nrrd");
  ASSERT_EQ(data.size(), u.data.size());
  int wrong = 0;
  for (std::size_t v = 0; v < data.size(); v += 3)
    if (data[v] != -u.data[v] || data[v + 1] != -u.data[v + 1] || data[v + 2] != u.data[v + 2])
      ++wrong;
  EXPECT_EQ(wrong, 0);
  expect_same_volume(u, read_volume(dir / "u.nrrd"));
}

TEST(SlicerDisplacement, RefusesOtherFormatsAndScalarVolumes) {
  const tests::TempFolder dir;
  expect_error(
      [&] { write_displacement_for_slicer(dir / "u.nii", VolumeF(oblique_geometry(), 3)); },
      {"u.nii", ".nrrd"});
  expect_error([&] { write_displacement_for_slicer(dir / "u.nrrd", VolumeF(oblique_geometry())); },
               {"u.nrrd", "3 components"});
  EXPECT_EQ(dir.count(), 0u);
}

TEST(ImageIoErrors, MissingFileUnknownExtensionAndEmptyFile) {
  const tests::TempFolder dir;
  expect_error([&] { read_volume(dir / "absent.nii"); }, {"absent.nii", "no such file"});
  write_text(dir / "image.png", "x");
  expect_error([&] { read_volume(dir / "image.png"); },
               {"image.png", "unknown image file extension"});
  write_text(dir / "empty.nii.gz", "");
  expect_error([&] { read_volume(dir / "empty.nii.gz"); }, {"empty.nii.gz", "empty file"});
  expect_error([&] { write_volume(dir / "no_folder" / "x.nii", VolumeF(oblique_geometry())); },
               {"x.nii", "does not exist"});
}

TEST(ImageIoErrors, GarbageAndTruncatedFilesAreOneLineErrors) {
  for (const std::string ext : {".nii", ".nii.gz", ".mha", ".nrrd", ".vti"}) {
    SCOPED_TRACE(ext);
    const tests::TempFolder dir;
    write_text(dir / ("garbage" + ext), std::string(400, 'g'));
    expect_error([&] { read_volume(dir / ("garbage" + ext)); }, {"garbage" + ext});

    ImageGeometry big = oblique_geometry();
    big.size = {40, 30, 20};
    write_volume(dir / ("whole" + ext), random_volume(big, 1));
    const auto size = std::filesystem::file_size(dir / ("whole" + ext));
    std::filesystem::copy_file(dir / ("whole" + ext), dir / ("cut" + ext));
    std::filesystem::resize_file(dir / ("cut" + ext), size / 2);
    expect_error([&] { read_volume(dir / ("cut" + ext)); }, {"cut" + ext});
  }
}

TEST(ImageIoErrors, NonFiniteSpacingAndZeroSizeAreRefused) {
  const tests::TempFolder dir;
  const std::string head = "NRRD0004\ntype: float\ndimension: 3\nspace: RAS\n";
  write_text(dir / "nan.nrrd", head +
                                   "sizes: 1 1 1\nspace directions: (nan,0,0) (0,1,0) (0,0,1)\n"
                                   "encoding: raw\n\nxxxx");
  expect_error([&] { read_volume(dir / "nan.nrrd"); }, {"nan.nrrd", "spacing"});
  write_text(dir / "zero.nrrd", head +
                                    "sizes: 0 1 1\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n"
                                    "encoding: raw\n\n");
  expect_error([&] { read_volume(dir / "zero.nrrd"); }, {"zero.nrrd", "zero-size"});
  write_text(dir / "shear.nrrd", head +
                                     "sizes: 1 1 1\nspace directions: (1,0,0) (1,1,0) (0,0,1)\n"
                                     "encoding: raw\n\nxxxx");
  expect_error([&] { read_volume(dir / "shear.nrrd"); }, {"shear.nrrd", "orthonormal"});
  ImageGeometry bad = oblique_geometry();
  bad.spacing[1] = std::numeric_limits<double>::infinity();
  expect_error([&] { write_volume(dir / "inf.nii", VolumeF(bad)); }, {"inf.nii", "spacing"});
}

/// A NIfTI-1 header (348 bytes + 4 of extension flag) claiming `dims` float32 voxels with
/// spacing `pixdim`, written by hand (the fields at their offsets in nifti1.h).
std::string nifti_header(std::array<std::int16_t, 3> dims, float pixdim) {
  std::string h(352, '\0');
  const auto put = [&](int at, const auto& v) { std::memcpy(h.data() + at, &v, sizeof v); };
  put(0, std::int32_t(348));
  put(40, std::int16_t(3));
  for (int a = 0; a < 3; ++a) put(42 + 2 * a, dims[std::size_t(a)]);
  put(70, std::int16_t(16));  // DT_FLOAT32
  put(72, std::int16_t(32));  // bitpix
  for (int a = 1; a <= 3; ++a) put(76 + 4 * a, pixdim);
  put(108, 352.0f);  // vox_offset
  std::memcpy(h.data() + 344, "n+1", 4);
  return h;
}

TEST(ImageIoErrors, HostileHeadersAreRefusedBeforeAnyAllocation) {
  // Issue 36: a header claiming 30000³ float voxels over 1 kB of data ended in std::bad_alloc;
  // a small .nii.gz inflating to gigabytes was decompressed before its zero spacing was seen.
  const tests::TempFolder dir;
  write_text(dir / "huge.nii", nifti_header({30000, 30000, 30000}, 1.0f) + std::string(1024, 'x'));
  expect_error([&] { read_volume(dir / "huge.nii"); }, {"huge.nii", "claims", "GiB"});
  write_text(dir / "short.nii", nifti_header({64, 64, 64}, 1.0f) + std::string(1024, 'x'));
  expect_error([&] { read_volume(dir / "short.nii"); }, {"short.nii", "truncated", "claims"});
  {  // Found by fuzzing: VTK's reader crashed on an unknown datatype code.
    std::string h = nifti_header({2, 2, 2}, 1.0f);
    const std::int16_t datatype = 24080;
    std::memcpy(h.data() + 70, &datatype, 2);
    write_text(dir / "datatype.nii", h + std::string(64, '\0'));
  }
  expect_error([&] { read_volume(dir / "datatype.nii"); },
               {"datatype.nii", "NIfTI datatype 24080", "not a scalar type"});
  const std::string zeros(4 << 20, '\0');  // 4 MiB of voxels: 64 × 128 × 128 floats
  {
    gzFile z = gzopen((dir / "zero_spacing.nii.gz").c_str(), "wb");
    const std::string h = nifti_header({64, 128, 128}, 0.0f);
    gzwrite(z, h.data(), unsigned(h.size()));
    gzwrite(z, zeros.data(), unsigned(zeros.size()));
    gzclose(z);
  }
  expect_error([&] { read_volume(dir / "zero_spacing.nii.gz"); },
               {"zero_spacing.nii.gz", "pixdim[1]", "spacing"});
  {  // 1.6 GB claimed from a few kB of gzip: more than deflate can hold.
    gzFile z = gzopen((dir / "bomb.nii.gz").c_str(), "wb");
    const std::string h = nifti_header({1000, 1000, 400}, 1.0f);
    gzwrite(z, h.data(), unsigned(h.size()));
    gzwrite(z, zeros.data(), 4096);
    gzclose(z);
  }
  expect_error([&] { read_volume(dir / "bomb.nii.gz"); }, {"bomb.nii.gz", "deflate"});
  // MetaImage: the header alone is read first.
  write_text(dir / "huge.mha",
             "ObjectType = Image\nNDims = 3\nDimSize = 30000 30000 30000\nElementType = "
             "MET_FLOAT\nElementDataFile = LOCAL\n" +
                 std::string(1024, 'x'));
  expect_error([&] { read_volume(dir / "huge.mha"); }, {"huge.mha", "claims"});
  write_text(dir / "short.mha",
             "ObjectType = Image\nNDims = 3\nDimSize = 64 64 64\nElementType = "
             "MET_FLOAT\nElementDataFile = LOCAL\n" +
                 std::string(1024, 'x'));
  expect_error([&] { read_volume(dir / "short.mha"); }, {"short.mha", "truncated"});
  // Found by fuzzing: MetaIO hung on a huge NDims (it reads NDims² matrix entries) and divided by
  // zero on NDims 0 and on a data-file pattern; the text header is checked before MetaIO sees it.
  const std::string mha = "ObjectType = Image\nDimSize = 2 2 2\nElementType = MET_FLOAT\n";
  write_text(dir / "ndims.mha", mha + "NDims = 33333333333333333333\nElementDataFile = LOCAL\n");
  expect_error([&] { read_volume(dir / "ndims.mha"); },
               {"ndims.mha", "MetaImage NDims \"33333333333333333333\"", "2 or 3"});
  write_text(dir / "zero.mha", mha + "NDims = 0\nElementDataFile = LOCAL\n");
  expect_error([&] { read_volume(dir / "zero.mha"); }, {"zero.mha", "NDims \"0\""});
  write_text(dir / "long_key.mha", "ObjectType = Image\n" + std::string(300, 'L') + "\n = 3\n");
  expect_error([&] { read_volume(dir / "long_key.mha"); },
               {"long_key.mha", "header line 2 is not 'Key = value'"});
  write_text(dir / "pattern.mhd", mha + "NDims = 3\nElementDataFile = slice%03d.raw 1 2 0\n");
  expect_error([&] { read_volume(dir / "pattern.mhd"); },
               {"pattern.mhd", "ElementDataFile", "patterns and lists are not read"});
  // NRRD (our own reader): the same two claims, raw and gzip.
  const std::string nrrd =
      "NRRD0004\ntype: float\ndimension: 3\nspace: left-posterior-superior\n"
      "space directions: (1,0,0) (0,1,0) (0,0,1)\nspace origin: (0,0,0)\n";
  write_text(dir / "huge.nrrd",
             nrrd + "sizes: 2048 2048 2048\nencoding: raw\n\n" + std::string(1024, 'x'));
  expect_error([&] { read_volume(dir / "huge.nrrd"); }, {"huge.nrrd", "claims", "GiB"});
  write_text(dir / "short.nrrd",
             nrrd + "sizes: 64 64 64\nencoding: raw\n\n" + std::string(1024, 'x'));
  expect_error([&] { read_volume(dir / "short.nrrd"); }, {"short.nrrd", "truncated", "claims"});
  write_text(dir / "bomb.nrrd",
             nrrd + "sizes: 1024 1024 1024\nencoding: gzip\n\n" + std::string(1024, 'x'));
  expect_error([&] { read_volume(dir / "bomb.nrrd"); }, {"bomb.nrrd", "deflate"});
}

TEST(ImageIoErrors, HostileVtkXmlHeadersAreRefusedBeforeVtkAllocates) {
  // Issue 36 item 1: a .vtu claiming 9·10¹¹ points made VTK allocate until std::bad_alloc (the
  // message named no file). The counts of every <Piece> and an image's WholeExtent are checked
  // against the memory ceiling and the file's size before VTK reads a byte of data.
  const tests::TempFolder dir;
  const auto vtu = [](const std::string& points) {
    return "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
           "<UnstructuredGrid><Piece NumberOfPoints=\"" +
           points +
           "\" NumberOfCells=\"1\">\n<Points><DataArray type=\"Float64\" "
           "NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 0 0 0 1 0 0 0 1</DataArray>"
           "</Points>\n<Cells><DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">"
           "0 1 2 3</DataArray><DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">4"
           "</DataArray><DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">10</DataArray>"
           "</Cells>\n</Piece></UnstructuredGrid></VTKFile>\n";
  };
  write_text(dir / "good.vtu", vtu("4"));
  EXPECT_EQ(read_tet_mesh(dir / "good.vtu").num_nodes(), 4);  // the check passes a valid file
  write_text(dir / "huge.vtu", vtu("900000000000"));
  expect_error([&] { read_tet_mesh(dir / "huge.vtu"); }, {"huge.vtu", "claims", "GiB"});
  write_text(dir / "short.vtu", vtu("4000000"));  // 96 MB in memory, 12 M values from 700 bytes
  expect_error([&] { read_tet_mesh(dir / "short.vtu"); }, {"short.vtu", "claims", "corrupt"});
  write_text(dir / "negative.vtu", vtu("-4"));
  expect_error([&] { read_tet_mesh(dir / "negative.vtu"); },
               {"negative.vtu", "NumberOfPoints", "not a count"});
  write_text(dir / "lines.vtp",
             "<VTKFile type=\"PolyData\" version=\"0.1\"><PolyData><Piece NumberOfPoints=\"2\" "
             "NumberOfLines=\"1e15\"></Piece></PolyData></VTKFile>\n");
  expect_error([&] { read_skeleton_vtp(dir / "lines.vtp"); }, {"lines.vtp", "claims", "GiB"});
  write_text(dir / "huge.vti",
             "<VTKFile type=\"ImageData\" version=\"0.1\"><ImageData WholeExtent=\"0 99999 0 "
             "99999 0 99999\" Origin=\"0 0 0\" Spacing=\"1 1 1\"><Piece Extent=\"0 99999 0 99999 0 "
             "99999\"></Piece></ImageData></VTKFile>\n");
  expect_error([&] { read_volume(dir / "huge.vti"); }, {"huge.vti", "claims", "GiB"});
  // Found by fuzzing: a line whose point id lies beyond the points was walked out of bounds.
  write_text(dir / "bad_id.vtp",
             "<VTKFile type=\"PolyData\" version=\"0.1\"><PolyData><Piece NumberOfPoints=\"2\" "
             "NumberOfLines=\"1\"><Points><DataArray type=\"Float32\" NumberOfComponents=\"3\" "
             "format=\"ascii\">0 0 0 1 0 0</DataArray></Points><Lines><DataArray type=\"Int64\" "
             "Name=\"connectivity\" format=\"ascii\">0 7</DataArray><DataArray type=\"Int64\" "
             "Name=\"offsets\" format=\"ascii\">2</DataArray></Lines></Piece></PolyData>"
             "</VTKFile>\n");
  expect_error([&] { read_skeleton_vtp(dir / "bad_id.vtp"); },
               {"bad_id.vtp", "line point id 7", "outside the 2 points"});
}

TEST(ImageIoHeaders, SinglePrecisionDirectionIsReorthonormalisedAndNoted) {
  const tests::TempFolder dir;
  for (const std::string ext : {".nii.gz", ".nrrd", ".mha"}) {
    SCOPED_TRACE(ext);
    // The TOF file: a float32 sform orthonormal only to 1.3e-6.
    ImageGeometry g = oblique_geometry();
    g.direction(0, 1) += 1.3e-6;
    ASSERT_GT(orthonormality_error(g.direction), direction_note_level);
    write_volume(dir / ("float" + ext), random_volume(g, 1));
    std::string note;
    const VolumeF v = read_volume(dir / ("float" + ext), &note);
    EXPECT_NE(note.find("float" + ext), std::string::npos) << note;
    EXPECT_NE(note.find("re-orthonormalised"), std::string::npos) << note;
    // Mended to an exact rotation (double rounding), which moves no voxel centre by more than
    // ≈ 1.3e-6 × the grid's extent (< 1e-4 mm here).
    EXPECT_LT(orthonormality_error(v.geometry.direction), 1e-12);
    EXPECT_GT(v.geometry.direction.determinant(), 0.0);
    ImageGeometry expected = g;
    expect_same_world(v.geometry, expected);

    // A clean rotation stored in float is only rounded: no note.
    write_volume(dir / ("clean" + ext), random_volume(oblique_geometry(), 1));
    std::string clean_note = "unset";
    (void)read_volume(dir / ("clean" + ext), &clean_note);
    EXPECT_TRUE(clean_note.empty()) << clean_note;
  }
}

TEST(ImageIoHeaders, RealShearAndSingularDirectionsAreStillErrors) {
  const tests::TempFolder dir;
  const std::string head = "NRRD0004\ntype: float\ndimension: 3\nspace: RAS\n";
  // 1e-3 of shear (0.06°): ten times the single-precision allowance.
  write_text(dir / "small_shear.nrrd",
             head +
                 "sizes: 1 1 1\nspace directions: (1,0,0) (0.001,1,0) (0,0,1)\n"
                 "encoding: raw\n\nxxxx");
  expect_error([&] { read_volume(dir / "small_shear.nrrd"); },
               {"small_shear.nrrd", "not orthonormal"});
  write_text(dir / "singular.nrrd", head +
                                        "sizes: 1 1 1\nspace directions: (1,0,0) (1,0,0) (0,0,1)\n"
                                        "encoding: raw\n\nxxxx");
  expect_error([&] { read_volume(dir / "singular.nrrd"); }, {"singular.nrrd", "singular"});
  ImageGeometry sheared = oblique_geometry();
  sheared.direction(0, 1) += 2e-4;
  expect_error([&] { write_volume(dir / "sheared.nii", VolumeF(sheared)); },
               {"sheared.nii", "orthonormal"});
}

TEST(ImageIoErrors, LabelOutsideTheFourValuesIsNamed) {
  const tests::TempFolder dir;
  VolumeF volume(oblique_geometry());
  volume.at(2, 1, 3) = 7.0f;
  write_volume(dir / "bad_labels.nii.gz", volume);
  expect_error([&] { read_labels(dir / "bad_labels.nii.gz"); },
               {"bad_labels.nii.gz", "label value 7", "(2, 1, 3)"});
  LabelVolume labels(oblique_geometry());
  labels.data[5] = 9;
  expect_error([&] { write_labels(dir / "l.nrrd", labels); }, {"l.nrrd", "label value 9"});
}

}  // namespace
}  // namespace brainshift::imaging
