// The global start against real navigation offsets (issue 14 item 2: "recovering real
// offsets"). RESECT (../shared/data/resect/landmarks, 22 patients) gives, per patient, 15-16
// expert landmark pairs between the pre-operative MRI and the ultrasound acquired on the dura
// before it was opened: the navigation offset of a real surgery, mostly rigid. Each patient's
// rigid part (least-squares rotation and translation of the pairs, Eigen::umeyama) is applied
// to a cortical vessel tree seen by a sweep, and the global start must undo it.
//
// What the pairs say: rotations of 1.5-13.8° (median 5.3°) and mean shift vectors of
// 0.7-19.7 mm (RESECT's summary: mean distances of 1.1-19.7 mm). The
// rotation is an estimate from 15 landmarks over a field 13-27 mm across (RMS distance from
// their centroid), so ≈ 1-3° of it is the experts' localisation error; it is applied as found,
// which errs on the large side. Label `real`; skips when the folder is absent.
#include "tests/config.hpp"
#include "tests/constraints/registration/vessel_trees.hpp"

#include "constraints/registration/start/global_start.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace brainshift::constraints {
namespace {

using namespace test_trees;  // NOLINT(google-build-using-namespace): the shared helpers

std::filesystem::path landmark_dir() {
  return std::filesystem::path(tests::shared_data_dir) / "resect" / "landmarks";
}

/// The pairs of an MNI tag file with two volumes: after "Points =", one pair per line,
/// `x1 y1 z1 x2 y2 z2` (mm, RAS), optionally followed by weight, ids and a label; ';' ends it.
/// Returns the two 3×N point sets (MRI, ultrasound); empty on a malformed file.
std::pair<Eigen::Matrix3Xd, Eigen::Matrix3Xd> read_tag_pairs(const std::filesystem::path& f) {
  std::ifstream in(f);
  std::stringstream all;
  all << in.rdbuf();
  const std::string text = all.str();
  const auto at = text.find("Points =");
  if (at == std::string::npos) return {};
  std::vector<Vector3d> a, b;
  std::istringstream lines(text.substr(at + 8));
  std::string line;
  while (std::getline(lines, line)) {
    std::istringstream ls(line);
    double v[6];
    int n = 0;
    while (n < 6 && ls >> v[n]) ++n;
    if (n < 6) continue;  // blank line, or the closing ';'
    a.emplace_back(v[0], v[1], v[2]);
    b.emplace_back(v[3], v[4], v[5]);
  }
  Eigen::Matrix3Xd A(3, static_cast<Eigen::Index>(a.size())), B(3, A.cols());
  for (std::size_t i = 0; i < a.size(); ++i) {
    A.col(static_cast<Eigen::Index>(i)) = a[i];
    B.col(static_cast<Eigen::Index>(i)) = b[i];
  }
  return {A, B};
}

TEST(GlobalStartResect, RecoversTheNavigationOffsetsOfTwentyTwoRealSurgeries) {
  if (!std::filesystem::is_directory(landmark_dir()))
    GTEST_SKIP() << "no real data: " << landmark_dir().string() << " is absent";
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(landmark_dir()))
    if (e.path().extension() == ".tag") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  ASSERT_EQ(files.size(), 22U) << "RESECT has 22 landmark files";

  // The sweep: the vessels of a cortical tree within 20 mm of the probe's spot (a 40 mm wide
  // field, as the phantoms' sweeps), sampled every mm with 0.5 mm scatter per axis (a Doppler
  // centreline's, docs/history/BENCHMARKS_NOTEBOOK.md v4: 0.5-0.9 mm RMS away from the sector's
  // side).
  const core::Skeleton tree = cortical_tree(4);
  const MatrixX3d all = sample(tree, 1.0, 0.5, 21);
  Eigen::Index top = 0;
  all.col(2).maxCoeff(&top);
  std::vector<Eigen::Index> near;
  for (Eigen::Index i = 0; i < all.rows(); ++i)
    if ((all.row(i) - all.row(top)).norm() < 20.0) near.push_back(i);
  // Every 4th of them: ≈ 70 points, as many as the phantoms' Doppler sweeps give (48-87).
  MatrixX3d pts(static_cast<Eigen::Index>((near.size() + 3) / 4), 3);
  for (std::size_t k = 0; k < near.size(); k += 4)
    pts.row(static_cast<Eigen::Index>(k / 4)) = all.row(near[k]);
  ASSERT_GE(pts.rows(), 50) << "the sweep sees too few vessel points to be a fair test";
  std::printf("sweep: %td vessel points within 20 mm of the probe\n", pts.rows());
  const Vector3d c = pts.colwise().mean().transpose();
  // Tolerance: 1 mm at every point. The pose's scatter from ≈ 70 points with 0.5 mm noise over
  // a 40 mm field is ≈ 0.5 / √(70/6) · 2 ≈ 0.3 mm at its edge; a wrong basin or an unrecovered
  // rotation is off by millimetres (the offsets' rotations are 1.5-14°, 1° at 20 mm ≈ 0.35 mm).
  constexpr double kTolMm = 1.0;
  int recovered = 0;
  double worst = 0.0, worst_angle = 0.0;
  for (const auto& f : files) {
    const auto [mri, us] = read_tag_pairs(f);
    ASSERT_GE(mri.cols(), 10) << f.string() << ": fewer than 10 landmark pairs read";
    // The patient's offset, MRI → ultrasound: rotation about the landmarks' centroid and the
    // mean shift, placed at the sweep's centroid.
    const Eigen::Matrix4d T = Eigen::umeyama(mri, us, false);
    const Matrix3d R = T.topLeftCorner<3, 3>();
    const Vector3d shift = (us - mri).rowwise().mean();
    Eigen::Isometry3d O = Eigen::Isometry3d::Identity();
    O.linear() = R;
    O.translation() = c + shift - R * c;
    const double angle = Eigen::AngleAxisd(R).angle() / deg;
    const MatrixX3d intra = apply(O, pts);
    const StartResult r = global_start(tree, intra, {}, GlobalStartOptions{});
    const double err = max_error(r.transform, O.inverse(), intra);  // the identity if refused
    std::printf("%-28s shift %5.1f mm, rotation %5.2f deg: %s, error %.2f mm; %s\n",
                f.filename().string().c_str(), shift.norm(), angle,
                err < kTolMm ? "recovered" : "NOT recovered", err, r.message.c_str());
    EXPECT_TRUE(r.transform.matrix().allFinite()) << f.string();
    EXPECT_LT(err, kTolMm) << f.filename().string() << ": shift " << shift.norm()
                           << " mm, rotation " << angle << " deg; " << r.message;
    // A recovered real offset is not flagged as ambiguous (no false alarm on the 22 patients).
    if (err < kTolMm) {
      EXPECT_FALSE(r.ambiguous) << f.filename().string() << ": " << r.ambiguity;
    }
    // Under the prior of the navigation's accuracy measured on these very offsets
    // (kResectNavigationAccuracyMm, rotation σ from the 52 mm lever) every offset is still
    // recovered: the prior shrinks a pose only where the sweep's data leave it open. A tighter
    // rotation prior (4 mm over 75 mm, ≈ 3° RMS) lost Case2, 3, 13 and 25 (9–14°) by 1–2.6 mm.
    GlobalStartOptions with_prior;
    with_prior.navigation_accuracy_mm = kResectNavigationAccuracyMm;
    const StartResult p = global_start(tree, intra, {}, with_prior);
    EXPECT_LT(max_error(p.transform, O.inverse(), intra), kTolMm)
        << f.filename().string() << " with the navigation prior: " << p.message;
    recovered += err < kTolMm ? 1 : 0;
    if (err > worst) {
      worst = err;
      worst_angle = angle;
    }
  }
  std::printf("recovered %d of %zu real offsets; worst %.2f mm (rotation %.1f deg)\n", recovered,
              files.size(), worst, worst_angle);
}

}  // namespace
}  // namespace brainshift::constraints
