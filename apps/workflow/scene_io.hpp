#pragma once
/// @file
/// @brief The registration scene (issue 4 item 1): a JSON file naming the model's files and
/// which constraint sets exist, with the solver settings. Only what the scene names is built.
/// Paths inside are relative to the scene file's folder (or absolute). Units: mm, kPa; world
/// RAS frame. Every key is optional except `mesh`; unknown keys are errors (a typo must not
/// silently fall back to a default), and so is the old spelling `center` (it says `centre`).
///
/// Every registration option can be set: the keys, their ranges and defaults are the tables
/// next to the Options structs (`visit_fields`, core/option_fields.hpp), read and written by
/// options_json.hpp. The groups: constraints, craniotomy (DuraOptions), rigid (RigidInitOptions
/// and `enabled`), global_start, shift_search, pairing, filter.vessels / filter.footprint
/// (FilterOptions), solver (StepOptions, PgsOptions as pgs_*, ComplianceOptions as compliance_*,
/// the iteration caps), noise (NoiseOptions), acceptance, uncertainty (UncertaintyOptions: the
/// predicted error's, e.g. the stated tracking accuracy). `options_to_json()` lists them all.
///
/// ```json
/// {
///   "version": 1,
///   "mesh": "mesh.vtu",
///   "materials": {"youngs_modulus_kpa": 1.5, "poisson_ratio": 0.45},
///   "fixed": {"nodes": "fixed.csv"}  or  {"below": {"direction": [0, 0, -1], "height_mm": 15}},
///   "collision_surface": "surface.vtp",
///   "vessels": "vessels.vtp",
///   "craniotomy": {"centre_mm": [0, 0, 50], "radius_mm": 30},
///   "constraints": {"vessels": true, "footprint": true, "dura": "none|sliding|unilateral",
///                   "landmarks": true},
///   "rigid": {"enabled": true, "loss": "huber|cauchy|none", "loss_scale_mm": 2.0,
///             "max_pair_distance_mm": 20.0},
///   "global_start": {"max_translation_mm": 25, "max_rotation_deg": 5, "bulk_response": true},
///   "shift_search": {"enabled": true, "radius_mm": 20, "stage_iterations": 40},
///   "pairing": {"max_distance_mm": 15.0, "direction_radius_mm": 5.0, "refine_distance_mm": 2},
///   "filter": {"vessels": {"one_per_feature": true, "median_threshold_mm": 5.0,
///                          "min_distance_mm": 0.0, "max_angle_deg": 45.0, "max_per_tet": 2},
///              "footprint": {...same keys...}},
///   "solver": {"max_iterations": 80, "increment_tolerance_mm": 0.01, "trust_region_mm": 5.0,
///              "pgs_tolerance": 1e-4, "pgs_max_iterations": 500,
///              "constraint_solver": "auto|active_set|gauss_seidel",
///              "mechanics": "warped|unwarped|linear|exact",
///              "compliance": {"vessels": 0.2, "footprint": 0.0, "dura": 0.2, "landmarks": 0.0},
///              "compliance_budget_mib": 512},
///   "noise": {"enabled": false, "criterion": "block_cv|gcv"},
///   "acceptance": {"min_vessel_pairs": 20, "max_scatter_mm": 3.0},
///   "uncertainty": {"tracking_translation_mm": 0, "tracking_rotation_deg": 0}
/// }
/// ```

#include "constraints/registration/registration.hpp"
#include "core/mesh/tet_mesh.hpp"

#include <filesystem>
#include <set>
#include <string>
#include <vector>

namespace brainshift::workflow {

/// A scene read from disk: the model's parts and the registration settings.
struct Scene {
  core::TetMesh mesh;
  std::vector<index_t> fixed_nodes;
  core::Skeleton skeleton;    ///< empty when the scene names no vessels
  core::SurfaceMesh surface;  ///< empty when the scene names no collision surface
  constraints::RegistrationOptions options;
  constraints::ComplianceOptions compliance;
};

/// Reads and validates a scene file and the files it names.
/// \throws brainshift::Error, one line naming the scene file and the key: unknown key (with the
/// known ones), wrong type, value out of range, a missing or unreadable referenced file (with
/// that file's own error), no fixed nodes.
Scene read_scene(const std::filesystem::path& path);

/// The scene's top-level keys that hold options (constraints, craniotomy, rigid, solver, ...).
std::set<std::string> scene_option_keys();

/// Checks a JSON file of option overrides (`prepare --scene-options`): every key and value it
/// holds must be a scene key (a file name such as `mesh` is allowed) or a valid option.
/// \throws brainshift::Error, one line naming the file and the key: unreadable file, invalid
/// JSON, unknown key (with the known keys of that object), wrong type, out of range.
void check_scene_options(const std::filesystem::path& path);

/// Nodes within `height_mm` of the lowest node along `direction` (pointing down; need not be
/// unit): the default fixed (cerebellum-side) region.
std::vector<index_t> nodes_below(const core::TetMesh& mesh, const Vector3d& direction,
                                 double height_mm);

}  // namespace brainshift::workflow
