// The product as users meet it, driven through the real executable on a small phantom: phantom
// → prepare → register → evaluate → replay (with a broken frame in the middle), and every kind of
// bad input a new user might try. One test, because generating the phantom takes ≈ 10 s and
// CTest runs each test in its own process.

#include "cli_helpers.hpp"
#include "plus_sweep.hpp"

#include "imaging/io/csv.hpp"
#include "imaging/io/dicom_io.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/landmark_files.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace brainshift {
namespace {

nlohmann::json read_json(const std::filesystem::path& p) {
  return nlohmann::json::parse(read_all(p));
}

/// No temporary or partial folder next to `target` (the write-then-rename contract).
void expect_nothing_half_written(const std::filesystem::path& target) {
  EXPECT_FALSE(std::filesystem::exists(target)) << target;
  for (const auto& e : std::filesystem::directory_iterator(target.parent_path()))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
}

TEST(Workflow, PhantomPrepareRegisterEvaluateReplayAndBadInputs) {
  const tests::TempFolder dir;
  const auto ph = dir / "phantom", model = dir / "model", res = dir / "res";
  CliRun r = run_brainshift(dir, "phantom --case standard --seed 1 --frames 3 --out " + q(ph));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;

  // The MRI as a scanner would give it: a DICOM series (written by GDCM; read back through the
  // same path as any input volume), for prepare and register.
  const auto mri_dicom = dir / "mri_dicom";
  imaging::DicomSeriesInfo patient;
  patient.patient_name = "Phantom^Standard";
  patient.patient_id = "BS-0001";
  patient.study_instance_uid = "1.2.826.0.1.3680043.2.1125.9.1";
  patient.frame_of_reference_uid = "1.2.826.0.1.3680043.2.1125.9.2";
  std::filesystem::create_directories(mri_dicom);
  imaging::write_dicom_series(mri_dicom, imaging::read_volume(ph / "preop/mri.nii.gz"), patient,
                              "T1");
  r = run_brainshift(dir, "prepare --labels " + q(ph / "preop/labels.nii.gz") + " --mra " +
                              q(ph / "preop/mra.nii.gz") + " --mri " + q(mri_dicom) + " --out " +
                              q(model));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const char* f : {"scene.json", "model.json", "mesh.vtu", "surface.vtp", "vessels.vtp",
                        "fixed.csv", "compliance.bin"})
    EXPECT_TRUE(std::filesystem::exists(model / f)) << f;
  EXPECT_NE(r.err.find("brainshift prepare: ["), std::string::npos) << "progress lines on stderr";

  const std::string reg = "register --model " + q(model) + " --doppler " +
                          q(ph / "intraop/doppler.nii.gz") + " --mri " + q(mri_dicom);
  r = run_brainshift(dir, reg + " --out " + q(res));
  // 0 = converged, 2 = stopped without meeting the convergence test; both write the result.
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 2) << r.out << r.err;
  for (const char* f : {"report.json", "deformed.vtu", "displacement.nii.gz",
                        "preop_to_intraop.nrrd", "intraop_to_preop.nrrd", "warped_mri.nii.gz",
                        "overlay.png", "uncertainty.nii.gz", "overlay_uncertainty.png"})
    EXPECT_TRUE(std::filesystem::exists(res / f)) << f;
  {  // A PLUS sequence of tracked Doppler frames (cut from the phantom's Doppler volume, one with
     // an INVALID transform): reconstructed by `reconstruct`, and registered directly.
    const imaging::VolumeF d = imaging::read_volume(ph / "intraop/doppler.nii.gz");
    const float peak = *std::max_element(d.data.begin(), d.data.end());
    const tests::Sweep sweep = tests::cut_sweep(d, 0.5, 0.8, 80, {5}, 255.0 / double(peak));
    tests::write_plus_sequence(dir / "sweep.seq.mha", sweep, "MF", /*image_to_reference=*/true);
    CliRun e =
        run_brainshift(dir, "reconstruct --sequence " + q(dir / "sweep.seq.mha") + " --out " +
                                q(dir / "sweep.nii.gz") + " --report " + q(dir / "sweep.json"));
    ASSERT_EQ(e.exit_code, 0) << e.out << e.err;
    const auto rep = read_json(dir / "sweep.json");
    EXPECT_EQ(rep["frames"].get<int>(), 80);
    EXPECT_EQ(rep["frames_skipped"].get<int>(), 1);
    EXPECT_NEAR(rep["spacing_mm"].get<double>(), 0.5, 1e-9) << "the frames' pixel size";
    e = run_brainshift(dir, "register --model " + q(model) + " --doppler " +
                                q(dir / "sweep.seq.mha") + " --out " + q(dir / "res_seq"));
    EXPECT_TRUE(e.exit_code == 0 || e.exit_code == 2) << e.out << e.err;
    EXPECT_NE(read_json(dir / "res_seq" / "report.json").dump().find("sweep.seq.mha"),
              std::string::npos);
    // replay over a folder of sequence files: one sweep each, named by the file.
    std::filesystem::create_directories(dir / "sweeps");
    std::filesystem::copy_file(dir / "sweep.seq.mha", dir / "sweeps" / "sweep_a.seq.mha");
    e = run_brainshift(dir, "replay --model " + q(model) + " --sequence " + q(dir / "sweeps") +
                                " --uncertainty none --out " + q(dir / "replay_seq"));
    EXPECT_TRUE(e.exit_code == 0 || e.exit_code == 2) << e.out << e.err;
    EXPECT_TRUE(std::filesystem::exists(dir / "replay_seq" / "sweep_a" / "report.json"));
    // A truncated sequence: one line naming it, nothing written.
    const std::string bytes = read_all(dir / "sweep.seq.mha");
    std::ofstream(dir / "cut.seq.mha", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    expect_one_line_error(run_brainshift(dir, "reconstruct --sequence " + q(dir / "cut.seq.mha") +
                                                  " --out " + q(dir / "cut.nii.gz")),
                          "cut.seq.mha");
    EXPECT_FALSE(std::filesystem::exists(dir / "cut.nii.gz"));
  }
  {  // The warped MRI as a DICOM series of the patient's study, for a navigation system.
    const auto out = dir / "warped_dicom";
    const CliRun e = run_brainshift(dir, "export-dicom --volume " + q(res / "warped_mri.nii.gz") +
                                             " --like " + q(mri_dicom) + " --out " + q(out));
    ASSERT_EQ(e.exit_code, 0) << e.out << e.err;
    imaging::DicomSeriesInfo info;
    const imaging::VolumeF back = imaging::read_dicom_series(out, &info);
    const imaging::VolumeF warped = imaging::read_volume(res / "warped_mri.nii.gz");
    EXPECT_EQ(info.patient_name, patient.patient_name);
    EXPECT_EQ(info.patient_id, patient.patient_id);
    EXPECT_EQ(info.study_instance_uid, patient.study_instance_uid);
    EXPECT_EQ(info.frame_of_reference_uid, patient.frame_of_reference_uid);
    EXPECT_EQ(info.series_description, imaging::corrected_series_description);
    ASSERT_EQ(back.geometry.size, warped.geometry.size);
    // Geometry within 1e-4 mm (issue 35); values within half a stored step of the int16 range.
    const Vector3d far(warped.geometry.size[0] - 1, warped.geometry.size[1] - 1,
                       warped.geometry.size[2] - 1);
    for (const Vector3d& ijk : {Vector3d(0, 0, 0), far})
      EXPECT_LT((back.geometry.index_to_world(ijk) - warped.geometry.index_to_world(ijk)).norm(),
                1e-4);
    const auto [lo, hi] = std::minmax_element(warped.data.begin(), warped.data.end());
    const double half_step = 0.5 * double(*hi - *lo) / 65535.0 + 1e-3;
    double worst = 0;
    for (std::size_t i = 0; i < warped.data.size(); ++i)
      worst = std::max(worst, double(std::abs(back.data[i] - warped.data[i])));
    EXPECT_LE(worst, half_step);
    // Bad input: one line naming the file, nothing written.
    expect_one_line_error(run_brainshift(dir, "export-dicom --volume " + q(res / "deformed.vtu") +
                                                  " --out " + q(dir / "bad_dicom")),
                          "deformed.vtu");
    expect_nothing_half_written(dir / "bad_dicom");
  }
  const auto report = read_json(res / "report.json");
  for (const char* k : {"timing", "iterations", "converged", "stop_reason", "constraints", "rigid"})
    EXPECT_TRUE(report.contains(k)) << k;
  EXPECT_TRUE(report["timing"].contains("total"));
  // The noise model's decision (issue 14 item 3): kept start or deformation, on how many held-out
  // blocks, with the paired test's gain and its standard error.
  for (const char* k : {"start_kept", "heldout_blocks", "paired_gain_mm2", "paired_se_mm2"})
    EXPECT_TRUE(report["noise"].contains(k)) << k << ": " << report["noise"].dump();
  EXPECT_GT(report["noise"]["heldout_blocks"].get<int>(), 1) << report["noise"].dump();
  // Predicted error (issue 16): estimated from the data, finite, positive over the brain.
  for (const char* k : {"at_tumour_mm", "median_mm", "p95_mm", "estimation", "seconds"})
    EXPECT_TRUE(report["uncertainty"].contains(k)) << k << ": " << report["uncertainty"].dump();
  EXPECT_TRUE(report["uncertainty"]["estimated"].get<bool>()) << report["uncertainty"].dump();
  EXPECT_GT(report["uncertainty"]["median_mm"].get<double>(), 0.0);
  EXPECT_GE(report["uncertainty"]["p95_mm"].get<double>(),
            report["uncertainty"]["median_mm"].get<double>());
  EXPECT_GT(report["uncertainty"]["at_tumour_mm"].get<double>(), 0.0) << "the phantom has a tumour";
  // One sweep, the pose searched on it: s² by maximum likelihood (ScaleEstimator::BY_POSE).
  EXPECT_EQ(report["uncertainty"]["s2_estimator"], "maximum_likelihood")
      << report["uncertainty"].dump();
  EXPECT_EQ(report["converged"].get<bool>(), r.exit_code == 0);
  // prepare's compliance block is reloaded, not recomputed.
  EXPECT_EQ(report["model"]["compliance"]["strategy"], "dense_block") << report["model"].dump();
  EXPECT_EQ(report["model"]["compliance"]["cache"], "adopted") << report["model"].dump();
  {  // Without the cache, with a stale one and with a damaged one: recomputed, said so, same
     // answer.
    // The loop's own deformation in every copy (scene noise.enabled false): with the default the
    // noise model keeps the start on this phantom (no deformation), and a wrong compliance would
    // hardly show in the answer.
    auto copy_model = [&](const char* name) {
      const auto m = dir / name;
      std::filesystem::copy(model, m, std::filesystem::copy_options::recursive);
      auto scene = read_json(m / "scene.json");
      scene["noise"]["enabled"] = false;
      std::ofstream(m / "scene.json") << scene.dump(2);
      return m;
    };
    auto cache_status_and_shift = [&](const std::filesystem::path& m, const char* out) {
      const CliRun run =
          run_brainshift(dir, "register --model " + q(m) + " --doppler " +
                                  q(ph / "intraop/doppler.nii.gz") + " --out " + q(dir / out));
      EXPECT_TRUE(run.exit_code == 0 || run.exit_code == 2) << run.out << run.err;
      const auto rep = read_json(dir / out / "report.json");
      return std::make_pair(rep["model"]["compliance"]["cache"].get<std::string>(),
                            rep["max_displacement_mm"].get<double>());
    };
    const auto [cached, shift_cached] = cache_status_and_shift(copy_model("model_ref"), "res_ref");
    EXPECT_EQ(cached, "adopted");
    EXPECT_GT(shift_cached, 1.0);  // the phantom's sag, 10 mm at the cortex: the loop deforms
    const auto none = copy_model("model_no_cache");
    std::filesystem::remove(none / "compliance.bin");
    const auto [absent, shift_absent] = cache_status_and_shift(none, "res_no_cache");
    EXPECT_EQ(absent, "absent; computed");
    // The cache holds the block bit for bit (it is exactly symmetric; one triangle is stored), so
    // the answer is the same to the last bit; 1e-9 mm allows only for printing.
    EXPECT_NEAR(shift_absent, shift_cached, 1e-9);

    const auto stale = copy_model("model_stale");
    std::vector<std::string> lines;
    {
      std::ifstream in(stale / "fixed.csv");
      for (std::string l; std::getline(in, l);) lines.push_back(l);
    }
    lines.pop_back();  // one fixed node fewer: another stiffness
    {
      std::ofstream o(stale / "fixed.csv");
      for (const auto& l : lines) o << l << '\n';
    }
    EXPECT_NE(
        cache_status_and_shift(stale, "res_stale").first.find("rejected (made for another mesh"),
        std::string::npos);

    const auto damaged = copy_model("model_damaged");
    std::filesystem::resize_file(damaged / "compliance.bin",
                                 std::filesystem::file_size(damaged / "compliance.bin") / 2);
    const auto [unreadable, shift_damaged] = cache_status_and_shift(damaged, "res_damaged");
    EXPECT_NE(unreadable.find("unreadable"), std::string::npos) << unreadable;
    EXPECT_NE(unreadable.find("truncated"), std::string::npos) << unreadable;
    EXPECT_NEAR(shift_damaged, shift_cached, 1e-9);
  }

  r = run_brainshift(dir, "evaluate --result " + q(res) + " --landmarks-pre " +
                              q(ph / "truth/landmarks_preop.csv") + " --landmarks-intra " +
                              q(ph / "truth/landmarks_intraop.csv") + " --surface-pre " +
                              q(ph / "truth/ventricles_preop.vtp") + " --surface-intra " +
                              q(ph / "truth/ventricles_intraop.vtp"));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto ev = read_json(res / "evaluation.json");
  {  // Whole-brain points are point files like the landmarks: given the landmarks themselves,
     // the whole-brain figures are the landmarks' to the last digit; one of the two alone is a
     // one-line error.
    const std::string eval = "evaluate --result " + q(res) + " --landmarks-pre " +
                             q(ph / "truth/landmarks_preop.csv") + " --landmarks-intra " +
                             q(ph / "truth/landmarks_intraop.csv");
    const CliRun wb =
        run_brainshift(dir, eval + " --brain-points-pre " + q(ph / "truth/landmarks_preop.csv") +
                                " --brain-points-intra " + q(ph / "truth/landmarks_intraop.csv"));
    ASSERT_EQ(wb.exit_code, 0) << wb.out << wb.err;
    EXPECT_NE(wb.out.find("whole brain"), std::string::npos) << wb.out;
    const auto ew = read_json(res / "evaluation.json");
    EXPECT_EQ(ew["whole_brain_after_mm"], ew["tre_after_mm"]);
    EXPECT_EQ(ew["whole_brain_before_mm"], ew["tre_before_mm"]);
    expect_one_line_error(
        run_brainshift(dir, eval + " --brain-points-pre " + q(ph / "truth/landmarks_preop.csv")),
        "--brain-points-intra");
  }
  {  // The same landmarks as users have them (issue 35): a two-volume MNI tag file (pre-operative
     // set first) and Slicer markups in LPS, written here from the CSVs' text, give the CSV's
     // figures to 1e-6 mm; evaluate writes the per-landmark errors as markups for Slicer.
    const imaging::Landmarks pre = imaging::read_landmarks(ph / "truth/landmarks_preop.csv");
    const imaging::Landmarks intra = imaging::read_landmarks(ph / "truth/landmarks_intraop.csv");
    ASSERT_EQ(pre.ids, intra.ids);
    std::ostringstream tag, lps_pre, lps_intra;
    tag.precision(17);
    lps_pre.precision(17);
    lps_intra.precision(17);
    tag << "MNI Tag Point File\nVolumes = 2;\nPoints =\n";
    const auto markup = [](std::ostringstream& m, const imaging::Landmarks& l) {
      m << R"({"markups": [{"type": "Fiducial", "coordinateSystem": "LPS", "controlPoints": [)";
      for (std::size_t i = 0; i < l.ids.size(); ++i) {
        const auto k = static_cast<Eigen::Index>(i);
        m << (i ? ", " : "") << R"({"label": ")" << l.ids[i] << R"(", "position": [)"
          << -l.points(k, 0) << ", " << -l.points(k, 1) << ", " << l.points(k, 2) << "]}";
      }
      m << "]}]}";
    };
    for (std::size_t i = 0; i < pre.ids.size(); ++i) {
      const auto k = static_cast<Eigen::Index>(i);
      tag << ' ' << pre.points(k, 0) << ' ' << pre.points(k, 1) << ' ' << pre.points(k, 2) << ' '
          << intra.points(k, 0) << ' ' << intra.points(k, 1) << ' ' << intra.points(k, 2) << " \""
          << pre.ids[i] << '"' << (i + 1 == pre.ids.size() ? ";" : "") << "\n";
    }
    markup(lps_pre, pre);
    markup(lps_intra, intra);
    std::ofstream(dir / "pairs.tag") << tag.str();
    std::ofstream(dir / "pre.mrk.json") << lps_pre.str();
    std::ofstream(dir / "intra.mrk.json") << lps_intra.str();
    for (const auto& [a, b] : {std::pair{dir / "pairs.tag", dir / "pairs.tag"},
                               std::pair{dir / "pre.mrk.json", dir / "intra.mrk.json"}}) {
      const CliRun e = run_brainshift(dir, "evaluate --result " + q(res) + " --landmarks-pre " +
                                               q(a) + " --landmarks-intra " + q(b));
      ASSERT_EQ(e.exit_code, 0) << e.out << e.err;
      const auto ef = read_json(res / "evaluation.json");
      EXPECT_EQ(ef["landmarks"], ev["landmarks"]) << a;
      for (const char* set : {"tre_before_mm", "tre_after_mm"})
        for (const char* k : {"mean", "median", "p95", "max"})
          EXPECT_NEAR(ef[set][k].get<double>(), ev[set][k].get<double>(), 1e-6) << a << set << k;
    }
    const imaging::Landmarks errors = imaging::read_landmark_file(res / "landmark_errors.mrk.json");
    EXPECT_EQ(errors.ids, intra.ids);
    EXPECT_LE((errors.points - intra.points).cwiseAbs().maxCoeff(), 1e-9);

    // register --landmarks: every other pair given (a two-volume tag file), the others held out.
    // Truth pairs pull the model where it is: the held-out landmarks must come out no worse than
    // from the vessels alone (0.1 mm: trilinear sampling of two fields).
    std::ostringstream given;
    given.precision(17);
    given << "MNI Tag Point File\nVolumes = 2;\nPoints =\n";
    imaging::Landmarks held_pre, held_intra;
    std::vector<Vector3d> hp, hi;
    int n_given = 0;
    for (std::size_t i = 0; i < pre.ids.size(); ++i) {
      const auto k = static_cast<Eigen::Index>(i);
      if (i % 2 == 0) {
        ++n_given;
        given << ' ' << pre.points(k, 0) << ' ' << pre.points(k, 1) << ' ' << pre.points(k, 2)
              << ' ' << intra.points(k, 0) << ' ' << intra.points(k, 1) << ' ' << intra.points(k, 2)
              << " \"" << pre.ids[i] << "\"\n";
      } else {
        held_pre.ids.push_back(pre.ids[i]);
        hp.push_back(pre.points.row(k).transpose());
        hi.push_back(intra.points.row(k).transpose());
      }
    }
    given << ";\n";
    held_intra.ids = held_pre.ids;
    held_pre.points.resize(static_cast<Eigen::Index>(hp.size()), 3);
    held_intra.points.resize(held_pre.points.rows(), 3);
    for (std::size_t i = 0; i < hp.size(); ++i) {
      held_pre.points.row(static_cast<Eigen::Index>(i)) = hp[i].transpose();
      held_intra.points.row(static_cast<Eigen::Index>(i)) = hi[i].transpose();
    }
    std::ofstream(dir / "given.tag") << given.str();
    imaging::write_landmarks(dir / "held_pre.csv", held_pre);
    imaging::write_landmarks(dir / "held_intra.csv", held_intra);
    const auto res_l = dir / "res_landmarks";
    const CliRun rl =
        run_brainshift(dir, reg + " --landmarks " + q(dir / "given.tag") + " --out " + q(res_l));
    ASSERT_TRUE(rl.exit_code == 0 || rl.exit_code == 2) << rl.out << rl.err;
    EXPECT_EQ(read_json(res_l / "report.json")["intraop"]["landmarks"]["pairs"].get<int>(),
              n_given);
    const auto held_tre = [&](const std::filesystem::path& result) {
      const CliRun e = run_brainshift(dir, "evaluate --result " + q(result) + " --landmarks-pre " +
                                               q(dir / "held_pre.csv") + " --landmarks-intra " +
                                               q(dir / "held_intra.csv"));
      EXPECT_EQ(e.exit_code, 0) << e.out << e.err;
      return read_json(result / "evaluation.json")["tre_after_mm"]["mean"].get<double>();
    };
    const double vessels_only = held_tre(res), with_landmarks = held_tre(res_l);
    EXPECT_LE(with_landmarks, vessels_only + 0.1)
        << "held-out TRE " << with_landmarks << " mm with landmarks, " << vessels_only
        << " mm from the vessels alone";
    expect_one_line_error(run_brainshift(dir, reg + " --landmarks " + q(dir / "held_pre.csv") +
                                                  " --out " + q(dir / "res_bad")),
                          "not pairs");
  }
  for (const char* k : {"mean", "median", "p95", "max"}) {
    EXPECT_TRUE(ev["tre_before_mm"].contains(k)) << k;
    EXPECT_TRUE(ev["tre_after_mm"].contains(k)) << k;
  }
  // Registration must help, clearly: at least a third of the mean shift removed (measured 68 %
  // on seed 1; other seeds do worse — see the README's state of accuracy).
  EXPECT_GT(ev["shift_corrected_pct"].get<double>(), 33.0) << ev.dump();
  EXPECT_TRUE(ev.contains("surface_after_mm"));
  // The predicted error's calibration on the 13 truth landmarks (independent TLED truth). One case
  // is too few landmarks to hold the issue's bars (bench: docs/history/BENCHMARKS_NOTEBOOK.md,
  // "Predicted error"); asked here: reported, the predicted error not off by more than 3× on
  // average either way (RMS actual/predicted within [1/3, 3]) and most landmarks within 2 sigma.
  const auto& cal = ev["uncertainty_calibration"];
  ASSERT_TRUE(cal.is_object()) << ev.dump();
  EXPECT_EQ(cal["landmarks"].get<int>(), ev["landmarks"].get<int>());
  EXPECT_GT(cal["rms_actual_over_predicted"].get<double>(), 1.0 / 3.0) << cal.dump();
  EXPECT_LT(cal["rms_actual_over_predicted"].get<double>(), 3.0) << cal.dump();
  EXPECT_GE(cal["within_2_sigma_pct"].get<double>(), 50.0) << cal.dump();

  // Replay with a broken frame in the middle: it is reported and skipped, the others register;
  // the predicted error only for the last frame (--uncertainty last).
  std::ofstream(ph / "intraop/frame_001/doppler.nii.gz") << "not an image";
  const auto rep = dir / "replay";
  r = run_brainshift(dir, "replay --model " + q(model) + " --sequence " + q(ph / "intraop") +
                              " --out " + q(rep) + " --uncertainty last");
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;  // some frames failed (or did not converge)
  const auto summary = read_json(rep / "replay.json");
  ASSERT_EQ(summary["frames"].size(), 3u);
  EXPECT_EQ(summary["frames"][1]["status"], "failed");
  EXPECT_NE(summary["frames"][1]["error"].get<std::string>().find("frame_001"), std::string::npos);
  EXPECT_NE(summary["frames"][0]["status"], "failed");
  EXPECT_NE(summary["frames"][2]["status"], "failed");
  for (const char* k : {"median", "p95", "max"})
    EXPECT_GT(summary["latency_s"][k].get<double>(), 0.0) << k;
  EXPECT_TRUE(std::filesystem::exists(rep / "frame_002" / "report.json"));
  EXPECT_TRUE(std::filesystem::exists(rep / "frame_002" / "uncertainty.nii.gz"));
  EXPECT_FALSE(std::filesystem::exists(rep / "frame_000" / "uncertainty.nii.gz"));
  EXPECT_FALSE(read_json(rep / "frame_000" / "report.json")["uncertainty"]["computed"].get<bool>());
  EXPECT_FALSE(summary["frames"][0]["uncertainty"].get<bool>());

  // Bad inputs: one line naming the file and the problem, nothing half-written.
  const auto bad = dir / "bad_out";
  expect_one_line_error(
      run_brainshift(dir, "prepare --labels " + q(dir / "none.nii.gz") + " --mra " +
                              q(ph / "preop/mra.nii.gz") + " --out " + q(bad)),
      "none.nii.gz");
  expect_nothing_half_written(bad);
  std::ofstream(dir / "text.nii.gz") << "hello";
  expect_one_line_error(
      run_brainshift(dir, "prepare --labels " + q(dir / "text.nii.gz") + " --mra " +
                              q(ph / "preop/mra.nii.gz") + " --out " + q(bad)),
      "text.nii.gz");
  {  // an image with no brain in it
    imaging::LabelVolume empty = imaging::read_labels(ph / "preop/labels.nii.gz");
    std::fill(empty.data.begin(), empty.data.end(), 0);
    imaging::write_labels(dir / "empty_labels.nii.gz", empty);
    expect_one_line_error(
        run_brainshift(dir, "prepare --labels " + q(dir / "empty_labels.nii.gz") + " --mra " +
                                q(ph / "preop/mra.nii.gz") + " --out " + q(bad)),
        "no brain");
    expect_nothing_half_written(bad);
  }
  imaging::VolumeF doppler = imaging::read_volume(ph / "intraop/doppler.nii.gz");
  {  // Doppler and model in different spaces
    imaging::VolumeF far = doppler;
    far.geometry.origin += Vector3d(500, 0, 0);
    imaging::write_volume(dir / "far.nii.gz", far);
    expect_one_line_error(run_brainshift(dir, "register --model " + q(model) + " --doppler " +
                                                  q(dir / "far.nii.gz") + " --out " + q(bad)),
                          "does not overlap");
  }
  {  // an empty Doppler volume, and one of NaN
    imaging::VolumeF zero = doppler;
    std::fill(zero.data.begin(), zero.data.end(), 0.0F);
    imaging::write_volume(dir / "zero.nii.gz", zero);
    expect_one_line_error(run_brainshift(dir, "register --model " + q(model) + " --doppler " +
                                                  q(dir / "zero.nii.gz") + " --out " + q(bad)),
                          "no vessels found");
    imaging::VolumeF nan = doppler;
    std::fill(nan.data.begin(), nan.data.end(), std::numeric_limits<float>::quiet_NaN());
    imaging::write_volume(dir / "nan.nii.gz", nan);
    expect_one_line_error(run_brainshift(dir, "register --model " + q(model) + " --doppler " +
                                                  q(dir / "nan.nii.gz") + " --out " + q(bad)),
                          "NaN");
    expect_nothing_half_written(bad);
  }
  {  // a MODEL folder from an older version, and one that is not a model at all
    const auto old_model = dir / "old_model";
    std::filesystem::copy(model, old_model, std::filesystem::copy_options::recursive);
    auto manifest = read_json(old_model / "model.json");
    manifest["version"] = 0;
    std::ofstream(old_model / "model.json") << manifest.dump();
    expect_one_line_error(
        run_brainshift(dir, "register --model " + q(old_model) + " --doppler " +
                                q(ph / "intraop/doppler.nii.gz") + " --out " + q(bad)),
        "prepare again");
    expect_one_line_error(
        run_brainshift(dir, "register --model " + q(ph) + " --doppler " +
                                q(ph / "intraop/doppler.nii.gz") + " --out " + q(bad)),
        "not a brainshift model folder");
  }
  {  // The pose from a sweep on the dura before it was opened (register --pre-dura).
    const auto pre = ph / "intraop/predura/doppler.nii.gz";
    ASSERT_TRUE(std::filesystem::exists(pre)) << "the phantom writes the pre-dura sweep";
    const auto res_pre = dir / "res_pre";
    const CliRun run = run_brainshift(dir, reg + " --pre-dura " + q(pre) + " --out " + q(res_pre));
    ASSERT_TRUE(run.exit_code == 0 || run.exit_code == 2) << run.out << run.err;
    const auto rpt = read_json(res_pre / "report.json");
    ASSERT_TRUE(rpt["intraop"].contains("pre_dura")) << rpt["intraop"].dump();
    const auto& p = rpt["intraop"]["pre_dura"];
    for (const char* k : {"model_from_intraop", "message", "points", "translation_mm"})
      EXPECT_TRUE(p.contains(k)) << k;
    EXPECT_NE(rpt["rigid"]["stop_reason"].get<std::string>().find("given pose"), std::string::npos)
        << rpt["rigid"].dump();
    // The pose given: s² from the held-out vessel blocks (ScaleEstimator::BY_POSE).
    EXPECT_EQ(rpt["uncertainty"]["s2_estimator"], "held_out_blocks") << rpt["uncertainty"].dump();
    // The standard phantom has no navigation offset: the pose is the identity up to what the
    // Doppler centrelines' bias allows (vessels cut by the sector's side sit ≈ 1.5 mm inside it
    // along the beam; docs/history/BENCHMARKS_NOTEBOOK.md): < 2 mm at the centroid and < 5°
    // (measured 0.4 mm, 3°).
    EXPECT_LT(p["translation_mm"].get<double>(), 2.0) << p.dump();
    EXPECT_LT(p["rotation_deg"].get<double>(), 5.0) << p.dump();
    // replay --pre-dura: the offset is measured once and every frame keeps it.
    const auto rep_pre = dir / "replay_pre";
    const CliRun rr = run_brainshift(dir, "replay --model " + q(model) + " --sequence " +
                                              q(ph / "intraop") + " --pre-dura " + q(pre) +
                                              " --uncertainty none --out " + q(rep_pre));
    ASSERT_TRUE(rr.exit_code == 0 || rr.exit_code == 2) << rr.out << rr.err;
    const auto sp = read_json(rep_pre / "replay.json");
    ASSERT_TRUE(sp.contains("pre_dura")) << sp.dump();
    EXPECT_EQ(sp["pre_dura"]["model_from_intraop"], p["model_from_intraop"]);
    EXPECT_NE(sp["frames"][0]["status"], "failed") << sp.dump();
    EXPECT_NE(read_json(rep_pre / "frame_000" / "report.json")["rigid"]["stop_reason"]
                  .get<std::string>()
                  .find("given pose"),
              std::string::npos);
    // The pose is stored beside the result (RES/pre_dura_pose.json) and, measured once by
    // `pre-dura`, reused by register and replay without extracting the sweep again: the same
    // pose to the last digit JSON keeps (the same function on the same points), and the same
    // registration.
    ASSERT_TRUE(std::filesystem::exists(res_pre / "pre_dura_pose.json"));
    const auto pose_file = dir / "pose.json";
    const CliRun pd = run_brainshift(
        dir, "pre-dura --model " + q(model) + " --doppler " + q(pre) + " --out " + q(pose_file));
    ASSERT_EQ(pd.exit_code, 0) << pd.out << pd.err;
    EXPECT_NE(pd.out.find("pre-dura pose from"), std::string::npos) << pd.out;
    const auto stored = read_json(pose_file);
    EXPECT_EQ(stored["model_from_intraop"], p["model_from_intraop"]);
    EXPECT_EQ(stored["model_from_intraop"],
              read_json(res_pre / "pre_dura_pose.json")["model_from_intraop"]);
    const auto res_pose = dir / "res_pose";
    const CliRun rp =
        run_brainshift(dir, reg + " --pre-dura-pose " + q(pose_file) + " --out " + q(res_pose));
    ASSERT_EQ(rp.exit_code, run.exit_code) << rp.out << rp.err;
    const auto rep_pose = read_json(res_pose / "report.json");
    EXPECT_EQ(rep_pose["intraop"]["pre_dura"]["source"], "pose_file");
    EXPECT_EQ(rep_pose["intraop"]["pre_dura"]["model_from_intraop"], p["model_from_intraop"]);
    EXPECT_EQ(rep_pose["rigid"]["model_from_intraop"], rpt["rigid"]["model_from_intraop"]);
    EXPECT_EQ(rep_pose["iterations"], rpt["iterations"]);
    EXPECT_EQ(rep_pose["uncertainty"]["s2_estimator"], "held_out_blocks");
    EXPECT_EQ(rep_pose["uncertainty"]["s2_mn_mm"], rpt["uncertainty"]["s2_mn_mm"]);
    EXPECT_FALSE(std::filesystem::exists(res_pose / "pre_dura_pose.json"))
        << "a given pose is not stored again";
    const auto rep_stored = dir / "replay_stored";
    const CliRun rs = run_brainshift(
        dir, "replay --model " + q(model) + " --sequence " + q(ph / "intraop") +
                 " --pre-dura-pose " + q(pose_file) + " --uncertainty none --out " + q(rep_stored));
    ASSERT_EQ(rs.exit_code, rr.exit_code) << rs.out << rs.err;
    EXPECT_EQ(read_json(rep_stored / "replay.json")["pre_dura"]["model_from_intraop"],
              p["model_from_intraop"]);
    // Both flags at once, a damaged pose file, or a pose measured for another model: one line,
    // nothing written.
    const CliRun both = run_brainshift(dir, reg + " --pre-dura " + q(pre) + " --pre-dura-pose " +
                                                q(pose_file) + " --out " + q(bad));
    EXPECT_NE(both.exit_code, 0);
    EXPECT_NE(both.err.find("excludes"), std::string::npos) << both.err;
    expect_nothing_half_written(bad);
    std::ofstream(dir / "broken_pose.json") << "{\"format\": \"brainshift-pose\"";
    expect_one_line_error(run_brainshift(dir, reg + " --pre-dura-pose " +
                                                  q(dir / "broken_pose.json") + " --out " + q(bad)),
                          "broken_pose.json: not valid JSON");
    expect_nothing_half_written(bad);
    auto other = stored;
    other["preop_grid"]["origin_mm"][0] = other["preop_grid"]["origin_mm"][0].get<double>() + 5.0;
    std::ofstream(dir / "other_pose.json") << other.dump();
    expect_one_line_error(run_brainshift(dir, reg + " --pre-dura-pose " +
                                                  q(dir / "other_pose.json") + " --out " + q(bad)),
                          "measured for another model");
    expect_nothing_half_written(bad);
    // A pre-dura sweep without vessels is a one-line error naming it; nothing is written.
    imaging::VolumeF zero = imaging::read_volume(pre);
    std::fill(zero.data.begin(), zero.data.end(), 0.0F);
    imaging::write_volume(dir / "zero_predura.nii.gz", zero);
    expect_one_line_error(
        run_brainshift(dir,
                       reg + " --pre-dura " + q(dir / "zero_predura.nii.gz") + " --out " + q(bad)),
        "zero_predura.nii.gz");
    expect_nothing_half_written(bad);
  }
  {  // an MRI from another patient (another grid) is refused before anything is written
    imaging::VolumeF mri = imaging::read_volume(ph / "preop/mri.nii.gz");
    mri.geometry.spacing *= 1.1;
    imaging::write_volume(dir / "other_mri.nii.gz", mri);
    expect_one_line_error(run_brainshift(dir, "register --model " + q(model) + " --doppler " +
                                                  q(ph / "intraop/doppler.nii.gz") + " --mri " +
                                                  q(dir / "other_mri.nii.gz") + " --out " + q(bad)),
                          "another patient");
    expect_nothing_half_written(bad);
  }
  // An unwritable output folder is refused before the work starts.
  expect_one_line_error(run_brainshift(dir, reg + " --out " + q(dir / "no/such/folder/res")),
                        "no/such/folder");
}

}  // namespace
}  // namespace brainshift
