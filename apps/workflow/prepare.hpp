#pragma once
/// @file
/// @brief Prepare: the pre-operative model from a label volume and an MRA — mesh (CGAL),
/// decimated collision surface, fixed region, craniotomy, vessel skeleton, scene — written as a
/// MODEL folder (model_folder.hpp), with the compliance block precomputed (compliance_cache.hpp).
/// The whole pipeline of `brainshift prepare` and the Slicer module BrainshiftPrepare. Inputs
/// share one world frame (RAS, mm).

#include "apps/workflow/progress.hpp"
#include "core/config.hpp"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace brainshift::workflow {

/// The inputs and settings of prepare (the flags of `brainshift prepare`).
struct PrepareOptions {
  std::filesystem::path labels;                        ///< 0 bg, 1 brain, 2 tumour, 3 ventricles
  std::filesystem::path mra;                           ///< MR angiogram, same patient and frame
  std::optional<std::filesystem::path> mri;            ///< recorded in the manifest (grid, hash)
  std::optional<std::filesystem::path> scene_options;  ///< JSON merged over the default scene
  std::filesystem::path out;                           ///< MODEL folder (replaced atomically)
  double mesh_refinement = 1.0;  ///< 1 ≈ 1.6k nodes (phantom); grows ≈ r^2.7
  int surface_vertices = 300;    ///< decimated collision surface
};

/// What prepare built (the full account is MODEL/model.json).
struct PrepareResult {
  index_t nodes = 0;                  ///< mesh nodes
  index_t tets = 0;                   ///< mesh tetrahedra
  index_t surface_vertices = 0;       ///< collision-surface vertices
  std::size_t fixed_nodes = 0;        ///< nodes of the fixed region
  std::size_t vessel_branches = 0;    ///< branches of the kept vessel skeleton
  double vessel_length_mm = 0.0;      ///< their total length, mm
  index_t vessel_points_snapped = 0;  ///< vessel points moved onto the mesh (≤ 5 mm outside)
  index_t vessel_points_dropped = 0;  ///< vessel points dropped (farther out, or alone)
  std::vector<std::string> warnings;  ///< weak inputs (also in model.json → warnings)
  double seconds = 0.0;               ///< wall time of the whole prepare, s
};

/// Builds and writes the model; progress stages go to `progress`.
/// \throws brainshift::Error, one line naming the file, for any bad input (nothing is written
/// then).
PrepareResult prepare_model(const PrepareOptions& o, const Progress& progress);

}  // namespace brainshift::workflow
