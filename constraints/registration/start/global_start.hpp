#pragma once
/// @file
/// @brief Global start of the registration: the rigid pose (rotation and
/// translation) of the intra-operative vessel points relative to the pre-operative skeleton, plus
/// the amplitude of the model's bulk response, found by an exhaustive search that a dense tree
/// cannot fool, then refined locally. Positions in mm, world (RAS) frame; angles in degrees.
///
/// Pose. Point i of the intra-operative points p (#N×3, tracked frame) is placed in the model
/// frame at xᵢ = R (pᵢ − c) + c + t, with c the centroid of the points; with a basis Bᵢ (the
/// model's response to a uniform load at the point, normalised to I on average; see load_basis)
/// it is compared with the rest skeleton at xᵢ − Bᵢ s: s is the bulk shift of a smooth
/// deformation, the rigid part maps the tracking frame into the model (`transform`).
///
/// Score. With d(x) the distance from x to the nearest skeleton segment and the truncated kernel
///   κ_τ(d) = max(0, 1 − d²/τ²),
/// a pose scores S = Σᵢ κ_τ(d(xᵢ)): a point farther than τ from every vessel (clutter, a vessel
/// missing on either side) adds nothing, so spurious points cannot pull the pose (kernel
/// correlation: Tsin & Kanade, ECCV 2004). d² is tabulated once per call on a grid
/// (`voxel_mm`), exactly near each segment and truncated at τ beyond.
///
/// Search, coarse to fine:
/// 1. coarse: every translation of a grid of step `coarse_step_mm` covering ±max_translation_mm
///    (one step more, so that a peak is never on the edge) × every rotation of a 3×3×3 grid of
///    rotation vectors (0 and ±⅔ max_rotation_deg about each axis), kernel τ = coarse_kernel_mm,
///    on at most `coarse_points` evenly spread points. Every candidate is scored: there is no
///    basin of attraction to fall out of, which is what fools ICP on a tree whose vessels are
///    closer together than the offset.
/// 2. the `candidates` best interior local maxima over the translation grid are rescored with
///    τ = fine_kernel_mm on up to `max_points` points, by coordinate ascent on a local grid (the
///    27 translations within half a step, the 7 rotations within half a rotation step, the
///    translations again).
/// 3. refinement of the best (and of up to two others within 10 % of its score): robust
///    point-to-line ICP with Ceres (Cauchy loss of scale loss_scale_mm; pairs within
///    refine_distance_mm), first over the rotation and translation, then — with a basis —
///    jointly with the bulk shift s, kept only when |s| ≥ bulk_min_mm (a smaller s would only
///    bias the rigid part it trades against). Without a navigation prior (the default) the pose
///    is free and a weak prior (s costs as much as moving every pair by loss_scale_mm when
///    |s| = bulk_prior_mm) keeps s small where the data cannot tell it from a translation. With
///    one (navigation_accuracy_mm > 0) both are maximum a posteriori: Gaussian priors on the pose
///    and on s (RMS 15 mm), the data's residuals of scale loss_scale_mm, and candidates compared
///    by the posterior. Where the data cannot tell a sag from a translation (Bᵢ ≈ I near the
///    probe) the priors decide: the sag explains the motion and the fixed base stays where the
///    navigation put it, unless the data demand a pose (reported: prior_z). The basis is evaluated
///    once, where the best searched pose puts the points. With the craniotomy's outward direction n
///    given (and bulk_sinks), n·s ≤ 0: the bulk response is a sag, the brain sinks away from the
///    opening. Near the probe a sag and a pose are nearly interchangeable, and without the bound
///    the fit can trade a sag for a larger pose plus a bulk shift out of the brain (the phantoms,
///    seed 3: 11.6 mm / 7.7° plus 3 mm upwards, where the truth is no offset and a 7 mm sag).
/// 4. decision by the data score: the pose is kept when its fine score beats the identity's by
///    `min_gain` and when the gain is significant across blocks of points (significance_z);
///    otherwise the identity is returned and the message says why. No motion cap.

#include "constraints/registration/start/bulk_search.hpp"
#include "constraints/registration/start/start_result.hpp"
#include "core/config.hpp"
#include "core/geometry/skeleton.hpp"
#include "core/option_fields.hpp"

#include <functional>
#include <string>
#include <vector>

namespace brainshift::core {
class TetMesh;
}

namespace brainshift::constraints {

/// RMS length of the 22 real navigation offsets of RESECT (mm): a value for
/// GlobalStartOptions::navigation_accuracy_mm measured on real surgeries.
inline constexpr double kResectNavigationAccuracyMm = 6.6;

/// Options of global_start(); defaults recover offsets up to 25 mm and 5°.
struct GlobalStartOptions {
  double max_translation_mm = 25.0;  ///< translations searched, per axis (mm)
  double max_rotation_deg = 5.0;     ///< rotations searched, per axis (degrees)
  double coarse_step_mm = 3.0;       ///< coarse translation grid (mm); ≤ coarse_kernel_mm
  double coarse_kernel_mm = 4.0;     ///< τ of the coarse search (mm)
  double fine_kernel_mm = 2.5;       ///< τ of the fine rescoring and of the final score (mm)
  double voxel_mm =
      1.0;  ///< distance table spacing (mm); grown when the table would exceed 4 M voxels
  int coarse_points = 100;  ///< points scored by the coarse search (evenly spread)
  int max_points = 500;     ///< points scored by the fine stage and the refinement
  int candidates = 8;       ///< local maxima of the coarse score rescored finely
  int min_points = 6;       ///< fewer vessel points: identity, not accepted
  /// Keep the pose only when its score > min_gain × the identity's: a pose that matches hardly
  /// more points than no motion (noise, a flat score along a single vessel) is not worth moving.
  double min_gain = 1.05;
  /// And only when the gain stands out of its own scatter: the fine points grouped in cubes of
  /// significance_block_mm (errors along a vessel are correlated within a block), the blocks'
  /// mean gain ≥ significance_z standard errors (one-sided ≈ 98 % at 2; 0: off). Fewer than
  /// four blocks are not tested. A pose that only tilts the points by a centreline bias gains
  /// little and unevenly; a navigation offset gains on every block.
  double significance_z = 2.0;
  double significance_block_mm = 10.0;
  double refine_distance_mm =
      3.0;                     ///< refinement pairs within this distance (mm); ≤ coarse_kernel_mm
  double loss_scale_mm = 1.0;  ///< Cauchy loss scale of the refinement (mm)
  int refine_iterations = 8;   ///< ICP rounds of the refinement (pair, then Ceres)
  int solver_iterations = 10;  ///< Levenberg–Marquardt iterations per round
  double convergence_mm = 0.01;  ///< stop the rounds when the pose moves less than this (mm)
  bool bulk_response = true;     ///< refine the bulk shift s too (needs a basis)
  /// The pose's prior: the navigation's error at the operative field, as the RMS length of a
  /// translation (mm); 0 (the default): no prior, a free pose. The prior is isotropic: per axis
  /// σ_t = a/√3 on the translation at the points' centroid, σ_w = (a / kNavigationLeverMm)/√3 rad
  /// on the rotation about it. What real surgeries show: RESECT's 22 patients (landmark pairs
  /// between the MRI and the ultrasound on the closed dura; ../shared/data/resect) have
  /// navigation offsets of 0.7–19.7 mm, RMS 6.6 mm (kResectNavigationAccuracyMm), and rotations
  /// of 1.5–13.8°, RMS 7.3° (1–3° of it the experts' localisation error); the lever (52 mm) is
  /// the ratio of the two. Stieglitz et al. (Neurosurgery 2013, 55 patients) measured
  /// 2.9 ± 3.3 mm after the patient registration and 1.3 ± 1.5 mm more by the end of draping
  /// and the craniotomy. Why the default is no prior: docs/BENCHMARKS.md, "The navigation prior"
  /// — a prior that real offsets allow lets the pose's rotation take the sag's tilt near the
  /// probe all the same, and costs the landmarks near the sweep on three phantom cases.
  double navigation_accuracy_mm = 0.0;
  /// Without a navigation prior: |s| that costs as much as loss_scale_mm at every pair (mm), a
  /// weak prior that keeps s small where the data cannot tell it from a translation. With one,
  /// the bulk shift has a Gaussian prior of RMS length 15 mm (the sag after opening is 5–25 mm)
  /// and this is not used.
  double bulk_prior_mm = 40.0;
  double bulk_min_mm = 1.0;  ///< a bulk shift below this is reported as not accepted (mm)
  /// The bulk shift is a sag: with an outward direction given (global_start's `outward`), its
  /// component along it is bounded above by 0 (the brain sinks away from the craniotomy; a bulge
  /// is left to the deformation loop). Without the bound, a sag seen near the probe is
  /// matched equally well by a larger pose plus a bulk shift *out* of the brain
  /// (docs/history/BENCHMARKS_NOTEBOOK.md, "Never worse than rigid, v7").
  bool bulk_sinks = true;
  /// Ambiguity (not scene keys: constants of the method). The pose is ambiguous when a searched
  /// pose that places the points at least ambiguity_distance_mm (RMS) away from the best one
  /// scores at least ambiguity_ratio of the best's fine score (two trees, or two parts of one,
  /// that the points match nearly equally well), or when the points' spread across their main
  /// axis is below min_spread_mm (points along one vessel: the rotation about it is not pinned).
  double ambiguity_ratio = 0.9;
  double ambiguity_distance_mm = 5.0;
  double min_spread_mm = 3.0;
  /// The bulk search when the pose is known (start_at_pose()); its scene keys are shift_search.*
  /// (RegistrationOptions' visit_fields), not global_start.*.
  BulkSearchOptions bulk_search;
  /// Empty when valid (bulk_search included), else what is wrong.
  [[nodiscard]] std::string validate() const;
};

/// The options' names, ranges and documentation (core/option_fields.hpp); in the scene under
/// global_start. The search grids, kernels, refinement settings and bulk_sinks are not scene
/// keys: constants of the method (library callers and the bench may set them).
template <class V>
void visit_fields(GlobalStartOptions& o, V&& v) {
  v("max_translation_mm", o.max_translation_mm, core::Range{0, 200},
    "translations searched, per axis (mm)");
  v("max_rotation_deg", o.max_rotation_deg, core::Range{0, 30},
    "rotations searched, per axis (degrees)");
  v("min_points", o.min_points, core::Range{3, 1e6},
    "fewer vessel points: the identity, not accepted");
  v("significance_z", o.significance_z, core::Range{0, 10},
    "a searched pose is kept only when its score gain over the identity is this many standard "
    "errors of the gain between 10 mm blocks of points (0: off)");
  v("bulk_response", o.bulk_response, "refine the bulk shift of the model's load response too");
  v("navigation_accuracy_mm", o.navigation_accuracy_mm, core::Range{0, 100},
    "the pose's prior: RMS error of the navigation at the operative field (mm; a rotation of "
    "this over 52 mm costs the same; 0: a free pose; RESECT's real offsets: 6.6)");
  v("bulk_prior_mm", o.bulk_prior_mm, core::Range{1e-6, 1e6},
    "prior scale of the bulk shift: a shift this large costs as much as the robust loss's scale "
    "at every pair (mm; without a navigation prior)");
}

/// The bulk-response basis at given model-frame points (#N×3 → N matrices 3×3, or empty).
using BasisAt = std::function<std::vector<Matrix3d>(ConstRef<MatrixX3d>)>;

/// Runs the global start; see the file doc.
/// @param[in] skeleton  pre-operative vessel skeleton (rest, model frame, mm)
/// @param[in] points    intra-operative vessel points (#N×3, tracked frame, mm)
/// @param[in] basis_at  the bulk basis at the points once placed by the best rigid pose; empty
///                      function (or options.bulk_response false): rigid only
/// @param[in] options   see GlobalStartOptions
/// @param[in] outward   the direction out of the brain at the craniotomy (model frame, any
///                      length): with options.bulk_sinks the bulk shift's component along it is
///                      ≤ 0. Zero: the bulk shift is not bounded.
/// @return the pose; identity with accepted = false and the reason when there are fewer than
///         min_points points, no segments, or no pose beats the identity.
/// \throws brainshift::Error when options.validate() fails or the inputs are not finite.
StartResult global_start(const core::Skeleton& skeleton, ConstRef<MatrixX3d> points,
                         const BasisAt& basis_at, const GlobalStartOptions& options,
                         const Vector3d& outward = Vector3d::Zero());
/// The start when the pose is known — a pre-dura sweep's (IntraopData::pose) or the identity
/// (start = identity): the points placed by `pose`, only the bulk shift is searched
/// (search_bulk_shift(), options.bulk_search), against the part of the skeleton within its
/// radius of the points, with the basis at the placed points (`basis_at`; empty function: a
/// translation).
/// @param[in] search whether to search the bulk shift (false: the pose alone, bulk_message empty)
/// @param[in] reason how the pose was obtained (StartResult::stop_reason)
/// @return transform = pose, converged, accepted false (the pose was not searched), the bulk part
/// as search_bulk_shift() gives it.
/// \throws brainshift::Error as search_bulk_shift().
StartResult start_at_pose(const core::Skeleton& skeleton, ConstRef<MatrixX3d> points,
                          const Eigen::Isometry3d& pose, const BasisAt& basis_at,
                          const GlobalStartOptions& options, bool search, std::string reason);

/// The 3×3 load response at a node of `response` (#N×3 nodal displacements per axis, mm):
/// column k is the node's displacement under a uniform load along axis k.
Matrix3d load_response_at(const std::array<MatrixX3d, 3>& response, Eigen::Index node);

/// The mean of load_response_at() over the rest nodes nearest each point (model frame, #P×3 mm):
/// load_basis()'s normalisation. Zero without points.
Matrix3d mean_load_response(const core::TetMesh& mesh, const std::array<MatrixX3d, 3>& response,
                            ConstRef<MatrixX3d> points);

/// Per point, the 3×3 response (column k: displacement under a uniform load along axis k) of the
/// linear model at the rest node nearest the point, normalised so that the mean over the points
/// is the identity. Empty when that mean is singular (points on fixed nodes).
/// @param[in] mesh rest mesh; @param[in] response #N×3 nodal displacements per axis (mm);
/// @param[in] points model-frame points (#P×3, mm).
std::vector<Matrix3d> load_basis(const core::TetMesh& mesh,
                                 const std::array<MatrixX3d, 3>& response,
                                 ConstRef<MatrixX3d> points);

}  // namespace brainshift::constraints
