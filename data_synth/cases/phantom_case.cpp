#include "data_synth/cases/phantom_case.hpp"

#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/timing.hpp"
#include "data_synth/cases/case_anatomy.hpp"
#include "data_synth/cases/case_outputs.hpp"
#include "data_synth/truth/truth_field.hpp"
#include "data_synth/vessels/tree_graph.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/skeleton_io.hpp"

#include <nlohmann/json.hpp>

#include <fstream>
#include <iomanip>
#include <memory>
#include <optional>
#include <random>
#include <sstream>

namespace brainshift::data_synth {
namespace {

namespace fs = std::filesystem;
using core::Clock;
using nlohmann::json;

using core::seconds_since;

json to_json(const Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

void say(const CaseOptions& o, const std::string& message) {
  logger().info("phantom: {}", message);
  if (o.progress) o.progress(message);
}

/// One deformed state: the solve and its field.
struct TruthState {
  TledResult result;
  std::unique_ptr<TruthField> field;
};

TruthState solve_truth(const CaseParameters& p, const CaseAnatomy& an, const TledSolver& solver,
                       const SagLoad& load) {
  const PhantomMesh& pm = an.mesh;
  TledProblem problem;
  problem.external_force = sag_nodal_force(pm.mesh, load);
  for (const index_t i : pm.base_nodes)
    problem.constraints.push_back({i, {true, true, true}, Vector3d::Zero()});
  problem.contact = an.contact;
  problem.contact->candidate_nodes = pm.surface_nodes;
  TruthState s;
  s.result = solver.solve(problem, p.tled);
  BS_VERIFY(s.result.status != TledStatus::DIVERGED,
            "the truth solve of case '" << p.name << "' diverged: " << s.result.message);
  if (s.result.status != TledStatus::CONVERGED)
    logger().warn("phantom {}: truth solve {}", p.name, s.result.message);
  s.field = std::make_unique<TruthField>(pm.mesh, s.result.displacement);
  return s;
}

/// The probe on the deformed cortex under the craniotomy, pressed in by probe_indent, looking
/// along the inward normal of the rest surface there.
Probe place_probe(const CaseParameters& p, const CaseAnatomy& an, const TruthField& field) {
  const Vector3d cc = an.shape.craniotomy_centre;
  const Vector3d n = an.shape.surface_normal(cc);
  constexpr double inside = 0.5;  // mm: sample the field just inside the surface
  const Vector3d surface = field.deform(cc - inside * n) + inside * n;
  return make_probe(surface - p.probe_indent * n, -n, p.probe);
}

VesselTree deformed(const VesselTree& tree, const TruthField& field) {
  VesselTree out = tree;
  for (Vector3d& x : out.points)
    if (const auto u = field.try_displacement_at(x)) x += *u;
  return out;
}

/// Landmarks (rest positions): tree bifurcations that land in the field of view, then points around
/// the tumour along ±R, ±A, ±S.
std::vector<Vector3d> choose_landmarks(const CaseParameters& p, const CaseAnatomy& an,
                                       const VesselTree& tree, const TruthField& field,
                                       const Probe& probe, index_t& vessel_count) {
  std::vector<Vector3d> out;
  for (const index_t b : tree.bifurcations()) {
    const Vector3d X = tree.points[std::size_t(b)];
    const auto u = field.try_displacement_at(X);
    if (u && probe.in_field_of_view(X + *u)) out.push_back(X);
  }
  vessel_count = index_t(out.size());
  const double r = an.shape.tumour_radius + p.deep_landmark_offset;
  for (int axis = 0; axis < 3; ++axis)
    for (const double sign : {-1.0, 1.0}) {
      const Vector3d X = an.shape.tumour_centre + sign * r * Vector3d::Unit(axis);
      if (an.shape.label_at(X) == imaging::BRAIN && field.try_displacement_at(X)) out.push_back(X);
    }
  return out;
}

std::vector<Vector3d> deform_points(const std::vector<Vector3d>& X, const TruthField& field) {
  std::vector<Vector3d> x;
  for (const Vector3d& p : X) x.push_back(field.deform(p));
  return x;
}

ShiftStats shift_stats(const CaseAnatomy& an, const MatrixX3d& u, const std::vector<Vector3d>& pre,
                       const std::vector<Vector3d>& intra) {
  ShiftStats s;
  const PhantomMesh& pm = an.mesh;
  const Vector3d cc = an.shape.craniotomy_centre;
  double sum = 0.0;
  int count = 0;
  for (const index_t i : pm.surface_nodes) {
    const double d = u.row(i).norm();
    s.max_cortical_shift = std::max(s.max_cortical_shift, d);
    if ((pm.mesh.nodes().row(i).transpose() - cc).norm() <= an.shape.craniotomy_radius) {
      sum += d;
      ++count;
    }
  }
  s.mean_cortical_shift = count > 0 ? sum / count : 0.0;
  for (std::size_t k = 0; k < pre.size(); ++k) {
    const double d = (intra[k] - pre[k]).norm();
    s.mean_landmark_shift += d / double(pre.size());
    s.max_landmark_shift = std::max(s.max_landmark_shift, d);
  }
  return s;
}

json to_json(const ShiftStats& s) {
  return {{"max_cortical_shift_mm", s.max_cortical_shift},
          {"mean_cortical_shift_mm", s.mean_cortical_shift},
          {"mean_landmark_shift_mm", s.mean_landmark_shift},
          {"max_landmark_shift_mm", s.max_landmark_shift}};
}

/// Intra-operative truth points in the frame the case writes them in (CaseParameters::
/// truth_in_image_frame): the world, or that of the intra-operative images (tracking applied).
std::vector<Vector3d> in_truth_frame(const CaseParameters& p, const Probe& probe,
                                     std::vector<Vector3d> x) {
  if (p.truth_in_image_frame)
    for (Vector3d& q : x) q = p.tracking.apply(q, probe.face_centre);
  return x;
}

/// Doppler and B-mode of one deformed state into `dir`; the headers carry the tracking error,
/// rotated about `pivot` (the probe's face centre when not given). `resected`: the tumour renders
/// as fluid (the resection case after the resection; never before the dura is opened).
void write_ultrasound(const CaseParameters& p, const CaseAnatomy& an, const VesselTree& tree,
                      const TruthField& field, const Probe& probe, const fs::path& dir,
                      const std::optional<Vector3d>& pivot = std::nullopt,
                      std::optional<bool> resected = std::nullopt) {
  const imaging::ImageGeometry grid = probe.grid();
  const imaging::LabelVolume labels =
      deformed_labels(field, an.image_label, grid, resected.value_or(p.resection));
  imaging::VolumeF doppler = make_doppler(probe, deformed(tree, field), labels, p.doppler);
  imaging::VolumeF bmode = make_bmode(probe, labels, p.bmode);
  if (!p.tracking.is_zero()) {
    doppler.geometry = with_tracking_error(grid, pivot.value_or(probe.face_centre), p.tracking);
    bmode.geometry = doppler.geometry;
  }
  imaging::write_volume(dir / "doppler.nii.gz", doppler);
  imaging::write_volume(dir / "bmode.nii.gz", bmode);
}

json parameters_json(const CaseParameters& p, const CaseAnatomy& an) {
  return {{"geometry", an.geometry},
          {"truth_mesh",
           {{"cell_size_mm", p.mesh.cell_size},
            {"brain_youngs_modulus_kPa", p.mesh.brain_youngs_modulus},
            {"tumour_youngs_modulus_kPa", p.mesh.tumour_youngs_modulus},
            {"poisson_ratio", p.mesh.poisson_ratio},
            {"resection", p.resection},
            {"cavity_youngs_modulus_kPa", p.cavity_youngs_modulus}}},
          {"load",
           {{"gravity_direction", to_json(p.load.gravity_direction.normalized())},
            {"drain_depth_mm", p.load.drain_depth},
            {"load_scale", p.load.load_scale}}},
          {"vessels",
           {{"cortical_trees", p.vessels.cortical_trees},
            {"one_side", p.vessels.one_side},
            {"deep_branches", p.vessels.deep_branches},
            {"generations", {p.vessels.min_generations, p.vessels.max_generations}}}},
          {"probe",
           {{"half_angle_deg", p.probe.half_angle_deg},
            {"depth_mm", p.probe.depth},
            {"footprint_radius_mm", p.probe.footprint_radius},
            {"spacing_mm", p.probe.spacing}}},
          {"doppler",
           {{"dropout", p.doppler.dropout},
            {"speckle_shape", p.doppler.speckle_shape},
            {"spurious_blobs", p.doppler.spurious_blobs},
            {"blur_sigma_mm", p.doppler.blur_sigma}}},
          {"tracking_error",
           {{"translation_mm", to_json(p.tracking.translation)},
            {"rotation_deg", to_json(p.tracking.rotation_deg)},
            {"truth_in_image_frame", p.truth_in_image_frame}}},
          {"thin_structures", p.thin_structures},
          {"preop_spacing_mm", p.preop_spacing}};
}

fs::path temporary_sibling(const fs::path& dir) {
  std::random_device rd;
  for (int attempt = 0; attempt < 100; ++attempt) {
    std::ostringstream name;
    name << dir.filename().string() << ".tmp-" << std::setw(6) << std::setfill('0')
         << rd() % 1000000;
    const fs::path tmp = dir.parent_path() / name.str();
    if (!fs::exists(tmp)) return tmp;
  }
  BS_THROW("cannot find a free temporary folder name next to " << dir.string());
}

/// Everything of one case into `root` (a fresh folder).
CaseSummary write_case(const CaseParameters& p, const CaseAnatomy& an, const CaseOptions& o,
                       const fs::path& root) {
  const auto t0 = Clock::now();
  CaseSummary summary;
  summary.name = p.name;
  summary.seed = p.seed;
  for (const char* sub : {"preop", "intraop", "truth"}) fs::create_directories(root / sub);

  say(o, "vessels");
  VesselTree tree;
  if (o.user_vessels) {
    BS_VERIFY(an.analytic,
              "a user vessel tree (--vessels) can only be placed into the analytic phantom");
    tree = place_user_tree(from_vessel_graph(imaging::read_skeleton_vtp(*o.user_vessels)),
                           *an.analytic);
  } else {
    tree = make_vessel_tree(an.shape, p.vessels);
  }
  summary.vessel_points = tree.size();

  say(o, "pre-operative images");
  const imaging::LabelVolume& labels = an.labels;
  imaging::write_labels(root / "preop/labels.nii.gz", labels);
  imaging::write_volume(root / "preop/mri.nii.gz", make_mri(labels, p.mri));
  imaging::write_volume(root / "preop/mra.nii.gz", make_mra(labels, tree, p.mra));
  imaging::write_skeleton_vtp(root / "preop/vessels.vtp", to_vessel_graph(tree));

  say(o, "truth solve");
  const auto t_solve = Clock::now();
  const PhantomMesh& pm = an.mesh;
  const TledSolver solver(pm.mesh);
  const TruthState truth = solve_truth(p, an, solver, p.load);
  const double solve_seconds = seconds_since(t_solve);
  summary.solver_status = truth.result.status;
  summary.solver_message = truth.result.message;

  say(o, "truth field, landmarks, surfaces");
  imaging::write_volume(root / "truth/displacement.nii.gz",
                        truth.field->displacement_image(labels.geometry));
  const Probe probe = place_probe(p, an, *truth.field);
  const std::vector<Vector3d> pre =
      choose_landmarks(p, an, tree, *truth.field, probe, summary.vessel_landmarks);
  const std::vector<Vector3d> intra = deform_points(pre, *truth.field);
  summary.landmarks = index_t(pre.size());
  write_landmarks_csv(root / "truth/landmarks_preop.csv", pre);
  write_landmarks_csv(root / "truth/landmarks_intraop.csv", in_truth_frame(p, probe, intra));
  const core::BoundarySurface ventricles =
      region_surface(pm.mesh, pm.tet_labels, imaging::VENTRICLES);
  MatrixX3d moved = ventricles.vertices;
  for (index_t v = 0; v < moved.rows(); ++v) {
    moved.row(v) += truth.result.displacement.row(ventricles.node_of_vertex[std::size_t(v)]);
    if (p.truth_in_image_frame)
      moved.row(v) = p.tracking.apply(moved.row(v).transpose(), probe.face_centre).transpose();
  }
  write_surface_vtp(root / "truth/ventricles_preop.vtp", ventricles.vertices, ventricles.faces);
  write_surface_vtp(root / "truth/ventricles_intraop.vtp", moved, ventricles.faces);
  summary.stats = shift_stats(an, truth.result.displacement, pre, intra);

  say(o, "intra-operative ultrasound");
  write_ultrasound(p, an, tree, *truth.field, probe, root / "intraop");
  // The sweep made on the dura before it is opened (no shift yet), through the same navigation
  // offset (one world transform: rotated about the same pivot): what `register --pre-dura`
  // takes the pose from, so that the sag is not mistaken for a pose.
  say(o, "pre-dura ultrasound");
  const TruthField rest(pm.mesh, MatrixX3d::Zero(pm.mesh.num_nodes(), 3));
  const Probe predura_probe = place_probe(p, an, rest);
  fs::create_directories(root / "intraop" / "predura");
  write_ultrasound(p, an, tree, rest, predura_probe, root / "intraop" / "predura",
                   probe.face_centre, false);

  json frames = json::array();
  for (int k = 1; k <= o.frames; ++k) {
    say(o, "frame " + std::to_string(k) + "/" + std::to_string(o.frames));
    SagLoad load = p.load;
    load.drain_depth = p.load.drain_depth * double(k) / double(o.frames);
    const TruthState state = k == o.frames ? TruthState{} : solve_truth(p, an, solver, load);
    const TruthField& field = k == o.frames ? *truth.field : *state.field;
    std::ostringstream name;
    name << "frame_" << std::setw(3) << std::setfill('0') << (k - 1);
    const fs::path dir = root / "intraop" / name.str();
    fs::create_directories(dir);
    const Probe frame_probe = place_probe(p, an, field);
    write_ultrasound(p, an, tree, field, frame_probe, dir);
    const std::vector<Vector3d> x = deform_points(pre, field);
    write_landmarks_csv(dir / "landmarks_intraop.csv", in_truth_frame(p, frame_probe, x));
    const ShiftStats s = shift_stats(an, field.nodal_displacement(), pre, x);
    summary.frames.push_back(s);
    frames.push_back(
        {{"frame", k - 1}, {"drain_depth_mm", load.drain_depth}, {"stats", to_json(s)}});
  }

  summary.seconds = seconds_since(t0);
  const json doc = {
      {"name", p.name},
      {"seed", p.seed},
      {"generator", "brainshift data_synth (neo-Hookean TLED truth)"},
      {"frame", "world RAS, mm"},
      {"parameters", parameters_json(p, an)},
      {"user_vessels", o.user_vessels ? o.user_vessels->string() : ""},
      {"stats", to_json(summary.stats)},
      {"frames", frames},
      {"truth_solver",
       {{"status", to_string(truth.result.status)},
        {"message", truth.result.message},
        {"iterations", truth.result.iterations},
        {"nodes", pm.mesh.num_nodes()},
        {"tets", pm.mesh.num_tets()},
        {"seconds", solve_seconds},
        {"min_jacobian", truth.result.min_jacobian}}},
      {"probe",
       {{"face_centre_mm", to_json(probe.face_centre)}, {"axis", to_json(probe.frame.col(2))}}},
      {"pre_dura",
       {{"doppler", "intraop/predura/doppler.nii.gz"},
        {"bmode", "intraop/predura/bmode.nii.gz"},
        {"probe_face_centre_mm", to_json(predura_probe.face_centre)}}},
      {"counts",
       {{"landmarks", summary.landmarks},
        {"vessel_landmarks", summary.vessel_landmarks},
        {"vessel_points", summary.vessel_points},
        {"bifurcations", tree.bifurcations().size()},
        {"max_generation", tree.max_generation()}}},
      {"seconds", summary.seconds}};
  std::ofstream(root / "case.json") << doc.dump(2) << '\n';
  return summary;
}

}  // namespace

void apply_resection(const CaseParameters& p, PhantomMesh& pm) {
  if (!p.resection) return;
  Eigen::VectorXd E = pm.mesh.youngs_modulus(), nu = pm.mesh.poisson_ratio();
  for (index_t t = 0; t < pm.mesh.num_tets(); ++t)
    if (pm.tet_labels[std::size_t(t)] == imaging::TUMOUR) {
      E[t] = p.cavity_youngs_modulus;
      nu[t] = p.cavity_poisson_ratio;
    }
  pm.mesh = core::TetMesh(pm.mesh.nodes(), pm.mesh.tets(), E, nu);
}

CaseAnatomy analytic_anatomy(const CaseParameters& p) {
  const PhantomGeometry& g = p.geometry;
  CaseAnatomy an;
  an.shape = brain_shape(g);
  an.image_label = [g](const Vector3d& X) { return g.label_at(X); };
  an.labels = case_labels(p);
  an.mesh = make_phantom_mesh(g, p.mesh);
  apply_resection(p, an.mesh);
  an.contact.skull = g.skull();
  an.contact.opening_centre = g.craniotomy_centre_on_skull();
  an.contact.opening_radius = g.craniotomy_radius;
  an.geometry = {{"centre_mm", to_json(g.centre)},
                 {"semi_axes_mm", to_json(g.semi_axes)},
                 {"base_depth", g.base_depth},
                 {"tumour_centre_mm", to_json(g.tumour_centre())},
                 {"tumour_radius_mm", g.tumour_radius},
                 {"ventricle_scale", g.ventricle_scale},
                 {"craniotomy_centre_mm", to_json(g.craniotomy_centre_on_brain())},
                 {"craniotomy_radius_mm", g.craniotomy_radius},
                 {"skull_gap_mm", g.skull_gap}};
  an.analytic = g;
  return an;
}

imaging::LabelVolume case_labels(const CaseParameters& p) {
  PhantomImageOptions io;
  io.spacing = p.preop_spacing;
  imaging::LabelVolume labels = make_label_volume(p.geometry, io);
  if (!p.thin_structures) return labels;
  const imaging::ImageGeometry& g = labels.geometry;
  const Ellipsoid brain = p.geometry.brain_ellipsoid();
  // Horn: a thin cylinder forward (+A) from the anterior tip of the left ventricle.
  const Ellipsoid v = p.geometry.ventricle(0);
  const Vector3d a = v.centre + Vector3d(0.0, 0.9 * v.semi_axes.y(), 0.0);
  const Vector3d b = a + Vector3d(0.0, 25.0, -5.0);
  // Sulcus: the one-voxel slab through the voxel column nearest to 30 mm left of the centre.
  const int sulcus_i =
      int(std::lround(g.world_to_index(p.geometry.centre - Vector3d(30.0, 0, 0)).x()));
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        std::uint8_t& l = labels.at(i, j, k);
        if (l != imaging::BRAIN) continue;
        const Vector3d x = g.index_to_world(Vector3d(i, j, k));
        const double t = std::clamp((x - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
        if ((x - (a + t * (b - a))).norm() <= p.horn_radius)
          l = imaging::VENTRICLES;
        else if (i == sulcus_i && (brain.closest_point(x) - x).norm() <= p.sulcus_depth)
          l = imaging::BACKGROUND;
      }
  return labels;
}

CaseSummary generate_case(const std::string& name, std::uint32_t seed, const CaseOptions& options) {
  return generate_case(named_case(name, seed), options);
}

CaseSummary generate_case(const CaseParameters& parameters, const CaseOptions& options) {
  check_case_options(options);
  return generate_case(parameters, analytic_anatomy(parameters), options);
}

void check_case_options(const CaseOptions& options) {
  BS_VERIFY(!options.out.empty(), "no output folder given");
  BS_VERIFY(options.frames >= 0, "frames must be >= 0, got " << options.frames);
  const fs::path dir = fs::absolute(options.out);
  BS_VERIFY(!fs::exists(dir) || (fs::is_directory(dir) && fs::is_empty(dir)),
            dir.string() << " exists and is not an empty folder; choose a new output folder");
  BS_VERIFY(fs::is_directory(dir.parent_path()),
            "the folder " << dir.parent_path().string() << " of the output does not exist");
  if (options.user_vessels)
    BS_VERIFY(fs::is_regular_file(*options.user_vessels),
              "vessel file " << options.user_vessels->string() << " does not exist");
}

CaseSummary generate_case(const CaseParameters& parameters, const CaseAnatomy& anatomy,
                          const CaseOptions& options) {
  check_case_options(options);
  const fs::path dir = fs::absolute(options.out);
  const fs::path tmp = temporary_sibling(dir);
  try {
    CaseSummary summary = write_case(parameters, anatomy, options, tmp);
    if (fs::exists(dir)) fs::remove(dir);  // empty, checked above
    fs::rename(tmp, dir);
    return summary;
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(tmp, ignored);
    throw;
  }
}

}  // namespace brainshift::data_synth
