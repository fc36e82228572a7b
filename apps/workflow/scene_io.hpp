#pragma once
/// @file
/// @brief The registration scene: a JSON file naming the model's files (what `prepare` made and
/// measured) and, optionally, registration options. Paths inside are relative to the scene
/// file's folder (or absolute). Units: mm, kPa; world RAS frame. Every key is optional except
/// `mesh`; unknown keys are errors (a typo must not silently fall back to a default), and so is
/// the old spelling `center` (it says `centre`); keys of earlier versions that are no longer
/// options say so (options_json.cpp), and `rigid.enabled` is still read as `start`.
///
/// The option keys, their ranges and defaults are the tables next to the Options structs
/// (`visit_fields`, core/option_fields.hpp), read and written by options_json.hpp; a key left
/// out is the library's default. `brainshift options` lists them (docs/OPTIONS.md).
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
///   "start": "rigid|identity",
///   "constraints": {"vessels": true, "footprint": true, "dura": "none|sliding|unilateral"},
///   "solver": {"max_iterations": 80, "pgs_tolerance": 1e-4, "compliance": {"vessels": 0.2}},
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
