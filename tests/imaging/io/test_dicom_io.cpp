// DICOM series written by brainshift (GDCM) and read back by DCMTK's dcmdump, an independent
// implementation, and by our reader (issue 35: "reads back with the geometry of the NIfTI within
// 1e-4 mm").
#include "expect_error.hpp"
#include "temp_folder.hpp"
#include "tests/imaging/io/oblique_grid.hpp"

#include "imaging/io/dicom_io.hpp"
#include "imaging/io/image_io.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace brainshift::imaging {
namespace {

namespace fs = std::filesystem;
using tests::expect_error;

/// Geometry agreement required (issue 35): 1e-4 mm. Our decimal strings keep ≥ 10 significant
/// digits (≤ 16 characters), so ~1e-8 mm on coordinates ≲ 1000 mm.
constexpr double geometry_tolerance = 1e-4;

using test_grids::oblique_geometry;

VolumeF random_volume(const ImageGeometry& g, bool integral, unsigned seed = 1) {
  VolumeF v(g, 1);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-100.0f, 100.0f);
  std::uniform_int_distribution<int> n(-1000, 3000);
  for (float& x : v.data) x = integral ? float(n(rng)) : u(rng);
  return v;
}

std::vector<fs::path> files_in(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

/// dcmdump's value of each element of `file`, by "gggg,eeee" (text between the brackets).
std::map<std::string, std::string> dcmdump(const fs::path& file) {
  // -Un: UIDs as numbers, not DCMTK's names for the well-known ones; +L: long values whole.
  const std::string command = "dcmdump -q -Un +L '" + file.string() + "' 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  EXPECT_NE(pipe, nullptr) << command;
  std::map<std::string, std::string> out;
  if (!pipe) return out;
  std::string all;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe)) all += buffer;
  EXPECT_EQ(pclose(pipe), 0) << "dcmdump (DCMTK; scripts/install_deps.sh installs it) failed:\n"
                             << all;
  // Strings are printed in brackets, binary numbers (US) bare.
  const std::regex line(R"(\(([0-9a-f]{4},[0-9a-f]{4})\) [A-Z]{2} (\[([^\]]*)\]|([^ \[]\S*)))");
  for (std::sregex_iterator it(all.begin(), all.end(), line), end; it != end; ++it)
    out[(*it)[1]] = (*it)[3].matched ? (*it)[3].str() : (*it)[4].str();
  return out;
}

std::vector<double> numbers(const std::string& text) {
  std::vector<double> v;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, '\\');) v.push_back(std::stod(item));
  return v;
}

Vector3d lps(const Vector3d& ras) { return {-ras[0], -ras[1], ras[2]}; }

TEST(DicomSeries, DcmdumpReadsTheGeometryOfTheVolume) {
  const tests::TempFolder dir;
  const ImageGeometry g = oblique_geometry();
  write_dicom_series(dir.path(), random_volume(g, false), {}, corrected_series_description);
  const std::vector<fs::path> files = files_in(dir.path());
  ASSERT_EQ(files.size(), 4u) << "one file per slice";
  std::vector<std::string> series;
  for (const fs::path& f : files) {
    SCOPED_TRACE(f.string());
    auto e = dcmdump(f);
    EXPECT_EQ(e["0008,0016"], "1.2.840.10008.5.1.4.1.1.4") << "MR Image Storage";
    EXPECT_EQ(e["0008,0060"], "MR");
    EXPECT_EQ(e["0008,103e"], corrected_series_description);
    EXPECT_EQ(e["0008,0008"], "DERIVED\\SECONDARY");
    EXPECT_EQ(e["0002,0010"], "1.2.840.10008.1.2.1") << "explicit VR little endian";
    series.push_back(e["0020,000e"]);
    const int k = std::stoi(e["0020,0013"]) - 1;
    ASSERT_GE(k, 0);
    ASSERT_LT(k, 4);
    // The centre of the slice's first pixel, and its row and column directions, in LPS.
    const std::vector<double> ipp = numbers(e["0020,0032"]);
    const std::vector<double> iop = numbers(e["0020,0037"]);
    const std::vector<double> spacing = numbers(e["0028,0030"]);
    ASSERT_EQ(ipp.size(), 3u);
    ASSERT_EQ(iop.size(), 6u);
    ASSERT_EQ(spacing.size(), 2u);
    const Vector3d want = lps(g.index_to_world(Vector3d(0, 0, k)));
    EXPECT_LT((Vector3d(ipp[0], ipp[1], ipp[2]) - want).norm(), geometry_tolerance);
    const Vector3d row = lps(g.direction.col(0)), col = lps(g.direction.col(1));
    EXPECT_LT((Vector3d(iop[0], iop[1], iop[2]) - row).norm(), 1e-6);
    EXPECT_LT((Vector3d(iop[3], iop[4], iop[5]) - col).norm(), 1e-6);
    EXPECT_NEAR(spacing[0], g.spacing[1], 1e-9) << "between rows first";
    EXPECT_NEAR(spacing[1], g.spacing[0], 1e-9);
    EXPECT_EQ(e["0028,0010"], "5") << "rows";
    EXPECT_EQ(e["0028,0011"], "7") << "columns";
  }
  EXPECT_EQ(std::count(series.begin(), series.end(), series.front()), 4) << "one series";
}

TEST(DicomSeries, ReadsBackTheVolumeWithinHalfAStoredStep) {
  const tests::TempFolder dir;
  const VolumeF v = random_volume(oblique_geometry(), false);
  write_dicom_series(dir.path(), v, {}, corrected_series_description);
  for (const fs::path& p : {dir.path(), files_in(dir.path())[2]}) {
    SCOPED_TRACE(p.string());
    const VolumeF r = read_volume(p);  // a folder or one file of the series
    ASSERT_EQ(r.geometry.size, v.geometry.size);
    for (const Vector3d& ijk : {Vector3d(0, 0, 0), Vector3d(6, 0, 0), Vector3d(0, 4, 0),
                                Vector3d(0, 0, 3), Vector3d(6, 4, 3)})
      EXPECT_LT((r.geometry.index_to_world(ijk) - v.geometry.index_to_world(ijk)).norm(),
                geometry_tolerance);
    // Values span [-100, 100] in 65535 steps: each within half a step (+ float rounding).
    const double half_step = 0.5 * 200.0 / 65535.0 + 1e-4;
    double worst = 0;
    for (std::size_t i = 0; i < v.data.size(); ++i)
      worst = std::max(worst, std::abs(double(r.data[i]) - double(v.data[i])));
    EXPECT_LE(worst, half_step);
  }
}

TEST(DicomSeries, IntegerValuesAreExactAndALeftHandedGridKeepsItsWorldPositions) {
  const tests::TempFolder dir;
  const VolumeF v = random_volume(oblique_geometry(/*left_handed=*/true), true);
  write_dicom_series(dir.path(), v, {}, "test");
  const VolumeF r = read_dicom_series(dir.path());
  // The reader orders slices along row × column, the reverse of this grid's k: compare by world
  // position, voxel by voxel.
  int wrong = 0;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 7; ++i) {
        const Vector3d at = r.geometry.world_to_index(v.geometry.index_to_world(Vector3d(i, j, k)));
        const Eigen::Vector3i n = at.array().round().cast<int>();
        if ((at - n.cast<double>()).norm() > 1e-6 || r.at(n[0], n[1], n[2]) != v.at(i, j, k))
          ++wrong;
      }
  EXPECT_EQ(wrong, 0);
}

TEST(DicomSeries, KeepsPatientStudyAndFrameWithANewSeries) {
  const tests::TempFolder dir;
  DicomSeriesInfo source;
  source.patient_name = "Doe^Jane";
  source.patient_id = "RESECT-07";
  source.patient_sex = "F";
  source.study_instance_uid = "1.2.826.0.1.3680043.2.1125.1.1";
  source.study_date = "20261203";
  source.frame_of_reference_uid = "1.2.826.0.1.3680043.2.1125.1.2";
  source.series_instance_uid = "1.2.826.0.1.3680043.2.1125.1.3";
  source.series_number = 7;
  write_dicom_series(dir.path(), random_volume(oblique_geometry(), true), source,
                     corrected_series_description);
  DicomSeriesInfo read;
  (void)read_dicom_series(dir.path(), &read);
  EXPECT_EQ(read.patient_name, source.patient_name);
  EXPECT_EQ(read.patient_id, source.patient_id);
  EXPECT_EQ(read.patient_sex, source.patient_sex);
  EXPECT_EQ(read.study_instance_uid, source.study_instance_uid);
  EXPECT_EQ(read.study_date, source.study_date);
  EXPECT_EQ(read.frame_of_reference_uid, source.frame_of_reference_uid);
  EXPECT_NE(read.series_instance_uid, source.series_instance_uid) << "a new series";
  EXPECT_FALSE(read.series_instance_uid.empty());
  EXPECT_EQ(read.series_number, 1007);
  EXPECT_EQ(read.series_description, corrected_series_description);
  EXPECT_EQ(read.modality, "MR");
}

TEST(DicomSeries, SlicesAreOrderedByPositionNotByName) {
  const tests::TempFolder dir;
  const VolumeF v = random_volume(oblique_geometry(), true);
  write_dicom_series(dir.path(), v, {}, "test");
  const std::vector<fs::path> files = files_in(dir.path());
  // Reverse the names: IMG0001 <-> IMG0004, IMG0002 <-> IMG0003.
  for (std::size_t a = 0; a < 2; ++a) {
    const fs::path& x = files[a];
    const fs::path& y = files[3 - a];
    fs::rename(x, dir.path() / "swap");
    fs::rename(y, x);
    fs::rename(dir.path() / "swap", y);
  }
  const VolumeF r = read_dicom_series(dir.path());
  ASSERT_EQ(r.data.size(), v.data.size());
  EXPECT_TRUE(r.data == v.data);
  EXPECT_LT((r.geometry.origin - v.geometry.origin).norm(), geometry_tolerance);
}

TEST(DicomSeries, BadSeriesGiveOneLineNamingThePath) {
  const tests::TempFolder dir;
  fs::create_directories(dir / "empty");
  expect_error([&] { read_volume(dir / "empty"); }, {"empty", "no DICOM file"});
  { std::ofstream(dir / "notes.dcm") << "not a DICOM file\n"; }
  expect_error([&] { read_volume(dir / "notes.dcm"); }, {"notes.dcm", "DICOM"});

  const VolumeF v = random_volume(oblique_geometry(), true);
  fs::create_directories(dir / "gap");
  write_dicom_series(dir / "gap", v, {}, "test");
  fs::remove(dir / "gap" / "IMG0002.dcm");
  expect_error([&] { read_volume(dir / "gap"); }, {"gap", "unevenly spaced"});

  fs::create_directories(dir / "two");
  write_dicom_series(dir / "two", v, {}, "test");
  fs::create_directories(dir / "other");
  write_dicom_series(dir / "other", v, {}, "test");
  fs::copy_file(dir / "other" / "IMG0001.dcm", dir / "two" / "X0001.dcm");
  expect_error([&] { read_volume(dir / "two"); }, {"two", "2 DICOM series"});
  // One file picks its series out of the folder.
  EXPECT_EQ(read_volume(dir / "two" / "IMG0003.dcm").geometry.size[2], 4);

  fs::create_directories(dir / "vector");
  expect_error(
      [&] { write_dicom_series(dir / "vector", VolumeF(oblique_geometry(), 3), {}, "test"); },
      {"vector", "one component"});
  expect_error([&] { write_dicom_series(dir / "vector", v, {}, std::string(65, 'x')); },
               {"vector", "64 characters"});
  EXPECT_TRUE(fs::is_empty(dir / "vector"));
}

}  // namespace
}  // namespace brainshift::imaging
