#include "cmd_register.hpp"

#include "intraop_footprint.hpp"
#include "progress.hpp"
#include "result_fields.hpp"
#include "result_overlay.hpp"

#include "apps/workflow/compliance_cache.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/timing.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/mesh_io.hpp"
#include "imaging/vessels/skeleton_graph.hpp"
#include "imaging/vessels/vessel_extraction.hpp"

#include <CLI/CLI.hpp>

#include <cmath>
#include <fstream>
#include <iostream>

namespace brainshift::apps {
namespace {

using core::Clock;
constexpr auto since = &core::seconds_since;  // core/timing.hpp

void mesh_box(const core::TetMesh& mesh, Vector3d& lo, Vector3d& hi) {
  lo = mesh.nodes().colwise().minCoeff().transpose();
  hi = mesh.nodes().colwise().maxCoeff().transpose();
}

nlohmann::json matrix_json(const Eigen::Matrix4d& m) {
  nlohmann::json j = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) j.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  return j;
}

}  // namespace

CLI::App* add_register_command(CLI::App& app, RegisterArgs& args) {
  CLI::App* c =
      app.add_subcommand("register", "Register a prepared model to intra-operative ultrasound");
  c->add_option("--model", args.model, "MODEL folder from brainshift prepare")->required();
  c->add_option("--doppler", args.doppler, "power-Doppler volume (vessels)")->required();
  c->add_option("--bmode", args.bmode,
                "B-mode volume (probe footprint; the beam is estimated from the swept region, any "
                "grid orientation)");
  c->add_option("--mri", args.mri, "pre-operative MRI to warp (same grid as the model's labels)");
  c->add_option("--init", args.init, "rigid start: rigid or identity (default: the scene's)")
      ->check(CLI::IsMember({"rigid", "identity"}));
  c->add_option("--out", args.out, "result folder RES")->required();
  return c;
}

Session open_session(const std::filesystem::path& model_dir) {
  const auto t0 = Clock::now();
  Session s;
  s.loaded = load_model(model_dir);
  const auto& sc = s.loaded.scene;
  constraints::ComplianceOptions compliance = sc.compliance;
  const std::filesystem::path cache = model_dir / compliance_cache_file;
  std::string cache_problem;
  if (compliance.strategy != constraints::ComplianceStrategy::SPARSE_SOLVE &&
      std::filesystem::exists(cache)) {
    try {
      compliance.precomputed = std::make_shared<const constraints::ComplianceBlock>(
          workflow::read_compliance_cache(cache));
    } catch (const Error& e) {
      cache_problem = e.what();
      logger().warn("{}; the compliance block will be recomputed", cache_problem);
    }
  }
  s.model = std::make_unique<constraints::RegistrationModel>(sc.mesh, sc.fixed_nodes, sc.skeleton,
                                                             sc.surface, compliance);
  s.seconds_load = since(t0);
  const auto& op = s.model->mechanics().compliance();
  std::string status = op.cache_status();
  if (!cache_problem.empty())
    status = "unreadable (" + cache_problem + "); computed";
  else if (status == "computed" && !compliance.precomputed)
    status = "absent; computed";
  s.model_report = {{"nodes", sc.mesh.num_nodes()},
                    {"tets", sc.mesh.num_tets()},
                    {"compliance",
                     {{"strategy", constraints::to_string(op.strategy())},
                      {"block_nodes", op.block_nodes().size()},
                      {"block_mib", static_cast<double>(op.block_bytes()) / (1 << 20)},
                      {"cache", status}}},
                    {"seconds_prepare", s.model->seconds_prepare()}};
  return s;
}

IntraopInputs read_intraop(const Session& s, const std::filesystem::path& doppler,
                           const std::optional<std::filesystem::path>& bmode,
                           const imaging::VesselExtractionOptions& vessels) {
  const auto t0 = Clock::now();
  IntraopInputs in;
  const imaging::VolumeF d = imaging::read_volume(doppler);
  BS_VERIFY(d.components == 1, doppler.string() << ": expected a scalar Doppler volume, got "
                                                << d.components << " components");
  Vector3d lo, hi;
  mesh_box(s.model->mesh(), lo, hi);
  BS_VERIFY(grid_overlaps(d.geometry, lo, hi, 5.0),
            doppler.string()
                << ": does not overlap the model (different space or patient? check the tracking)");
  const imaging::VesselExtractionResult v = imaging::extract_vessels(d, vessels);
  BS_VERIFY(v.non_finite_voxels < d.geometry.voxel_count(),
            doppler.string() << ": every voxel is NaN or infinite");
  BS_VERIFY(v.status == imaging::VesselStatus::OK,
            doppler.string() << ": no vessels found (" << v.message << ")");
  in.data.vessel_points = imaging::to_skeleton(v.graph).points;
  in.report["doppler"] = {
      {"file", doppler.string()},           {"threshold", v.threshold},
      {"threshold_rule", v.threshold_rule}, {"branches", v.branch_count},
      {"length_mm", v.total_length_mm},     {"points", in.data.vessel_points.rows()},
      {"nan_voxels", v.non_finite_voxels}};
  if (bmode) {
    const IntraopFootprint f = footprint_from_bmode(*bmode);
    in.data.footprint_points = f.points;
    in.data.footprint_normals = f.normals;
    in.report["bmode"] = f.report;
  }
  in.seconds = since(t0);
  return in;
}

imaging::VolumeF read_preop_mri(const Session& s, const std::filesystem::path& mri) {
  imaging::VolumeF image = imaging::read_volume(mri);
  BS_VERIFY(
      same_grid(image.geometry, s.loaded.preop_grid),
      mri.string() << ": not on the grid of the model's labels (another patient or another scan?)");
  return image;
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
  j["rigid"] = {{"model_from_intraop", matrix_json(r.rigid.transform.matrix())},
                {"converged", r.rigid.converged},
                {"stop_reason", r.rigid.stop_reason},
                {"rms_before_mm", r.rigid.rms_before_mm},
                {"rms_after_mm", r.rigid.rms_after_mm},
                {"weak_dofs", r.rigid.weak_dofs}};
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
                            {"seconds", h.seconds},
                            {"stage", constraints::to_string(h.stage)},
                            {"pairing", constraints::to_string(h.pairing)},
                            {"trust", constraints::to_string(h.trust)},
                            {"finite", h.finite},
                            {"vessel_compliance_ratio", h.vessel_compliance_ratio},
                            {"diagnosis", h.diagnosis}});
  j["stages"] = nlohmann::json::array();
  for (const auto& st : r.stages)
    j["stages"].push_back({{"stage", constraints::to_string(st.kind)},
                           {"stop", constraints::to_string(st.stop)},
                           {"first_iteration", st.first_iteration},
                           {"iterations", st.iterations},
                           {"vessel_compliance_ratio", st.vessel_compliance_ratio}});
  j["noise"] = {{"valid", r.noise.valid},         {"vessel_compliance_ratio", r.noise.ratio},
                {"scatter_mm", r.noise.sigma_mm}, {"effective_dof", r.noise.effective_dof},
                {"rows", r.noise.rows},           {"message", r.noise.message}};
  j["cold_retry"] = r.cold_retry;
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
  report["timing"]["load_model"] = s.seconds_load;
  report["timing"]["extraction"] = in.seconds;
  return report;
}

void write_result(const std::filesystem::path& res, const Session& s,
                  const constraints::RegistrationResult& r, const IntraopInputs& in,
                  const imaging::VolumeF* mri, const nlohmann::json& extra) {
  const auto t0 = Clock::now();
  // Everything is written in the intra-operative frame (result_fields.hpp).
  const ResultFields f = compute_result_fields(s, r, mri);
  write_result(res, s, r, in, mri, f, extra, since(t0));
}

void write_result(const std::filesystem::path& res, const Session& s,
                  const constraints::RegistrationResult& r, const IntraopInputs& in,
                  const imaging::VolumeF* mri, const ResultFields& f, const nlohmann::json& extra,
                  double seconds_fields) {
  const auto t0 = Clock::now();
  const core::TetMesh& mesh = s.model->mesh();
  nlohmann::json report = result_report(s, r, in, extra);
  report["uncertainty"] = uncertainty_report(s, f.uncertainty, in.data);
  write_folder_atomically(res, [&](const std::filesystem::path& dir) {
    auto t = Clock::now();
    const auto done = [&t](const char* what) {
      logger().debug("register: wrote {} in {:.3f} s", what, since(t));
      t = Clock::now();
    };
    imaging::write_tet_mesh(dir / "deformed.vtu", mesh, &f.u_intra);
    done("deformed.vtu");
    imaging::write_volume(dir / "displacement.nii.gz", f.displacement);
    done("displacement.nii.gz");
    imaging::write_displacement_for_slicer(dir / "preop_to_intraop.nrrd", f.preop_to_intraop);
    imaging::write_displacement_for_slicer(dir / "intraop_to_preop.nrrd", f.intraop_to_preop);
    done("the two Slicer transforms");
    imaging::write_volume(dir / "uncertainty.nii.gz", f.uncertainty.map);
    done("uncertainty.nii.gz");
    if (f.warped_mri) imaging::write_volume(dir / "warped_mri.nii.gz", *f.warped_mri);
    done("warped_mri.nii.gz");
    write_result_overlay(dir / "overlay.png", mri, f.warped_mri ? &*f.warped_mri : nullptr,
                         f.displacement, in.data, &f.uncertainty.map);
    done("overlay.png");
    report["timing"]["outputs"] = seconds_fields + since(t0);
    double total = 0;
    for (const char* k : {"load_model", "extraction", "registration", "outputs"})
      total += report["timing"][k].get<double>();
    report["timing"]["total"] = total;
    std::ofstream(dir / "report.json") << report.dump(2) << '\n';
  });
}

int run_register(const RegisterArgs& args, std::ostream& out) {
  const Progress progress("register");
  verify_output_folder(args.out);
  progress.stage("loading the model " + args.model.string());
  Session s = open_session(args.model);
  progress.stage("extracting vessels" + std::string(args.bmode ? " and the probe footprint" : ""));
  const IntraopInputs in = read_intraop(s, args.doppler, args.bmode);
  const std::optional<imaging::VolumeF> mri =
      args.mri ? std::optional<imaging::VolumeF>(read_preop_mri(s, *args.mri)) : std::nullopt;
  constraints::RegistrationOptions options = s.loaded.scene.options;
  if (args.init == "rigid") options.start = constraints::RigidStart::RIGID;
  if (args.init == "identity") options.start = constraints::RigidStart::IDENTITY;
  progress.stage("registering (" + std::to_string(in.data.vessel_points.rows()) +
                 " vessel points, " + std::to_string(in.data.footprint_points.rows()) +
                 " footprint points)");
  const constraints::RegistrationResult r = constraints::register_model(*s.model, in.data, options);
  progress.stage("writing " + args.out.string());
  write_result(args.out, s, r, in, mri ? &*mri : nullptr, {});
  out << "registered in " << r.iterations << " iterations (" << r.stop_reason << "); registration "
      << r.seconds.total << " s, total " << progress.seconds() << " s; max displacement "
      << (r.displacement.rows() ? r.displacement.rowwise().norm().maxCoeff() : 0.0)
      << " mm; results in " << args.out.string() << "\n";
  if (r.converged) return 0;
  std::cerr << "brainshift register: did not converge: " << r.stop_reason
            << " (results written; see report.json)\n";
  return 2;
}

}  // namespace brainshift::apps
