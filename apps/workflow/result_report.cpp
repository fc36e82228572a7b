#include "apps/workflow/result_report.hpp"

#include "apps/workflow/intraop_frame.hpp"
#include "apps/workflow/model_folder.hpp"
#include "apps/workflow/pose_file.hpp"
#include "apps/workflow/result_fields.hpp"
#include "apps/workflow/result_overlay.hpp"
#include "core/logger.hpp"
#include "core/timing.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/mesh_io.hpp"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <functional>

namespace brainshift::workflow {
namespace {

using core::Clock;
using core::seconds_since;

/// Writes the files of one part of the result's fields into `dir`; `transform_written` is called
/// once its Slicer transform (FORWARD: intraop_to_preop.nrrd, INVERSE: preop_to_intraop.nrrd)
/// is written, before the part's other files.
void write_part(const std::filesystem::path& dir, const ResultFields& f, ResultPart part,
                const std::function<void()>& transform_written = {}) {
  const core::Stopwatch watch;
  const auto transform_done = [&] {
    if (transform_written) transform_written();
  };
  const char* what = "";
  switch (part) {
    case ResultPart::FORWARD:  // the Slicer transform first (navigation needs it most)
      imaging::write_displacement_for_slicer(dir / "intraop_to_preop.nrrd", f.intraop_to_preop);
      transform_done();
      imaging::write_volume(dir / "displacement.nii.gz", f.displacement);
      what = "intraop_to_preop.nrrd and displacement.nii.gz";
      break;
    case ResultPart::INVERSE:
      imaging::write_displacement_for_slicer(dir / "preop_to_intraop.nrrd", f.preop_to_intraop);
      transform_done();
      what = "preop_to_intraop.nrrd";
      break;
    case ResultPart::WARPED_MRI:
      imaging::write_volume(dir / "warped_mri.nii.gz", *f.warped_mri);
      what = "warped_mri.nii.gz";
      break;
    case ResultPart::UNCERTAINTY:
      imaging::write_volume(dir / "uncertainty.nii.gz", f.uncertainty.map);
      what = "uncertainty.nii.gz";
      break;
  }
  logger().debug("register: wrote {} in {:.3f} s", what, watch.seconds());
}

void write_mesh(const std::filesystem::path& dir, const Session& s, const ResultFields& f) {
  const core::Stopwatch watch;
  imaging::write_tet_mesh(dir / "deformed.vtu", s.model->mesh(), &f.u_intra);
  logger().debug("register: wrote deformed.vtu in {:.3f} s", watch.seconds());
}

/// The overlay and report.json, last (the report's output time `seconds_outputs` counts to here).
void finish(const std::filesystem::path& dir, const Session& s, const IntraopInputs& in,
            const imaging::VolumeF* mri, const ResultFields& f, nlohmann::json& report,
            double seconds_outputs) {
  const core::Stopwatch watch;
  write_result_overlay(dir / "overlay.png", mri, f.warped_mri ? &*f.warped_mri : nullptr,
                       f.displacement, in.data,
                       f.uncertainty.computed ? &f.uncertainty.map : nullptr);
  logger().debug("register: wrote overlay.png in {:.3f} s", watch.seconds());
  report["uncertainty"] = f.uncertainty.computed ? uncertainty_report(s, f.uncertainty, in.data)
                                                 : nlohmann::json{{"computed", false}};
  report["timing"]["outputs"] = seconds_outputs + watch.seconds();
  double total = 0;
  for (const char* k : {"load_model", "extraction", "registration", "outputs"})
    total += report["timing"][k].get<double>();
  report["timing"]["total"] = total;
  if (report["timing"].contains("elapsed_before_outputs"))  // given by register_and_write()
    report["timing"]["elapsed"] = report["timing"]["elapsed_before_outputs"].get<double>() +
                                  report["timing"]["outputs"].get<double>();
  std::ofstream(dir / "report.json") << report.dump(2) << '\n';
  if (!in.measured_pose.is_null())
    std::ofstream(dir / pose_file_name) << in.measured_pose.dump(2) << '\n';
}

}  // namespace

nlohmann::json matrix_json(const Eigen::Matrix4d& m) {
  nlohmann::json j = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) j.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return j;
}

nlohmann::json registration_report(const constraints::RegistrationResult& r) {
  using constraints::ConstraintSet;
  nlohmann::json j;
  j["iterations"] = r.iterations;
  j["converged"] = r.converged;
  j["stop"] = constraints::to_string(r.stop);
  j["stop_reason"] = r.stop_reason;
  auto rows = [&](ConstraintSet k) { return r.rows_by_set[static_cast<std::size_t>(k)]; };
  const auto& last = r.history.empty() ? constraints::IterationRecord{} : r.history.back();
  j["constraints"] = {
      {"vessels", {{"pairs", last.vessel_pairs}, {"rows", rows(ConstraintSet::VESSELS)}}},
      {"footprint", {{"pairs", last.footprint_pairs}, {"rows", rows(ConstraintSet::FOOTPRINT)}}},
      {"dura", {{"rows", rows(ConstraintSet::DURA)}}},
      {"landmarks", {{"rows", rows(ConstraintSet::LANDMARK)}}},
      {"total_rows", last.rows}};
  j["rigid"] = {{"model_from_intraop", matrix_json(r.start.transform.matrix())},
                {"converged", r.start.converged},
                {"stop_reason", r.start.stop_reason},
                {"rms_before_mm", r.start.rms_before_mm},
                {"rms_after_mm", r.start.rms_after_mm},
                // The weakly determined directions: why the pose is ambiguous, when it is.
                {"weak_dofs", r.start.ambiguous ? r.start.ambiguity : std::string()}};
  // The global start's evidence for its pose (when it ran): the best distinct other pose's
  // share of the score and its distance, the points' spread, and whether it was ambiguous.
  j["rigid"]["ambiguity"] = {
      {"ambiguous", r.start.ambiguous},
      {"reason", r.start.ambiguity},
      {"runner_up_ratio", r.start.runner_up_ratio},
      {"runner_up_distance_mm", r.start.runner_up_distance_mm},
      {"spread_mm", {r.start.spread_mm(0), r.start.spread_mm(1), r.start.spread_mm(2)}},
      {"gain_z", r.start.gain_z},
      {"gain_blocks", r.start.gain_blocks}};
  // The pose against the navigation's stated accuracy (global_start.navigation_accuracy_mm):
  // its distance from the identity in the prior's standard deviations; beyond 3 the data moved
  // the pose, and the fixed base with it, further than the navigation's accuracy allows.
  j["rigid"]["navigation_prior"] = {
      {"z", r.start.prior_z},
      {"beyond", r.start.prior_z > 3.0},
      {"bulk_shift_mm", {r.start.bulk_shift(0), r.start.bulk_shift(1), r.start.bulk_shift(2)}}};
  j["timing"] = {{"rigid", r.seconds.rigid},
                 {"pairing", r.seconds.pairing},
                 {"free_motion", r.seconds.free_motion},
                 {"delassus", r.seconds.delassus},
                 {"pgs", r.seconds.pgs},
                 {"correction", r.seconds.correction},
                 {"noise", r.seconds.noise},
                 {"registration", r.seconds.total}};
  j["history"] = nlohmann::json::array();
  for (const auto& h : r.history)
    j["history"].push_back({{"vessel_pairs", h.vessel_pairs},
                            {"footprint_pairs", h.footprint_pairs},
                            {"dura_rows", h.dura_rows},
                            {"rows", h.rows},
                            {"max_increment_mm", h.max_increment_mm},
                            {"pgs_iterations", h.pgs_iterations},
                            {"pgs_residual", h.pgs_residual},
                            {"pgs_stop", constraints::to_string(h.pgs_stop)},
                            {"pairing_changed", h.pairing_changed},
                            {"pairing_frozen", h.pairing_frozen},
                            {"trust_radius_mm", h.trust_radius_mm},
                            {"damping", h.damping},
                            {"seconds", h.seconds},
                            {"stage", constraints::to_string(h.stage)},
                            {"pairing", constraints::to_string(h.pairing)},
                            {"trust", constraints::to_string(h.trust)},
                            {"finite", h.finite},
                            {"vessel_compliance_ratio", h.vessel_compliance_ratio},
                            {"diagnosis", h.diagnosis},
                            {"inverted_elements", h.inverted_elements},
                            {"max_increment_node", h.max_increment_node},
                            {"increment_beyond_mm", h.increment_beyond_mm},
                            {"extrapolated_mm", h.extrapolated_mm}});
  j["stages"] = nlohmann::json::array();
  for (const auto& st : r.stages)
    j["stages"].push_back({{"stage", constraints::to_string(st.kind)},
                           {"stop", constraints::to_string(st.stop)},
                           {"first_iteration", st.first_iteration},
                           {"iterations", st.iterations},
                           {"vessel_compliance_ratio", st.vessel_compliance_ratio}});
  j["noise"] = {{"valid", r.noise.valid},
                {"vessel_compliance_ratio", r.noise.ratio},
                {"scatter_mm", r.noise.sigma_mm},
                {"effective_dof", r.noise.effective_dof},
                {"rows", r.noise.rows},
                {"criterion", to_string(r.noise.criterion)},
                {"start_kept", r.noise.keep_start},
                {"heldout_blocks", r.noise.blocks},
                {"paired_gain_mm2", r.noise.paired_gain_mm2},
                {"paired_se_mm2", r.noise.paired_se_mm2},
                {"message", r.noise.message}};
  j["cold_retry"] = r.cold_retry;
  j["load_retry"] = r.load_retry;
  j["max_displacement_mm"] =
      r.displacement.rows() ? r.displacement.rowwise().norm().maxCoeff() : 0.0;
  return j;
}

nlohmann::json result_report(const Session& s, const constraints::RegistrationResult& r,
                             const IntraopInputs& in, const nlohmann::json& extra) {
  nlohmann::json report = registration_report(r);
  report["intraop"] = in.report;
  if (extra.is_object()) report.merge_patch(extra);
  report["model"] = s.model_report;
  // The rigid part's motion of the fixed base, against the navigation's accuracy (issue 32: the
  // base must not move beyond what the navigation allows unless the data demand it).
  const FixedBaseMotion base = fixed_base_motion(r, *s.model);
  const double yardstick = navigation_yardstick_mm(s.loaded.scene.options);
  report["rigid"]["fixed_base_moved_mm"] = {
      {"mean", base.mean_mm},
      {"max", base.max_mm},
      {"nodes", base.nodes},
      {"navigation_accuracy_mm", yardstick},
      {"note", fixed_base_note(base, in.data.pose.has_value(), yardstick)}};
  report["timing"]["load_model"] = s.seconds_load;
  report["timing"]["extraction"] = in.seconds;
  return report;
}

void write_result(const std::filesystem::path& res, const Session& s,
                  const constraints::RegistrationResult& r, const IntraopInputs& in,
                  const imaging::VolumeF* mri, const nlohmann::json& extra, bool with_uncertainty,
                  int threads) {
  const auto t0 = Clock::now();
  nlohmann::json report = result_report(s, r, in, extra);
  write_folder_atomically(res, [&](const std::filesystem::path& dir) {
    // Everything is written in the intra-operative frame (result_fields.hpp); each part's files
    // as soon as it is computed, on the thread that computed it.
    ResultFields f;
    // When the two Slicer transforms were written (each lane writes one first), s since t0.
    double transform_written[2] = {0.0, 0.0};
    compute_result_fields(s, r, mri, with_uncertainty, threads, f, [&](ResultPart part) {
      write_part(dir, f, part, [&] {
        const int k = part == ResultPart::FORWARD ? 0 : 1;
        transform_written[k] = seconds_since(t0);
      });
    });
    report["timing"]["transforms_written"] = std::max(transform_written[0], transform_written[1]);
    if (report["timing"].contains("elapsed_before_outputs"))
      report["timing"]["to_transform"] = report["timing"]["elapsed_before_outputs"].get<double>() +
                                         report["timing"]["transforms_written"].get<double>();
    write_mesh(dir, s, f);
    finish(dir, s, in, mri, f, report, seconds_since(t0));
  });
}

void write_result(const std::filesystem::path& res, const Session& s,
                  const constraints::RegistrationResult& r, const IntraopInputs& in,
                  const imaging::VolumeF* mri, const ResultFields& f, const nlohmann::json& extra,
                  double seconds_fields) {
  const auto t0 = Clock::now();
  nlohmann::json report = result_report(s, r, in, extra);
  write_folder_atomically(res, [&](const std::filesystem::path& dir) {
    write_mesh(dir, s, f);
    write_part(dir, f, ResultPart::FORWARD);
    write_part(dir, f, ResultPart::INVERSE);
    if (f.warped_mri) write_part(dir, f, ResultPart::WARPED_MRI);
    if (f.uncertainty.computed) write_part(dir, f, ResultPart::UNCERTAINTY);
    finish(dir, s, in, mri, f, report, seconds_fields + seconds_since(t0));
  });
}

}  // namespace brainshift::workflow
