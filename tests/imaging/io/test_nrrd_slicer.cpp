// NRRD volumes as 3D Slicer writes them for its command-line modules (the storage nodes: teem's
// header with comment lines, `space: left-posterior-superior`, oblique `space directions`, gzip
// data, key:=value pairs, short voxels for label maps) read into world RAS.

#include "expect_error.hpp"
#include "temp_folder.hpp"

#include "imaging/io/image_io.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>
#include <zlib.h>

namespace brainshift::imaging {
namespace {

std::string gzip(const std::string& raw) {
  z_stream z{};
  EXPECT_EQ(deflateInit2(&z, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::string out(deflateBound(&z, uLong(raw.size())) + 64, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(raw.data()));
  z.avail_in = uInt(raw.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = uInt(out.size());
  EXPECT_EQ(deflate(&z, Z_FINISH), Z_STREAM_END);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

TEST(NrrdFromSlicer, AGzipShortLabelMapInObliqueLpsReadsIntoRasWithItsLabels) {
  const tests::TempFolder dir;
  // 2 × 3 × 2 voxels, labels 0…3 (short, as Slicer stores label maps).
  std::vector<std::int16_t> labels = {0, 1, 2, 3, 1, 1, 0, 2, 2, 3, 3, 0};
  const std::string raw(reinterpret_cast<const char*>(labels.data()),
                        labels.size() * sizeof(std::int16_t));
  // Oblique axes (i along −P, j along L: a 90° turn about S, as after hardening a transform in
  // Slicer) with anisotropic spacing.
  const std::string header =
      "NRRD0004\n"
      "# Complete NRRD file format specification at:\n"
      "# http://teem.sourceforge.net/nrrd/format.html\n"
      "type: short\n"
      "dimension: 3\n"
      "space: left-posterior-superior\n"
      "sizes: 2 3 2\n"
      "space directions: (0,-0.5,0) (0.75,0,0) (0,0,1.2)\n"
      "kinds: domain domain domain\n"
      "endian: little\n"
      "encoding: gzip\n"
      "space units: \"mm\" \"mm\" \"mm\"\n"
      "space origin: (60,80,-30)\n"
      "ITK_InputFilterName:=NrrdImageIO\n"
      "\n";
  {
    std::ofstream out(dir / "labels.nrrd", std::ios::binary);
    out << header << gzip(raw);
  }
  const LabelVolume v = read_labels(dir / "labels.nrrd");
  ASSERT_EQ(v.geometry.size, Eigen::Vector3i(2, 3, 2));
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 2; ++i)
        EXPECT_EQ(int(v.at(i, j, k)), labels[std::size_t((k * 3 + j) * 2 + i)]);
  // Voxel (i, j, k) lies at LPS (60, 80, −30) + i (0, −0.5, 0) + j (0.75, 0, 0) + k (0, 0, 1.2);
  // RAS negates the first two coordinates. Exact up to rounding of the parsed decimals.
  constexpr double TOL = 1e-12;
  EXPECT_LT((v.geometry.index_to_world({0, 0, 0}) - Vector3d(-60, -80, -30)).norm(), TOL);
  EXPECT_LT((v.geometry.index_to_world({1, 0, 0}) - Vector3d(-60, -79.5, -30)).norm(), TOL);
  EXPECT_LT((v.geometry.index_to_world({0, 2, 1}) - Vector3d(-61.5, -80, -28.8)).norm(), TOL);
}

TEST(NrrdFromSlicer, VectorsInAMeasurementFrameAreTakenToWorldRas) {
  const tests::TempFolder dir;
  // One voxel, vector (1, 2, 3) in a measurement frame whose axes are the LPS space's
  // (y, −x, z) — a 90° turn about S (columns given one per parenthesis, as the NRRD format
  // says). In LPS the vector is M v = (−2, 1, 3); in RAS (2, −1, 3). Written by hand here,
  // not by our writer.
  const std::vector<float> v = {1.0f, 2.0f, 3.0f};
  const std::string header =
      "NRRD0004\n"
      "type: float\n"
      "dimension: 4\n"
      "space: left-posterior-superior\n"
      "sizes: 3 1 1 1\n"
      "space directions: none (1,0,0) (0,1,0) (0,0,1)\n"
      "kinds: vector domain domain domain\n"
      "endian: little\n"
      "encoding: raw\n"
      "space origin: (0,0,0)\n"
      "measurement frame: (0,1,0) (-1,0,0) (0,0,1)\n"
      "intent_code:=1006\n"
      "\n";
  {
    std::ofstream out(dir / "u.nrrd", std::ios::binary);
    out << header;
    out.write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(float)));
  }
  const VolumeF u = read_volume(dir / "u.nrrd");
  ASSERT_EQ(u.components, 3);
  // Exact: a permutation with signs of small integers.
  EXPECT_EQ(u.data[0], 2.0f);
  EXPECT_EQ(u.data[1], -1.0f);
  EXPECT_EQ(u.data[2], 3.0f);

  // A singular frame is a one-line error naming the file.
  {
    std::string bad = header;
    bad.replace(bad.find("(0,1,0) (-1,0,0)"), 16, "(0,1,0) (0,2,0)");
    std::ofstream out(dir / "singular.nrrd", std::ios::binary);
    out << bad;
    out.write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(float)));
  }
  tests::expect_error([&] { read_volume(dir / "singular.nrrd"); },
                      {"singular.nrrd", "measurement frame"});
}

TEST(NrrdFromSlicer, AHeaderClaimingAHugeOrEmptyComponentAxisIsOneLineNamingTheFile) {
  // Damaged headers are refused before any allocation: a component axis of 10^12 (its int
  // conversion used to wrap), one of 0, and three sizes whose product is 2^45 voxels.
  const tests::TempFolder dir;
  auto write = [&](const std::string& name, const std::string& dim, const std::string& sizes) {
    std::ofstream out(dir / name, std::ios::binary);
    out << "NRRD0004\ntype: float\ndimension: " << dim << "\nsizes: " << sizes
        << "\nencoding: raw\nendian: little\n\n"
        << std::string(64, '\0');
    return dir / name;
  };
  tests::expect_error(
      [&] { (void)read_volume(write("huge_axis.nrrd", "4", "1000000000000 2 2 2")); },
      {"huge_axis.nrrd", "component axis"});
  tests::expect_error([&] { (void)read_volume(write("zero_axis.nrrd", "4", "0 2 2 2")); },
                      {"zero_axis.nrrd", "component axis"});
  tests::expect_error([&] { (void)read_volume(write("huge.nrrd", "3", "32768 32768 32768")); },
                      {"huge.nrrd", "elements"});
}

}  // namespace
}  // namespace brainshift::imaging
