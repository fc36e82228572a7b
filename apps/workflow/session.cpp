#include "apps/workflow/session.hpp"

#include "apps/workflow/compliance_cache.hpp"
#include "apps/workflow/intraop_footprint.hpp"
#include "apps/workflow/result_report.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/timing.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/plus_sequence.hpp"
#include "imaging/reconstruction/volume_reconstruction.hpp"
#include "imaging/vessels/skeleton_graph.hpp"

#include <chrono>

namespace brainshift::workflow {
namespace {

using core::Clock;
using core::seconds_since;

void mesh_box(const core::TetMesh& mesh, Vector3d& lo, Vector3d& hi) {
  lo = mesh.nodes().colwise().minCoeff().transpose();
  hi = mesh.nodes().colwise().maxCoeff().transpose();
}

void verify_overlap(const Session& s, const imaging::ImageGeometry& g,
                    const std::filesystem::path& doppler) {
  Vector3d lo, hi;
  mesh_box(s.model->mesh(), lo, hi);
  BS_VERIFY(grid_overlaps(g, lo, hi, 5.0),
            doppler.string()
                << ": does not overlap the model (different space or patient? check the tracking)");
}

imaging::VolumeF read_doppler(const std::filesystem::path& doppler) {
  // A PLUS sequence of tracked frames: reconstructed at the frames' own pixel size.
  imaging::VolumeF d = imaging::is_plus_sequence(doppler)
                           ? imaging::reconstruct_sequence_file(doppler, {})
                           : imaging::read_volume(doppler);
  BS_VERIFY(d.components == 1, doppler.string() << ": expected a scalar Doppler volume, got "
                                                << d.components << " components");
  return d;
}

}  // namespace

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
  s.seconds_load = seconds_since(t0);
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

DopplerExtraction extract_doppler(const std::filesystem::path& doppler,
                                  const imaging::VesselExtractionOptions& vessels) {
  const auto t0 = Clock::now();
  DopplerExtraction out = extract_doppler(read_doppler(doppler), doppler.string(), vessels);
  out.seconds = seconds_since(t0);
  return out;
}

DopplerExtraction extract_doppler(const imaging::VolumeF& d, const std::string& name,
                                  const imaging::VesselExtractionOptions& vessels) {
  const auto t0 = Clock::now();
  BS_VERIFY(d.components == 1,
            name << ": expected a scalar Doppler volume, got " << d.components << " components");
  DopplerExtraction out;
  out.file = name;
  out.geometry = d.geometry;
  try {
    out.vessels = imaging::extract_vessels(d, vessels);
  } catch (...) {
    out.failure = std::current_exception();
  }
  out.seconds = seconds_since(t0);
  return out;
}

/// read_intraop() with the footprint made by `footprint` (null: none), after the Doppler's checks.
static IntraopInputs read_intraop(const Session& s, const DopplerExtraction& d,
                                  const std::function<IntraopFootprint()>& footprint) {
  const auto t0 = Clock::now();
  IntraopInputs in;
  const std::filesystem::path& doppler = d.file;
  verify_overlap(s, d.geometry, doppler);
  if (d.failure) std::rethrow_exception(d.failure);
  const imaging::VesselExtractionResult& v = d.vessels;
  BS_VERIFY(v.non_finite_voxels < d.geometry.voxel_count(),
            doppler.string() << ": every voxel is NaN or infinite");
  BS_VERIFY(v.status == imaging::VesselStatus::OK,
            doppler.string() << ": no vessels found (" << v.message << ")");
  in.data.vessel_points = imaging::to_skeleton(v.graph).points;
  in.report["doppler"] = {
      {"file", doppler.string()},           {"threshold", v.threshold},
      {"threshold_rule", v.threshold_rule}, {"branches", v.branch_count},
      {"length_mm", v.total_length_mm},     {"points", in.data.vessel_points.rows()},
      {"nan_voxels", v.non_finite_voxels},  {"points_at_support_edge", v.points_at_support_edge}};
  if (footprint) {
    const IntraopFootprint f = footprint();
    in.data.footprint_points = f.points;
    in.data.footprint_normals = f.normals;
    in.report["bmode"] = f.report;
  }
  in.seconds = d.seconds + seconds_since(t0);
  return in;
}

IntraopInputs read_intraop(const Session& s, const DopplerExtraction& d,
                           const std::optional<std::filesystem::path>& bmode) {
  if (!bmode) return read_intraop(s, d, std::function<IntraopFootprint()>());
  return read_intraop(s, d, [&bmode] { return footprint_from_bmode(*bmode); });
}

IntraopInputs read_intraop(const Session& s, const DopplerExtraction& d,
                           const imaging::VolumeF* bmode, const std::string& bmode_name) {
  if (!bmode) return read_intraop(s, d, std::function<IntraopFootprint()>());
  return read_intraop(s, d, [&] { return footprint_from_bmode(*bmode, bmode_name); });
}

IntraopInputs read_intraop(const Session& s, const DopplerExtraction& d,
                           const IntraopFootprint* footprint) {
  if (!footprint) return read_intraop(s, d, std::function<IntraopFootprint()>());
  return read_intraop(s, d, [footprint] { return *footprint; });
}

IntraopInputs read_intraop(const Session& s, const std::filesystem::path& doppler,
                           const std::optional<std::filesystem::path>& bmode,
                           const imaging::VesselExtractionOptions& vessels) {
  // Serially the overlap is checked before extracting (no extraction of a misplaced volume).
  const auto t0 = Clock::now();
  DopplerExtraction e;
  e.file = doppler;
  const imaging::VolumeF d = read_doppler(doppler);
  e.geometry = d.geometry;
  verify_overlap(s, e.geometry, doppler);
  e.vessels = imaging::extract_vessels(d, vessels);
  e.seconds = seconds_since(t0);
  return read_intraop(s, e, bmode);
}

Eigen::Isometry3d pose_from_pre_dura(const Session& s, const std::filesystem::path& doppler,
                                     const constraints::RegistrationOptions& options,
                                     nlohmann::json& report) {
  return pose_from_pre_dura(s, extract_doppler(doppler), options, report);
}

Eigen::Isometry3d pose_from_pre_dura(const Session& s, const DopplerExtraction& doppler,
                                     const constraints::RegistrationOptions& options,
                                     nlohmann::json& report) {
  const IntraopInputs pre = read_intraop(s, doppler, std::nullopt);
  const MatrixX3d& p = pre.data.vessel_points;
  BS_VERIFY(p.rows() >= options.global_start.min_points,
            doppler.file.string() << ": " << p.rows() << " vessel points, fewer than the "
                                  << options.global_start.min_points
                                  << " a pose needs (pre-dura sweep)");
  const constraints::StartResult g = constraints::pre_dura_pose(*s.model, p, options);
  report = pre.report["doppler"];
  report["accepted"] = g.accepted;
  report["translation_mm"] = g.translation_mm;
  report["rotation_deg"] = g.rotation_deg;
  report["rms_before_mm"] = g.rms_before_mm;
  report["rms_after_mm"] = g.rms_after_mm;
  report["message"] = g.message;
  report["ambiguous"] = g.ambiguous;
  report["ambiguity"] = g.ambiguity;
  report["gain_z"] = g.gain_z;
  report["gain_blocks"] = g.gain_blocks;
  report["navigation_prior_z"] = g.prior_z;
  report["model_from_intraop"] = matrix_json(g.transform.matrix());
  return g.transform;
}

imaging::VolumeF read_preop_mri(const Session& s, const std::filesystem::path& mri) {
  return read_preop_mri(s, mri, imaging::read_volume(mri));
}

imaging::VolumeF read_preop_mri(const Session& s, const std::filesystem::path& mri,
                                imaging::VolumeF image) {
  BS_VERIFY(
      same_grid(image.geometry, s.loaded.preop_grid),
      mri.string() << ": not on the grid of the model's labels (another patient or another scan?)");
  return image;
}

}  // namespace brainshift::workflow
