#include "cmd_prepare.hpp"

#include <CLI/CLI.hpp>

#include <chrono>
#include <fstream>
#include <iostream>

#include "core/error.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/compliance_cache.hpp"
#include "core/mapping/tet_locator.hpp"
#include "imaging/io/csv.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/mesh_io.hpp"
#include "imaging/io/skeleton_io.hpp"
#include "imaging/io/surface_io.hpp"
#include "imaging/meshing/boundary_surface.hpp"
#include "imaging/meshing/decimate_surface.hpp"
#include "imaging/meshing/label_mesher.hpp"
#include "imaging/vessels/vessel_extraction.hpp"
#include "model_folder.hpp"
#include "progress.hpp"

namespace brainshift::apps {
namespace {

/// The parts of the skeleton that lie in the mesh (≤ 2 mm outside): each branch is cut into
/// runs of such points; runs of ≥ 2 points become branches.
imaging::VesselGraph inside_mesh(const imaging::VesselGraph& g, const core::TetMesh& mesh) {
  const core::TetLocator locator(mesh.nodes(), mesh.tets());
  imaging::VesselGraph out;
  auto add_node = [&out](const Vector3d& p, double r) {
    out.nodes.push_back({p, r});
    return static_cast<index_t>(out.nodes.size() - 1);
  };
  for (const auto& b : g.branches) {
    std::size_t i = 0;
    while (i < b.points.size()) {
      while (i < b.points.size() && !locator.locate(b.points[i], 1.5)) ++i;
      std::size_t j = i;
      while (j < b.points.size() && locator.locate(b.points[j], 1.5)) ++j;
      if (j - i >= 2) {
        imaging::VesselGraph::Branch nb;
        nb.points.assign(b.points.begin() + static_cast<std::ptrdiff_t>(i), b.points.begin() + static_cast<std::ptrdiff_t>(j));
        nb.radius.assign(b.radius.begin() + static_cast<std::ptrdiff_t>(i), b.radius.begin() + static_cast<std::ptrdiff_t>(j));
        nb.from = add_node(nb.points.front(), nb.radius.front());
        nb.to = add_node(nb.points.back(), nb.radius.back());
        out.branches.push_back(std::move(nb));
      }
      i = j;
    }
  }
  return out;
}

nlohmann::json input_entry(const std::filesystem::path& p) {
  return {{"path", std::filesystem::absolute(p).string()},
          {"bytes", std::filesystem::file_size(p)},
          {"fnv1a64", std::to_string(file_hash(p))}};
}

}  // namespace

CLI::App* add_prepare_command(CLI::App& app, PrepareArgs& args) {
  CLI::App* c = app.add_subcommand("prepare", "Pre-operative model: mesh, surface, vessels, scene (MODEL folder)");
  c->add_option("--labels", args.labels, "label volume: 0 background, 1 brain, 2 tumour, 3 ventricles")->required();
  c->add_option("--mra", args.mra, "MR angiogram in the same frame")->required();
  c->add_option("--mri", args.mri, "pre-operative MRI (recorded to check later inputs)");
  c->add_option("--scene-options", args.scene_options, "JSON merged over the default scene (see scene_io.hpp)");
  c->add_option("--refine", args.mesh_refinement, "mesh refinement (1 ≈ 1.6k nodes on the phantom; node count grows ≈ r^2.7)")
      ->check(CLI::Range(0.25, 6.0));
  c->add_option("--surface-vertices", args.surface_vertices, "collision surface size")->check(CLI::Range(20, 100000));
  c->add_option("--out", args.out, "MODEL folder to write")->required();
  return c;
}

int run_prepare(const PrepareArgs& args, std::ostream& out, const Progress::Sink& progress_sink) {
  const Progress progress("prepare", progress_sink);
  verify_output_folder(args.out);
  progress.stage("reading the label volume");
  const imaging::LabelVolume labels = imaging::read_labels(args.labels);
  std::int64_t brain = 0;
  for (auto v : labels.data) brain += v != 0;
  BS_VERIFY(brain > 0, args.labels.string() << ": no brain in it (every voxel is background, label 0)");
  const imaging::VolumeF mra = imaging::read_volume(args.mra);
  BS_VERIFY(mra.components == 1, args.mra.string() << ": expected a scalar image, got " << mra.components
                                                   << " components");
  {
    Vector3d lo, hi;
    grid_bounds(labels.geometry, lo, hi);
    BS_VERIFY(grid_overlaps(mra.geometry, lo, hi, 0.0),
              args.mra.string() << ": does not overlap the label volume (different patient or frame?)");
  }
  if (args.mri) (void)imaging::read_volume(*args.mri);  // readable and sane

  progress.stage("meshing the labels (CGAL)");
  const imaging::MeshingResult meshed = imaging::mesh_labels(
      labels, args.mesh_refinement == 1.0 ? imaging::MeshingOptions::coarse()
                                          : imaging::MeshingOptions::refined(args.mesh_refinement));
  const core::TetMesh& mesh = meshed.mesh;
  const imaging::MeshSurface outer = imaging::outer_boundary_surface(mesh);
  // A boundary where thin parts touch along an edge cannot be decimated (edge collapses need a
  // manifold); the full boundary is then the collision surface — slower to pair, same shape.
  const index_t non_manifold = imaging::count_non_manifold_edges(outer.surface);
  const constraints::SurfaceMesh surface =
      non_manifold ? outer.surface : imaging::decimate_surface(outer.surface, args.surface_vertices);
  if (non_manifold)
    progress.stage("warning: the boundary is non-manifold at " + std::to_string(non_manifold) +
                   " edges (thin parts touching); the collision surface is the full boundary (" +
                   std::to_string(outer.surface.vertices.rows()) + " vertices), not decimated");
  const std::vector<index_t> fixed = imaging::fixed_region_nodes(outer);

  progress.stage("extracting the vessels from the MRA");
  // An MRA is not speckled: without the pre-filter (meant for Doppler noise) thin vessels are
  // kept (phantom recall 0.97 vs 0.91 with it, precision unchanged).
  imaging::VesselExtractionOptions mra_options;
  mra_options.prefilter_sigma_mm = 0.0;
  const imaging::VesselExtractionResult vessels = imaging::extract_vessels(mra, mra_options);
  const imaging::VesselGraph skeleton =
      vessels.status == imaging::VesselStatus::OK ? inside_mesh(vessels.graph, mesh) : imaging::VesselGraph{};

  // Default scene, then the user's options merged over it (RFC 7386 merge patch).
  Eigen::Index top = 0;
  outer.surface.vertices.col(2).maxCoeff(&top);
  nlohmann::json scene = {
      {"version", 1},
      {"mesh", "mesh.vtu"},
      {"fixed", {{"nodes", "fixed.csv"}}},
      {"collision_surface", "surface.vtp"},
      {"craniotomy",
       {{"centre_mm", {outer.surface.vertices(top, 0), outer.surface.vertices(top, 1), outer.surface.vertices(top, 2)}},
        {"radius_mm", 30.0}}},
      {"constraints", {{"vessels", true}, {"footprint", true}, {"dura", "none"}, {"landmarks", false}}},
      {"rigid", {{"enabled", true}}}};
  if (!skeleton.branches.empty()) scene["vessels"] = "vessels.vtp";
  if (args.scene_options) {
    std::ifstream in(*args.scene_options);
    BS_VERIFY(in.good(), args.scene_options->string() << ": cannot open");
    try {
      scene.merge_patch(nlohmann::json::parse(in));
    } catch (const nlohmann::json::exception& e) {
      BS_VERIFY(false, args.scene_options->string() << ": not valid JSON (" << e.what() << ")");
    }
  }
  nlohmann::json manifest = {{"format", model_format},
                             {"version", model_version},
                             {"preop_grid", grid_to_json(labels.geometry)},
                             {"inputs", {{"labels", input_entry(args.labels)}, {"mra", input_entry(args.mra)}}},
                             {"mesh", {{"nodes", mesh.num_nodes()}, {"tets", mesh.num_tets()}}},
                             {"vessels", {{"branches", skeleton.branches.size()}, {"length_mm", skeleton.total_length()}}}};
  if (args.mri) manifest["inputs"]["mri"] = input_entry(*args.mri);

  progress.stage("writing the model");
  write_folder_atomically(args.out, [&](const std::filesystem::path& dir) {
    imaging::write_tet_mesh(dir / "mesh.vtu", mesh);
    imaging::write_surface_vtp(dir / "surface.vtp", surface);
    if (!skeleton.branches.empty()) imaging::write_skeleton_vtp(dir / "vessels.vtp", skeleton);
    imaging::write_node_list(dir / "fixed.csv", fixed);
    std::ofstream(dir / "scene.json") << scene.dump(2) << '\n';
    std::ofstream(dir / "model.json") << manifest.dump(2) << '\n';
    LoadedModel loaded;
    try {  // the merged scene must be valid now, not at registration time
      loaded = load_model(dir);
    } catch (const Error& e) {
      BS_VERIFY(false, (args.scene_options ? args.scene_options->string() : std::string("scene"))
                           << ": " << e.what());
    }
    // The intra-operative fast path: factorise K0 and precompute the compliance block now,
    // once, and keep the block (register adopts it after checking it belongs to this model).
    progress.stage("factorising the stiffness and precomputing the compliance block");
    const auto& sc = loaded.scene;
    constraints::RegistrationModel model(sc.mesh, sc.fixed_nodes, sc.skeleton, sc.surface, sc.compliance);
    const auto& op = model.mechanics().compliance();
    nlohmann::json cache = {{"strategy", constraints::to_string(op.strategy())},
                            {"block_nodes", op.block_nodes().size()},
                            {"seconds", model.seconds_prepare()}};
    if (op.strategy() == constraints::ComplianceStrategy::DENSE_BLOCK) {
      imaging::write_compliance_cache(dir / compliance_cache_file, op.block());
      cache["file"] = compliance_cache_file;
      cache["bytes"] = std::filesystem::file_size(dir / compliance_cache_file);
    }
    manifest["compliance"] = cache;
    std::ofstream(dir / "model.json") << manifest.dump(2) << '\n';
  });
  out << "prepared " << args.out.string() << ": " << mesh.num_nodes() << " nodes, " << mesh.num_tets()
      << " tetrahedra, " << surface.vertices.rows() << " surface vertices, " << fixed.size() << " fixed nodes, "
      << skeleton.branches.size() << " vessel branches (" << static_cast<int>(skeleton.total_length())
      << " mm) in " << progress.seconds() << " s\n";
  if (vessels.status != imaging::VesselStatus::OK)
    out << "warning: no vessels in the MRA (" << vessels.message << "); registration will need footprint data\n";
  return 0;
}

}  // namespace brainshift::apps
