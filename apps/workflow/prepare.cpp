#include "apps/workflow/prepare.hpp"

#include "apps/workflow/compliance_cache.hpp"
#include "apps/workflow/model_folder.hpp"
#include "apps/workflow/scene_io.hpp"
#include "core/error.hpp"
#include "core/timing.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/csv.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/mesh_io.hpp"
#include "imaging/io/output_guard.hpp"
#include "imaging/io/skeleton_io.hpp"
#include "imaging/io/surface_io.hpp"
#include "imaging/meshing/boundary_surface.hpp"
#include "imaging/meshing/collision_surface.hpp"
#include "imaging/meshing/label_mesher.hpp"
#include "imaging/meshing/model_defaults.hpp"
#include "imaging/meshing/skeleton_in_mesh.hpp"
#include "imaging/vessels/vessel_extraction.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <fstream>
#include <functional>
#include <sstream>

namespace brainshift::workflow {
namespace {

/// Vessel points outside the mesh within this distance are moved onto it; farther ones are dropped
/// (cortical vessels lie on the pial surface and in the sulci, on or just outside the brain).
constexpr double vessel_snap_mm = 5.0;
/// Less kept centreline than this (mm) is a weak input, warned about (the phantoms have ≈ 600 mm,
/// a Doppler sector sees ≈ 100–300 mm of it).
constexpr double weak_vessels_mm = 100.0;

/// Below this labelled volume (labels 1–3, mL) the label volume is not a brain: an adult brain is
/// ≈ 1,200 mL, the phantoms ≈ 1,100 mL, a 27 mm cube 20 mL.
constexpr double min_brain_ml = 10.0;

/// Voxels of each label value.
std::array<std::int64_t, 256> count_labels(const imaging::LabelVolume& labels) {
  std::array<std::int64_t, 256> n{};
  for (auto v : labels.data) ++n[v];
  return n;
}

/// The label volume's checks before meshing: not empty, only labels 0–3, some brain (label 1),
/// at least min_brain_ml of it.
void verify_labels(const std::filesystem::path& path, const imaging::LabelVolume& labels,
                   const std::array<std::int64_t, 256>& n) {
  BS_VERIFY(!labels.empty() && labels.geometry.voxel_count() > 0,
            path.string() << ": empty label volume (no voxel)");
  for (int v = 4; v < 256; ++v)
    BS_VERIFY(n[std::size_t(v)] == 0,
              path.string() << ": label value " << v << " (" << n[std::size_t(v)]
                            << " voxels); allowed: 0 background, 1 brain, 2 tumour, 3 ventricles");
  BS_VERIFY(n[0] < labels.geometry.voxel_count(),
            path.string() << ": no brain in it (every voxel is background, label 0)");
  BS_VERIFY(n[1] > 0, path.string() << ": no brain in it (no voxel has label 1; " << n[2]
                                    << " tumour and " << n[3] << " ventricle voxels)");
  const double ml = double(n[1] + n[2] + n[3]) * labels.geometry.spacing.prod() / 1000.0;
  BS_VERIFY(ml >= min_brain_ml,
            path.string() << ": the labelled brain is only " << ml << " mL (" << n[1] + n[2] + n[3]
                          << " voxels of " << labels.geometry.spacing.prod()
                          << " mm³); an adult brain is ≈ 1,200 mL (wrong labels or voxel size?)");
}

/// Materials by label and how many tetrahedra carry each.
nlohmann::json materials_json(const imaging::MeshingOptions& o,
                              const std::vector<std::uint8_t>& tet_label) {
  std::array<std::int64_t, 4> tets{};
  for (auto l : tet_label) ++tets[std::min<std::size_t>(l, 3)];
  return {{"brain", {{"youngs_modulus_kpa", o.brain_youngs_modulus}, {"tets", tets[1]}}},
          {"tumour", {{"youngs_modulus_kpa", o.tumour_youngs_modulus}, {"tets", tets[2]}}},
          {"ventricles",
           {{"youngs_modulus_kpa", o.ventricle_youngs_modulus},
            {"model", o.ventricles == imaging::VentricleModel::CAVITY ? "cavity" : "soft material"},
            {"tets", tets[3]}}},
          {"poisson_ratio", o.poisson_ratio}};
}

/// Σ a · (b × c) / 6 over the triangles: the enclosed volume, mL (mm³ / 1000) for outward normals.
double enclosed_ml(const core::SurfaceMesh& s) {
  double v = 0.0;
  for (index_t f = 0; f < s.triangles.rows(); ++f) {
    const Vector3d a = s.vertices.row(s.triangles(f, 0)), b = s.vertices.row(s.triangles(f, 1)),
                   c = s.vertices.row(s.triangles(f, 2));
    v += a.dot(b.cross(c)) / 6.0;
  }
  return v / 1000.0;
}

double mesh_ml(const core::TetMesh& mesh) {
  double v = 0.0;
  for (index_t t = 0; t < mesh.num_tets(); ++t) v += mesh.signed_volume(t);
  return v / 1000.0;
}

nlohmann::json vector_json(const Vector3d& v) { return {v.x(), v.y(), v.z()}; }

/// Up to 3 significant decimals, for messages.
std::string mm(double x) {
  std::ostringstream s;
  s.precision(3);
  s << x;
  return s.str();
}

nlohmann::json surface_json(const imaging::CollisionSurface& c,
                            const imaging::CollisionSurfaceOptions& o) {
  const std::string method = c.wrapped ? "alpha wrap of the non-manifold boundary (alpha " +
                                             mm(o.wrap_alpha_mm) + " mm, offset " +
                                             mm(o.wrap_offset_mm) + " mm), decimated"
                                       : std::string("boundary decimated");
  return {{"vertices", c.surface.vertices.rows()},
          {"triangles", c.surface.triangles.rows()},
          {"enclosed_volume_ml", enclosed_ml(c.surface)},
          {"requested_vertices", o.target_vertices},
          {"boundary_vertices", c.boundary_vertices},
          {"non_manifold_edges", c.non_manifold_edges},
          {"non_manifold_vertices", c.non_manifold_vertices},
          {"method", method},
          {"vertices_moved_onto_mesh", c.moved_vertices},
          {"max_outside_mm", c.max_outside_mm}};
}

nlohmann::json fixed_json(const imaging::FixedRegion& f) {
  return {{"nodes", f.nodes.size()},
          {"down", vector_json(f.down)},
          {"height_mm", f.height_mm},
          {"extent_mm", f.extent_mm},
          {"rule", f.rule}};
}

nlohmann::json craniotomy_json(const imaging::Craniotomy& c) {
  return {{"centre_mm", vector_json(c.centre)}, {"radius_mm", c.radius_mm}, {"rule", c.rule}};
}

nlohmann::json vessels_json(const imaging::SkeletonFit& fit) {
  return {{"branches", fit.graph.branches.size()},
          {"length_mm", fit.graph.total_length()},
          {"points", fit.points},
          {"inside", fit.inside},
          {"snapped", fit.snapped},
          {"dropped", fit.dropped},
          {"snap_distance_mm", vessel_snap_mm},
          {"max_snap_mm", fit.max_snap_mm},
          {"mean_snap_mm", fit.mean_snap_mm}};
}

/// The MRA's vessel skeleton fitted to the mesh (skeleton_in_mesh.hpp), with its progress lines
/// and warnings. \throws brainshift::Error naming the MRA when it has vessels but none near the
/// mesh.
imaging::SkeletonFit mra_vessels(const std::filesystem::path& path, const imaging::VolumeF& mra,
                                 const core::TetMesh& mesh, const Progress& progress,
                                 const std::function<void(const std::string&)>& warn) {
  progress.stage("extracting the vessels from the MRA");
  // An MRA is not speckled: without the pre-filter (meant for Doppler noise) thin vessels are
  // kept (phantom recall 0.97 vs 0.91 with it, precision unchanged).
  imaging::VesselExtractionOptions mra_options;
  mra_options.prefilter_sigma_mm = 0.0;
  // No sector cuts an angiogram's vessels (its background is tissue, not a scanner's mask).
  mra_options.drop_at_support_edge = false;
  const imaging::VesselExtractionResult vessels = imaging::extract_vessels(mra, mra_options);
  imaging::SkeletonFit fit;
  if (vessels.status == imaging::VesselStatus::OK) {
    fit = imaging::fit_skeleton_to_mesh(vessels.graph, mesh, vessel_snap_mm);
    BS_VERIFY(!fit.graph.branches.empty(),
              path.string() << ": none of its " << fit.points
                            << " vessel points lies in the brain mesh or within " << vessel_snap_mm
                            << " mm of it (different patient or frame?)");
    progress.stage("vessels: " + std::to_string(fit.points) + " skeleton points, " +
                   std::to_string(fit.inside) + " inside the mesh, " + std::to_string(fit.snapped) +
                   " outside within " + mm(vessel_snap_mm) + " mm moved onto it (up to " +
                   mm(fit.max_snap_mm) + " mm), " + std::to_string(fit.dropped) +
                   " dropped (farther out, or alone)");
    if (2 * fit.dropped > fit.points)
      warn(std::to_string(fit.dropped) + " of the " + std::to_string(fit.points) +
           " vessel points of " + path.string() + " are farther than " + mm(vessel_snap_mm) +
           " mm from the brain mesh and were dropped");
    if (fit.graph.total_length() < weak_vessels_mm)
      warn("only " + mm(fit.graph.total_length()) + " mm of vessels from " + path.string() +
           " in the brain (" + std::to_string(fit.graph.branches.size()) +
           " branches): few points to register on");
  } else {
    warn("no vessels in " + path.string() + " (" + vessels.message +
         "); registration will need footprint data");
  }
  return fit;
}

nlohmann::json input_entry(const std::filesystem::path& p) {
  if (std::filesystem::is_directory(p)) {  // a DICOM series: its files, in name order
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::directory_iterator(p))
      if (e.is_regular_file()) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    std::uintmax_t bytes = 0;
    std::uint64_t hash = 14695981039346656037ull;  // FNV-1a over the files' own hashes
    for (const auto& f : files) {
      bytes += std::filesystem::file_size(f);
      const std::uint64_t h = file_hash(f);
      for (int b = 0; b < 8; ++b) hash = (hash ^ ((h >> (8 * b)) & 0xff)) * 1099511628211ull;
    }
    return {{"path", std::filesystem::absolute(p).string()},
            {"files", files.size()},
            {"bytes", bytes},
            {"fnv1a64", std::to_string(hash)}};
  }
  return {{"path", std::filesystem::absolute(p).string()},
          {"bytes", std::filesystem::file_size(p)},
          {"fnv1a64", std::to_string(file_hash(p))}};
}

/// What prepare reads: the labels (checked), their voxel counts, the MRA (over the labels) and
/// the notes on mended headers (the MRI, when given, only checked).
struct PrepareInputs {
  imaging::LabelVolume labels;
  std::array<std::int64_t, 256> label_voxels{};
  imaging::VolumeF mra;
  std::vector<std::string> header_notes;
};

PrepareInputs read_prepare_inputs(const PrepareOptions& o) {
  PrepareInputs in;
  in.labels = imaging::read_labels(o.labels);
  in.label_voxels = count_labels(in.labels);
  const imaging::LabelVolume& labels = in.labels;
  const std::array<std::int64_t, 256>& label_voxels = in.label_voxels;
  verify_labels(o.labels, labels, label_voxels);
  // Headers whose direction matrix is orthonormal only to single precision are mended on reading;
  // model.json → header_notes says which and by how much.
  std::vector<std::string>& header_notes = in.header_notes;
  std::string note;
  in.mra = imaging::read_volume(o.mra, &note);
  const imaging::VolumeF& mra = in.mra;
  if (!note.empty()) header_notes.push_back(o.mra.string() + ": " + note);
  BS_VERIFY(mra.components == 1,
            o.mra.string() << ": expected a scalar image, got " << mra.components << " components");
  {
    Vector3d lo, hi;
    grid_bounds(labels.geometry, lo, hi);
    BS_VERIFY(
        grid_overlaps(mra.geometry, lo, hi, 0.0),
        o.mra.string() << ": does not overlap the label volume (different patient or frame?)");
  }
  if (o.mri) {
    note.clear();
    (void)imaging::read_volume(*o.mri, &note);  // readable and sane
    if (!note.empty()) header_notes.push_back(o.mri->string() + ": " + note);
  }
  return in;
}

/// The default scene: what prepare measured (its files, the craniotomy), every option at the
/// library's default (`brainshift options`); the user's --scene-options merged over it (RFC 7386).
nlohmann::json model_scene(const PrepareOptions& o, const nlohmann::json& default_fixed,
                           const nlohmann::json& default_craniotomy, bool vessels) {
  nlohmann::json scene = {{"version", 1},
                          {"mesh", "mesh.vtu"},
                          {"fixed", default_fixed},
                          {"collision_surface", "surface.vtp"},
                          {"craniotomy", default_craniotomy}};
  if (vessels) scene["vessels"] = "vessels.vtp";
  if (o.scene_options) {
    std::ifstream in(*o.scene_options);
    BS_VERIFY(in.good(), o.scene_options->string() << ": cannot open");
    try {
      const nlohmann::json patch = nlohmann::json::parse(in);
      // A fixed region given replaces prepare's: 'nodes' and 'below' are alternatives, and a
      // merge would keep prepare's 'nodes' beside the user's 'below'.
      if (patch.is_object() && patch.contains("fixed") && patch["fixed"].is_object())
        scene.erase("fixed");
      scene.merge_patch(patch);
    } catch (const nlohmann::json::parse_error& e) {
      BS_VERIFY(false, o.scene_options->string() << ": not valid JSON (at byte " << e.byte << ")");
    } catch (const nlohmann::json::exception&) {  // e.g. a number beyond double's range
      BS_VERIFY(false, o.scene_options->string() << ": not valid JSON (a number out of range)");
    }
  }
  return scene;
}

/// The collision surface (wrapped where the boundary is non-manifold), the default fixed region
/// and craniotomy of a meshed brain, with what was done said on `progress`.
struct SurfaceAndRegions {
  imaging::CollisionSurfaceOptions surface_options;
  imaging::CollisionSurface collision;
  imaging::FixedRegion fixed;
  imaging::Craniotomy craniotomy;
  double seconds = 0;  ///< the collision surface's
};

SurfaceAndRegions surface_and_regions(const imaging::MeshingResult& meshed, const PrepareOptions& o,
                                      const Progress& progress) {
  const core::TetMesh& mesh = meshed.mesh;
  SurfaceAndRegions r;
  const core::Stopwatch surface_watch;
  progress.stage("collision surface, fixed region and craniotomy (" +
                 std::to_string(mesh.num_nodes()) + " nodes, " + std::to_string(mesh.num_tets()) +
                 " tetrahedra)");
  const imaging::MeshSurface outer = imaging::outer_boundary_surface(mesh);
  imaging::CollisionSurfaceOptions& surface_options = r.surface_options;
  surface_options.target_vertices = o.surface_vertices;
  r.collision = imaging::make_collision_surface(mesh, outer, surface_options);
  const imaging::CollisionSurface& collision = r.collision;
  const core::SurfaceMesh& surface = collision.surface;
  r.seconds = surface_watch.seconds();
  if (collision.wrapped)
    progress.stage(
        "the mesh boundary is non-manifold at " + std::to_string(collision.non_manifold_edges) +
        " edges and " + std::to_string(collision.non_manifold_vertices) +
        " vertices (thin parts touching): wrapped (alpha " + mm(surface_options.wrap_alpha_mm) +
        " mm) and decimated to " + std::to_string(surface.vertices.rows()) + " vertices");
  if (collision.moved_vertices > 0)
    progress.stage(std::to_string(collision.moved_vertices) +
                   " collision-surface vertices were up to " + mm(collision.max_outside_mm) +
                   " mm outside the mesh: moved onto it");
  r.fixed = imaging::default_fixed_region(outer);
  r.craniotomy = imaging::default_craniotomy(surface, mesh, meshed.tet_label);
  progress.stage("fixed region: " + std::to_string(r.fixed.nodes.size()) + " " + r.fixed.rule);
  progress.stage("craniotomy (default): " + r.craniotomy.rule);
  return r;
}

/// What --scene-options replaced is what the model uses: the manifest says so.
void note_scene_overrides(nlohmann::json& manifest, const nlohmann::json& scene,
                          const nlohmann::json& default_fixed,
                          const nlohmann::json& default_craniotomy) {
  const nlohmann::json none;
  if (scene.value("craniotomy", none) != default_craniotomy)
    manifest["craniotomy"] = {{"scene", scene.value("craniotomy", none)},
                              {"rule", "given by --scene-options"}};
  if (scene.value("fixed", none) != default_fixed)
    manifest["fixed"] = {{"scene", scene.value("fixed", none)},
                         {"rule", "given by --scene-options"}};
}

}  // namespace

PrepareResult prepare_model(const PrepareOptions& o, const Progress& progress) {
  verify_output_folder(o.out);
  const imaging::OutputLock lock(o.out);  // one run writes MODEL at a time
  // The scene options first: a typo must not cost a meshing run (and nothing is written).
  if (o.scene_options) workflow::check_scene_options(*o.scene_options);
  progress.stage("reading the label volume");
  const PrepareInputs inputs = read_prepare_inputs(o);
  const imaging::LabelVolume& labels = inputs.labels;
  const std::array<std::int64_t, 256>& label_voxels = inputs.label_voxels;
  const imaging::VolumeF& mra = inputs.mra;
  const std::vector<std::string>& header_notes = inputs.header_notes;
  std::vector<std::string> warnings;
  const auto warn = [&](const std::string& w) {
    warnings.push_back(w);
    progress.stage("warning: " + w);
  };

  progress.stage("meshing the labels (CGAL)");
  const imaging::MeshingOptions meshing = o.mesh_refinement == 1.0
                                              ? imaging::MeshingOptions::coarse()
                                              : imaging::MeshingOptions::refined(o.mesh_refinement);
  imaging::MeshingResult meshed;
  try {
    meshed = imaging::mesh_labels(labels, meshing);
  } catch (const Error& e) {
    BS_THROW(o.labels.string() << ": " << e.what());
  }
  const core::TetMesh& mesh = meshed.mesh;
  const double t_mesh = progress.seconds();
  const SurfaceAndRegions regions = surface_and_regions(meshed, o, progress);
  const imaging::CollisionSurfaceOptions& surface_options = regions.surface_options;
  const imaging::CollisionSurface& collision = regions.collision;
  const core::SurfaceMesh& surface = collision.surface;
  const double t_surface = regions.seconds;
  const imaging::FixedRegion& fixed = regions.fixed;
  const imaging::Craniotomy& craniotomy = regions.craniotomy;

  const imaging::SkeletonFit fit = mra_vessels(o.mra, mra, mesh, progress, warn);
  const imaging::VesselGraph& skeleton = fit.graph;

  // Default scene: what prepare measured (its files, the craniotomy); every option at the
  // library's default (`brainshift options`). The user's options merged over it (RFC 7386).
  const nlohmann::json default_fixed = {{"nodes", "fixed.csv"}};
  const nlohmann::json default_craniotomy = {{"centre_mm", vector_json(craniotomy.centre)},
                                             {"radius_mm", craniotomy.radius_mm}};
  const nlohmann::json scene =
      model_scene(o, default_fixed, default_craniotomy, !skeleton.branches.empty());
  nlohmann::json manifest = {
      {"format", model_format},
      {"version", model_version},
      {"preop_grid", grid_to_json(labels.geometry)},
      {"inputs", {{"labels", input_entry(o.labels)}, {"mra", input_entry(o.mra)}}},
      {"labels_ml",
       {{"brain", double(label_voxels[1]) * labels.geometry.spacing.prod() / 1000.0},
        {"tumour", double(label_voxels[2]) * labels.geometry.spacing.prod() / 1000.0},
        {"ventricles", double(label_voxels[3]) * labels.geometry.spacing.prod() / 1000.0}}},
      {"mesh",
       {{"nodes", mesh.num_nodes()},
        {"tets", mesh.num_tets()},
        {"volume_ml", mesh_ml(mesh)},
        {"min_dihedral_deg", meshed.quality.min_dihedral_deg},
        {"seconds", meshed.seconds}}},
      {"materials", materials_json(meshing, meshed.tet_label)},
      {"surface", surface_json(collision, surface_options)},
      {"fixed", fixed_json(fixed)},
      {"craniotomy", craniotomy_json(craniotomy)},
      {"vessels", vessels_json(fit)},
      {"warnings", warnings},
      {"header_notes", header_notes}};
  if (o.mri) manifest["inputs"]["mri"] = input_entry(*o.mri);
  note_scene_overrides(manifest, scene, default_fixed, default_craniotomy);

  progress.stage("writing the model");
  std::size_t fixed_nodes = fixed.nodes.size();
  write_folder_atomically(o.out, [&](const std::filesystem::path& dir) {
    imaging::write_tet_mesh(dir / "mesh.vtu", mesh);
    imaging::write_surface_vtp(dir / "surface.vtp", surface);
    if (!skeleton.branches.empty()) imaging::write_skeleton_vtp(dir / "vessels.vtp", skeleton);
    imaging::write_node_list(dir / "fixed.csv", fixed.nodes);
    std::ofstream(dir / "scene.json") << scene.dump(2) << '\n';
    std::ofstream(dir / "model.json") << manifest.dump(2) << '\n';
    LoadedModel loaded;
    try {  // the merged scene must be valid now, not at registration time
      loaded = load_model(dir);
    } catch (const Error& e) {
      BS_VERIFY(false, (o.scene_options ? o.scene_options->string() : std::string("scene"))
                           << ": " << e.what());
    }
    // The intra-operative fast path: factorise K0 and precompute the compliance block now,
    // once, and keep the block (register adopts it after checking it belongs to this model).
    progress.stage("factorising the stiffness and precomputing the compliance block");
    const auto& sc = loaded.scene;
    // fixed.csv holds the nodes the model is fixed at, also when the scene chose them.
    if (sc.fixed_nodes != fixed.nodes) {
      imaging::write_node_list(dir / "fixed.csv", sc.fixed_nodes);
      progress.stage("fixed region: " + std::to_string(sc.fixed_nodes.size()) +
                     " nodes, given by --scene-options (in place of the rule above)");
    }
    fixed_nodes = sc.fixed_nodes.size();
    constraints::RegistrationModel model(sc.mesh, sc.fixed_nodes, sc.skeleton, sc.surface,
                                         sc.compliance);
    const auto& op = model.mechanics().compliance();
    nlohmann::json cache = {{"strategy", constraints::to_string(op.strategy())},
                            {"block_nodes", op.block_nodes().size()},
                            {"seconds", model.seconds_prepare()}};
    if (op.strategy() == constraints::ComplianceStrategy::DENSE_BLOCK) {
      workflow::write_compliance_cache(dir / compliance_cache_file, op.block());
      cache["file"] = compliance_cache_file;
      cache["bytes"] = std::filesystem::file_size(dir / compliance_cache_file);
    }
    manifest["compliance"] = cache;
    manifest["seconds"] = {
        {"mesh", t_mesh}, {"collision_surface", t_surface}, {"total", progress.seconds()}};
    std::ofstream(dir / "model.json") << manifest.dump(2) << '\n';
  });
  PrepareResult result;
  result.nodes = mesh.num_nodes();
  result.tets = mesh.num_tets();
  result.surface_vertices = static_cast<index_t>(surface.vertices.rows());
  result.fixed_nodes = fixed_nodes;
  result.vessel_branches = skeleton.branches.size();
  result.vessel_length_mm = skeleton.total_length();
  result.vessel_points_snapped = fit.snapped;
  result.vessel_points_dropped = fit.dropped;
  result.warnings = warnings;
  result.seconds = progress.seconds();
  return result;
}

}  // namespace brainshift::workflow
