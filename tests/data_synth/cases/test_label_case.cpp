// A whole case on a label volume (issue 18): the analytic phantom rasterised (2 mm voxels) and
// written to a NIfTI file must give the same kind of phantom as the analytic `standard` case —
// every file of the layout, a converged truth solve, a shift of the same size, landmarks — and a
// refused request must leave nothing behind.

#include "core/error.hpp"
#include "data_synth/cases/label_case.hpp"
#include "imaging/io/image_io.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <random>

namespace brainshift::data_synth {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& tag) {
  std::random_device rd;
  return fs::temp_directory_path() / ("bs_label_case_" + tag + "_" + std::to_string(rd()));
}

struct Folder {
  fs::path path;
  explicit Folder(const std::string& tag) : path(fresh_dir(tag)) { fs::create_directories(path); }
  ~Folder() {
    std::error_code ignored;
    fs::remove_all(path, ignored);
  }
};

TEST(LabelCase, EllipsoidLabelsGiveTheSameKindOfPhantomAsTheAnalyticOne) {
  const Folder tmp("ellipsoid");
  PhantomImageOptions io;
  io.spacing = 2.0;
  const fs::path labels = tmp.path / "labels.nii.gz";
  imaging::write_labels(labels, make_label_volume(PhantomGeometry{}, io));

  LabelCaseRequest r;
  r.labels = labels;
  r.case_name = "standard";
  CaseOptions o;
  o.out = tmp.path / "case";
  const CaseSummary s = generate_label_case(r, o);
  EXPECT_EQ(s.solver_status, TledStatus::CONVERGED) << s.solver_message;
  for (const char* f :
       {"case.json", "preop/mri.nii.gz", "preop/labels.nii.gz", "preop/mra.nii.gz",
        "preop/vessels.vtp", "intraop/doppler.nii.gz", "intraop/bmode.nii.gz",
        "truth/displacement.nii.gz", "truth/landmarks_preop.csv", "truth/landmarks_intraop.csv",
        "truth/ventricles_preop.vtp", "truth/ventricles_intraop.vtp"})
    EXPECT_TRUE(fs::is_regular_file(o.out / f)) << f;
  // The analytic standard case shifts its landmarks by 7.2 mm on average (max cortical 10 mm).
  // The label version has the same brain, load and tumour but a fixed base of 10 mm instead of
  // the flat cut and a skull from the voxels: the same kind of sag, 3-20 mm.
  EXPECT_GT(s.stats.mean_landmark_shift, 3.0);
  EXPECT_LT(s.stats.mean_landmark_shift, 20.0);
  EXPECT_LT(s.stats.max_cortical_shift, 30.0);
  // Vessel bifurcations in the probe's view plus deep points: at least a handful, as standard.
  EXPECT_GE(s.landmarks, 6);
  EXPECT_GE(s.vessel_landmarks, 3);

  std::ifstream in(o.out / "case.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  const auto& geo = j["parameters"]["geometry"];
  EXPECT_EQ(geo["tumour_placement"], "from the labels");          // the phantom's own 12 mm tumour
  EXPECT_NEAR(geo["tumour_radius_mm"].get<double>(), 12.0, 1.0);  // within a 2 mm voxel
  EXPECT_EQ(geo["craniotomy_placement"].get<std::string>().rfind("default", 0), 0U);
  EXPECT_EQ(j["truth_solver"]["status"], "converged");
}

TEST(LabelCase, RefusedRequestsLeaveNothingBehind) {
  const Folder tmp("refused");
  PhantomImageOptions io;
  io.spacing = 3.0;
  const fs::path labels = tmp.path / "labels.nii.gz";
  imaging::write_labels(labels, make_label_volume(PhantomGeometry{}, io));
  LabelCaseRequest r;
  r.labels = labels;
  r.tumour_centre = Vector3d(400.0, 0.0, 0.0);
  CaseOptions o;
  o.out = tmp.path / "case";
  EXPECT_THROW((void)generate_label_case(r, o), Error);
  r.tumour_centre.reset();
  r.labels = tmp.path / "missing.nii.gz";
  EXPECT_THROW((void)generate_label_case(r, o), Error);
  // Only the labels file: no case folder, no temporary sibling.
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(tmp.path)) ++entries;
  EXPECT_EQ(entries, 1U);
}

}  // namespace
}  // namespace brainshift::data_synth
