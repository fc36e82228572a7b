#include "apps/workflow/result_uncertainty.hpp"

#include "core/error.hpp"
#include "core/timing.hpp"
#include "imaging/evaluation/metrics.hpp"
#include "imaging/warping/warp_image.hpp"

#include <chrono>
#include <cmath>

namespace brainshift::workflow {
namespace {

/// Centroid (mm, model frame) of the tumour's tetrahedra (tumour_tets()); nullopt without any.
std::optional<Vector3d> tumour_centroid(const Session& s) {
  const core::TetMesh& mesh = s.model->mesh();
  Vector3d sum = Vector3d::Zero();
  double volume = 0.0;
  for (const index_t e : tumour_tets(s)) {
    const double v = std::abs(mesh.signed_volume(e));
    sum += v * mesh.tet_nodes(e).colwise().mean().transpose();
    volume += v;
  }
  if (!(volume > 0)) return std::nullopt;
  return Vector3d(sum / volume);
}

}  // namespace

std::vector<index_t> tumour_tets(const Session& s) {
  const nlohmann::json& m = s.loaded.manifest;
  if (!m.contains("materials") || !m["materials"].contains("tumour")) return {};
  const nlohmann::json& t = m["materials"]["tumour"];
  if (!t.contains("youngs_modulus_kpa") || !t["youngs_modulus_kpa"].is_number()) return {};
  const double e_tumour = t["youngs_modulus_kpa"].get<double>();
  if (m["materials"].contains("brain") && m["materials"]["brain"].contains("youngs_modulus_kpa") &&
      m["materials"]["brain"]["youngs_modulus_kpa"].is_number() &&
      std::abs(m["materials"]["brain"]["youngs_modulus_kpa"].get<double>() - e_tumour) <=
          1e-9 * std::abs(e_tumour))
    return {};  // the same modulus: the tumour cannot be told apart
  const core::TetMesh& mesh = s.model->mesh();
  std::vector<index_t> tets;
  for (index_t e = 0; e < mesh.num_tets(); ++e) {
    const double ye = mesh.youngs_modulus()[e];
    // Stored in kPa or Pa depending on the scene's unit: accept either.
    if (std::abs(ye - e_tumour) <= 1e-6 * std::abs(e_tumour) ||
        std::abs(ye - 1e3 * e_tumour) <= 1e-3 * std::abs(e_tumour))
      tets.push_back(e);
  }
  return tets;
}

ResultUncertainty compute_result_uncertainty(const Session& s,
                                             const constraints::RegistrationResult& r) {
  const core::TetMesh& mesh = s.model->mesh();
  ResultUncertainty u;
  u.computed = true;
  u.nodal = constraints::predict_uncertainty(*s.model, r, s.loaded.scene.options);
  const core::Stopwatch watch;
  // Rasterise [tr Σ, 1, 0] as a "displacement" with no rigid part: component 0 interpolates the
  // variance inside the mesh, component 1 is 1 inside and 0 outside.
  MatrixX3d nodal(mesh.num_nodes(), 3);
  nodal.col(0) = u.nodal.node_variance;
  nodal.col(1).setOnes();
  nodal.col(2).setZero();
  const imaging::VolumeF field = imaging::displacement_field(mesh, nodal, s.loaded.preop_grid);
  u.map = imaging::VolumeF(field.geometry);
  std::vector<double> inside;
  for (std::size_t v = 0; v < u.map.data.size(); ++v) {
    const bool in = field.data[3 * v + 1] > 0.5F;
    const float value = in ? std::sqrt(std::max(0.0F, field.data[3 * v])) : 0.0F;
    u.map.data[v] = std::isfinite(value) ? value : 0.0F;
    if (in) inside.push_back(u.map.data[v]);
  }
  if (!inside.empty()) {
    u.median_mm = imaging::percentile(inside, 50.0);
    u.p95_mm = imaging::percentile(inside, 95.0);
  }
  u.seconds_map = watch.seconds();
  return u;
}

nlohmann::json uncertainty_report(const Session& s, const ResultUncertainty& u,
                                  const constraints::IntraopData& data) {
  const core::TetMesh& mesh = s.model->mesh();
  nlohmann::json j;
  const std::optional<Vector3d> tumour = tumour_centroid(s);
  j["at_tumour_mm"] = tumour ? nlohmann::json(constraints::sigma_at(mesh, u.nodal.node_variance,
                                                                    tumour->transpose())[0])
                             : nlohmann::json(nullptr);
  if (data.landmark_model_points.rows() > 0) {
    const Eigen::VectorXd at =
        constraints::sigma_at(mesh, u.nodal.node_variance, data.landmark_model_points);
    j["at_landmarks"] = std::vector<double>(at.data(), at.data() + at.size());
  }
  j["median_mm"] = u.median_mm;
  j["p95_mm"] = u.p95_mm;
  j["estimation"] = u.nodal.estimation;
  j["estimated"] = u.nodal.estimated;
  j["s2_mn_mm"] = u.nodal.s2;
  // The other estimates of s² (diagnostics: their spread says how well the model fits) and the
  // pose directions the rows determine.
  j["s2_candidates_mn_mm"] = {{"maximum_likelihood", u.nodal.s2_ml},
                              {"restricted", u.nodal.s2_restricted},
                              {"held_out_blocks", u.nodal.s2_heldout},
                              {"discrepancy", u.nodal.s2_discrepancy}};
  j["s2_estimator"] = constraints::scale_estimator_name(u.nodal);
  j["held_out_blocks"] = u.nodal.heldout_blocks;
  j["s2_effective_rows"] = u.nodal.scale_rows;
  j["s2_upper_bound_factor"] = u.nodal.scale_factor;
  j["rigid_rank"] = u.nodal.rigid_rank;
  const constraints::UncertaintyOptions& uo = s.loaded.scene.options.uncertainty;
  const Vector3d& c = u.nodal.tracking_centre;
  j["tracking_prior"] = {{"translation_mm", uo.tracking_translation_mm},
                         {"rotation_deg", uo.tracking_rotation_deg},
                         {"centre_mm", {c.x(), c.y(), c.z()}}};
  j["vessel_alpha_mm_per_mn"] = u.nodal.vessel_alpha;
  j["vessel_noise_sigma_mm"] = u.nodal.noise_sigma_mm;
  j["rows"] = u.nodal.rows;
  j["exact_nodes"] = u.nodal.exact_nodes;
  j["seconds"] = u.nodal.seconds + u.seconds_map;
  j["seconds_nodal"] = u.nodal.seconds;
  j["cpu_seconds_nodal"] = u.nodal.cpu_seconds;
  j["seconds_map"] = u.seconds_map;
  return j;
}

}  // namespace brainshift::workflow
