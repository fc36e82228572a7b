#include "data_synth/cases/label_case.hpp"

#include "core/error.hpp"
#include "imaging/io/image_io.hpp"

#include <memory>

namespace brainshift::data_synth {
namespace {

nlohmann::json to_json(const Vector3d& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); }

}  // namespace

CaseParameters label_case_parameters(const LabelCaseRequest& r) {
  CaseParameters p = named_case(r.case_name, r.seed);
  p.mesh.cell_size = r.cell_size;
  // The thin horn and sulcus are drawn into the analytic phantom's labels only; real labels
  // have their own thin parts.
  p.thin_structures = false;
  return p;
}

CaseAnatomy label_case_anatomy(const LabelCaseRequest& r, const CaseParameters& p) {
  BS_VERIFY(std::filesystem::is_regular_file(r.labels),
            "label file " << r.labels.string() << " does not exist");
  const imaging::LabelVolume labels = imaging::read_labels(r.labels);
  LabelAnatomyOptions o;
  o.craniotomy = r.craniotomy;
  o.tumour_centre = r.tumour_centre;
  o.tumour_radius = r.tumour_radius;
  o.up = -p.load.gravity_direction;
  o.craniotomy_radius = p.geometry.craniotomy_radius;
  o.skull_gap = p.geometry.skull_gap;
  const auto a =
      std::make_shared<const LabelAnatomy>(make_label_anatomy(labels, o, r.labels.string()));

  CaseAnatomy an;
  an.shape = a->shape();
  an.image_label = [a](const Vector3d& X) { return a->voxel_label(X); };
  an.labels = a->labels;
  an.mesh = make_label_mesh(*a, p.mesh);
  apply_resection(p, an.mesh);
  an.contact.hull = a->skull;
  an.contact.opening_centre = a->craniotomy_centre + a->skull_gap * a->craniotomy_normal;
  an.contact.opening_radius = a->craniotomy_radius;
  an.geometry = {
      {"labels_file", std::filesystem::absolute(r.labels).string()},
      {"brain_volume_ml", a->brain_volume_ml},
      {"hull", "labels 1-3 closed by a 5 mm ball, signed distance smoothed by a 1.5 mm Gaussian"},
      {"tumour_centre_mm", to_json(a->tumour_centre)},
      {"tumour_radius_mm", a->tumour_radius},
      {"tumour_placement", to_string(a->tumour_placement)},
      {"tumour_depth_mm", (a->tumour_centre - a->craniotomy_centre).norm()},
      {"craniotomy_centre_mm", to_json(a->craniotomy_centre)},
      {"craniotomy_normal", to_json(a->craniotomy_normal)},
      {"craniotomy_placement",
       to_string(a->craniotomy_placement) +
           (a->craniotomy_placement == Placement::DEFAULT
                ? ": the hull point furthest along -gravity tilted 25 deg toward +R"
                : "")},
      {"craniotomy_radius_mm", a->craniotomy_radius},
      {"skull_gap_mm", a->skull_gap},
      {"fixed_base",
       "boundary nodes within " + std::to_string(int(a->base_height)) + " mm of the lowest (S)"},
      {"fixed_base_nodes", an.mesh.base_nodes.size()}};
  return an;
}

CaseSummary generate_label_case(const LabelCaseRequest& request, const CaseOptions& options) {
  check_case_options(options);
  BS_VERIFY(!options.user_vessels,
            "--vessels cannot be combined with --labels (the user tree is placed into the "
            "analytic phantom only)");
  const CaseParameters p = label_case_parameters(request);
  return generate_case(p, label_case_anatomy(request, p), options);
}

}  // namespace brainshift::data_synth
