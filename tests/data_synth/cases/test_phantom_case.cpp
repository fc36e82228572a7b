#include "core/error.hpp"
#include "data_synth/cases/case_outputs.hpp"
#include "data_synth/cases/phantom_case.hpp"
#include "imaging/io/image_io.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

namespace brainshift::data_synth {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& tag) {
  std::random_device rd;
  return fs::temp_directory_path() / ("bs_phantom_" + tag + "_" + std::to_string(rd()));
}

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

/// Trilinear sample of component c at world point p (voxel centres at integer indices).
double sample(const imaging::VolumeF& v, const Vector3d& p, int c = 0) {
  const Vector3d q = v.geometry.world_to_index(p);
  const Eigen::Vector3i i0 = q.array().floor().cast<int>();
  const Vector3d f = q - i0.cast<double>();
  double s = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3i o((corner & 1) != 0, (corner & 2) != 0, (corner & 4) != 0);
    const Eigen::Vector3i i = i0 + o;
    if (!v.geometry.contains_index(i[0], i[1], i[2])) continue;
    double w = 1.0;
    for (int d = 0; d < 3; ++d) w *= o[d] ? f[d] : 1.0 - f[d];
    s += w * v.at(i[0], i[1], i[2], c);
  }
  return s;
}

void check_WritesEveryListedFile(const fs::path& dir, [[maybe_unused]] const CaseSummary& summary) {
  for (const char* f :
       {"case.json", "preop/mri.nii.gz", "preop/labels.nii.gz", "preop/mra.nii.gz",
        "preop/vessels.vtp", "intraop/doppler.nii.gz", "intraop/bmode.nii.gz",
        "truth/landmarks_preop.csv", "truth/landmarks_intraop.csv", "truth/displacement.nii.gz",
        "truth/ventricles_preop.vtp", "truth/ventricles_intraop.vtp"})
    EXPECT_TRUE(fs::is_regular_file(dir / f)) << f;
  for (const auto& e : fs::directory_iterator(dir.parent_path()))
    EXPECT_EQ(e.path().filename().string().find(dir.filename().string() + ".tmp-"),
              std::string::npos)
        << "temporary folder left behind: " << e.path();
}

void check_CaseJsonHasACorticalShiftOf5To25Mm(const fs::path& dir,
                                              [[maybe_unused]] const CaseSummary& summary) {
  const nlohmann::json j = read_json(dir / "case.json");
  EXPECT_EQ(j["name"], "standard");
  EXPECT_EQ(j["seed"], 1);
  const double shift = j["stats"]["max_cortical_shift_mm"];
  EXPECT_GE(shift, 5.0);
  EXPECT_LE(shift, 25.0);
  EXPECT_GT(j["stats"]["mean_landmark_shift_mm"].get<double>(), 0.5);
  EXPECT_EQ(j["truth_solver"]["status"], "converged");
  EXPECT_GE(summary.vessel_landmarks, 3) << "bifurcations in the field of view";
  ::testing::Test::RecordProperty("max_cortical_shift_mm", std::to_string(shift));
  ::testing::Test::RecordProperty("seconds", std::to_string(summary.seconds));
}

void check_BifurcationLandmarksLieOnBrightMraVoxels(const fs::path& dir,
                                                    [[maybe_unused]] const CaseSummary& summary) {
  const imaging::VolumeF mra = imaging::read_volume(dir / "preop/mra.nii.gz");
  const std::vector<Vector3d> pre = read_landmarks_csv(dir / "truth/landmarks_preop.csv");
  ASSERT_GE(pre.size(), std::size_t(summary.vessel_landmarks));
  for (index_t i = 0; i < summary.vessel_landmarks; ++i) {
    const Vector3d ijk = mra.geometry.world_to_index(pre[std::size_t(i)]);
    const Eigen::Vector3i n = ijk.array().round().cast<int>();
    ASSERT_TRUE(mra.geometry.contains_index(n[0], n[1], n[2]));
    // Tissue is 40 ± 8 (noise); the thinnest vessel peaks at 250: 150 separates them.
    EXPECT_GT(mra.at(n[0], n[1], n[2]), 150.0F)
        << "landmark " << i << " at voxel " << n.transpose();
  }
}

void check_DisplacementImageAtPreopLandmarksMatchesTheLandmarkShift(
    const fs::path& dir, [[maybe_unused]] const CaseSummary& summary) {
  const imaging::VolumeF u = imaging::read_volume(dir / "truth/displacement.nii.gz");
  ASSERT_EQ(u.components, 3);
  const std::vector<Vector3d> pre = read_landmarks_csv(dir / "truth/landmarks_preop.csv");
  const std::vector<Vector3d> intra = read_landmarks_csv(dir / "truth/landmarks_intraop.csv");
  ASSERT_EQ(pre.size(), intra.size());
  // Trilinear sampling of a piecewise-linear field on a 1 mm grid: the error is bounded by the
  // field's second variation over a voxel (gradients ≲ 0.3 near the cortex) ⇒ 0.3 mm.
  constexpr double interpolation_tolerance = 0.3;  // mm
  for (std::size_t k = 0; k < pre.size(); ++k) {
    const Vector3d sampled(sample(u, pre[k], 0), sample(u, pre[k], 1), sample(u, pre[k], 2));
    EXPECT_LT((sampled - (intra[k] - pre[k])).norm(), interpolation_tolerance) << "landmark " << k;
  }
}

void check_DopplerHasSignalOnlyInsideTheFieldOfView(const fs::path& dir,
                                                    [[maybe_unused]] const CaseSummary& summary) {
  const imaging::VolumeF doppler = imaging::read_volume(dir / "intraop/doppler.nii.gz");
  const nlohmann::json j = read_json(dir / "case.json");
  const auto v3 = [](const nlohmann::json& a) { return Vector3d(a[0], a[1], a[2]); };
  ProbeOptions po;
  po.half_angle_deg = j["parameters"]["probe"]["half_angle_deg"];
  po.depth = j["parameters"]["probe"]["depth_mm"];
  po.footprint_radius = j["parameters"]["probe"]["footprint_radius_mm"];
  po.spacing = j["parameters"]["probe"]["spacing_mm"];
  // The first voxel layer lies on the probe face; float headers put it ~1e-6 mm either side, so
  // the cone is grown by a hundredth of a millimetre (far below a voxel).
  constexpr double header_slack = 0.01;  // mm
  po.depth += 2.0 * header_slack;
  po.footprint_radius += header_slack;
  const Vector3d axis = v3(j["probe"]["axis"]);
  const Probe probe =
      make_probe(v3(j["probe"]["face_centre_mm"]) - header_slack * axis.normalized(), axis, po);
  index_t inside_signal = 0, outside_signal = 0;
  const imaging::ImageGeometry& g = doppler.geometry;
  for (int k = 0; k < g.size[2]; ++k)
    for (int jj = 0; jj < g.size[1]; ++jj)
      for (int i = 0; i < g.size[0]; ++i) {
        if (doppler.at(i, jj, k) <= 0.0F) continue;
        if (probe.in_field_of_view(g.index_to_world(Vector3d(i, jj, k))))
          ++inside_signal;
        else
          ++outside_signal;
      }
  EXPECT_GT(inside_signal, 1000);
  EXPECT_EQ(outside_signal, 0) << "signal outside the cone";
  // Vessel bifurcations in the field of view carry flow in the intra-operative Doppler (unless
  // dropped out): most of them are bright.
  const std::vector<Vector3d> intra = read_landmarks_csv(dir / "truth/landmarks_intraop.csv");
  int bright = 0;
  for (index_t i = 0; i < summary.vessel_landmarks; ++i)
    bright += sample(doppler, intra[std::size_t(i)]) > 60.0;
  EXPECT_GE(bright, summary.vessel_landmarks / 2);
}

// One generation of the standard case (≈ 10 s) serves all its checks: CTest runs each TEST in
// its own process, so a shared fixture would regenerate it per test.
TEST(PhantomCase, StandardCaseWritesConsistentImagesLandmarksAndTruth) {
  const fs::path dir = fresh_dir("standard");
  CaseOptions o;
  o.out = dir;
  const CaseSummary summary = generate_case("standard", 1, o);
  {
    SCOPED_TRACE("WritesEveryListedFile");
    check_WritesEveryListedFile(dir, summary);
  }
  {
    SCOPED_TRACE("CaseJsonHasACorticalShiftOf5To25Mm");
    check_CaseJsonHasACorticalShiftOf5To25Mm(dir, summary);
  }
  {
    SCOPED_TRACE("BifurcationLandmarksLieOnBrightMraVoxels");
    check_BifurcationLandmarksLieOnBrightMraVoxels(dir, summary);
  }
  {
    SCOPED_TRACE("DisplacementImageAtPreopLandmarksMatchesTheLandmarkShift");
    check_DisplacementImageAtPreopLandmarksMatchesTheLandmarkShift(dir, summary);
  }
  {
    SCOPED_TRACE("DopplerHasSignalOnlyInsideTheFieldOfView");
    check_DopplerHasSignalOnlyInsideTheFieldOfView(dir, summary);
  }
  std::error_code ignored;
  fs::remove_all(dir, ignored);
}

TEST(PhantomCase, UnknownNameIsAnErrorListingTheValidNames) {
  CaseOptions o;
  o.out = fresh_dir("unknown");
  try {
    (void)generate_case("no_such_case", 1, o);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("no_such_case"), std::string::npos) << m;
    EXPECT_NE(m.find("large_shift"), std::string::npos) << m;
  }
  EXPECT_FALSE(fs::exists(o.out));
}

TEST(PhantomCase, LargeShiftCaseShiftsTheCortexByAtLeast20Mm) {
  CaseOptions o;
  o.out = fresh_dir("large");
  const CaseSummary s = generate_case("large_shift", 1, o);
  fs::remove_all(o.out);
  EXPECT_EQ(s.solver_status, TledStatus::CONVERGED) << s.solver_message;
  EXPECT_GE(s.stats.max_cortical_shift, 20.0);
  RecordProperty("max_cortical_shift_mm", std::to_string(s.stats.max_cortical_shift));
}

}  // namespace
}  // namespace brainshift::data_synth
