#pragma once
/// @file
/// @brief The MODEL folder written by `brainshift prepare` and read by `register` / `replay`:
///   scene.json      the registration scene (apps/workflow/scene_io.hpp): names the files below
///   mesh.vtu        tetrahedral mesh with per-element materials (mm, RAS)
///   surface.vtp     decimated collision surface (≈300 vertices; closed 2-manifold, also where the
///                   mesh boundary is not: then its alpha wrap is decimated)
///   vessels.vtp     pre-operative vessel skeleton from the MRA (polylines, `radius`), in the mesh:
///                   points up to 5 mm outside moved onto it, farther ones dropped
///   fixed.csv       fixed nodes: the part on the skull base (kFixedBaseFraction)
///   compliance.bin  cached compliance block K0⁻¹ on the constrained nodes
///                   (apps/workflow/compliance_cache.hpp); optional, checked before use
///   model.json      manifest: format name and version, the inputs (path, size, FNV-1a hash), the
///                   pre-operative image grid (to refuse images from another patient), and what
///                   prepare chose and found: `labels_ml`, `mesh`, `materials`, `surface` (how it
///                   was made), `fixed` and `craniotomy` (with the `rule` that chose them),
///                   `vessels` (`points`, `inside`, `snapped`, `dropped`, `snap_distance_mm`),
///                   `warnings`, `compliance`, `seconds`
/// The folder is written under a temporary name and renamed, so it is complete or absent.

#include "apps/workflow/scene_io.hpp"
#include "imaging/io/volume.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

namespace brainshift::workflow {

inline constexpr const char* model_format = "brainshift-model";
inline constexpr int model_version = 1;
inline constexpr const char* compliance_cache_file = "compliance.bin";

/// 64-bit FNV-1a hash of a file's bytes (identifies inputs; not cryptographic).
/// \throws brainshift::Error naming the file when it cannot be read.
std::uint64_t file_hash(const std::filesystem::path& path);

/// A model folder loaded for registration.
struct LoadedModel {
  workflow::Scene scene;
  imaging::ImageGeometry preop_grid;  ///< grid of the pre-operative label image
  nlohmann::json manifest;
};

/// Reads MODEL/model.json and MODEL/scene.json with the files it names.
/// \throws brainshift::Error, one line: not a model folder, another format or an older version
/// (with the fix: run prepare again), or any scene error.
LoadedModel load_model(const std::filesystem::path& dir);

/// JSON of an image grid (size, origin, spacing, direction) and back.
nlohmann::json grid_to_json(const imaging::ImageGeometry& g);
imaging::ImageGeometry grid_from_json(const nlohmann::json& j);

/// True when two grids are the same to 1e-3 mm / 1e-6 (same patient scan).
bool same_grid(const imaging::ImageGeometry& a, const imaging::ImageGeometry& b);

/// World bounding box [lo, hi] (mm) of a grid's voxel centres.
void grid_bounds(const imaging::ImageGeometry& g, Vector3d& lo, Vector3d& hi);

/// World bounding boxes (mm) of a grid's voxel centres intersect a box [lo, hi] enlarged by
/// `margin`.
bool grid_overlaps(const imaging::ImageGeometry& g, const Vector3d& lo, const Vector3d& hi,
                   double margin);

/// Checks, before long work, that the output folder `dir` can be created or replaced: its parent
/// exists and accepts new entries. \throws brainshift::Error naming `dir`.
void verify_output_folder(const std::filesystem::path& dir);

/// Creates `dir` complete or not at all: `fill` writes into a fresh temporary sibling folder,
/// which then replaces `dir` (an existing `dir` is removed only after the new one is complete).
/// \throws brainshift::Error naming `dir` when its parent does not exist or is not writable;
/// whatever `fill` throws (the temporary folder is removed).
void write_folder_atomically(const std::filesystem::path& dir,
                             const std::function<void(const std::filesystem::path&)>& fill);

}  // namespace brainshift::workflow
