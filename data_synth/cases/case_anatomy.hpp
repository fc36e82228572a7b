#pragma once
/// @file
/// @brief The anatomy a phantom case is generated on: the analytic ellipsoid of the named cases
/// (from CaseParameters::geometry) or a label volume (label_case.hpp). Everything the case
/// writer needs to know about it, in world RAS mm.

#include "data_synth/cases/case_catalog.hpp"
#include "data_synth/geometry/brain_shape.hpp"
#include "data_synth/geometry/phantom_mesh.hpp"
#include "data_synth/truth/tled_solver.hpp"
#include "imaging/io/volume.hpp"

#include <nlohmann/json.hpp>

#include <functional>
#include <optional>

namespace brainshift::data_synth {

struct CaseAnatomy {
  BrainShape shape;  ///< vessels, probe, landmarks, craniotomy statistics
  /// Rest label of a point for the intra-operative images (0 where the truth mesh covers a sulcus
  /// or a stair corner: rendered as brain).
  std::function<imaging::Label(const Vector3d&)> image_label;
  imaging::LabelVolume labels;  ///< the pre-operative labels written to preop/labels.nii.gz
  PhantomMesh mesh;             ///< the truth mesh (resection already applied)
  SkullContact contact;         ///< the skull (candidate nodes: mesh.surface_nodes)
  nlohmann::json geometry;      ///< the "geometry" block of case.json
  /// Only for the analytic phantom: a user vessel tree is placed into it (tree_graph.hpp).
  std::optional<PhantomGeometry> analytic;
};

/// The analytic phantom of the parameters (the named cases).
CaseAnatomy analytic_anatomy(const CaseParameters& parameters);

/// For a resection, the tumour elements of `mesh` become the soft compressible cavity.
void apply_resection(const CaseParameters& parameters, PhantomMesh& mesh);

}  // namespace brainshift::data_synth
