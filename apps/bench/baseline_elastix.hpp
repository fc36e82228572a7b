#pragma once
/// @file
/// @brief elastix as the bench's image-registration peer: what a research
/// engineer tries first — Debian's `elastix` / `transformix` programs (never a dependency of the
/// product: the bench calls them as separate processes when they are installed), rigid then
/// B-spline, Mattes mutual information, the pre-operative MRA (moving) onto the intra-operative
/// power Doppler (fixed), the fixed image masked to the sweep (the B-mode's non-zero region on
/// the Doppler's grid, else the Doppler's). elastix's transform maps fixed (intra-operative)
/// points to moving (pre-operative) ones: transformix maps the truth's intra-operative points,
/// and the error is measured in the pre-operative frame, |T(p_intra) − p_pre| (mm). ITK works in
/// LPS: points are converted from and back to world RAS here.

#include "core/config.hpp"

#include <filesystem>
#include <string>

namespace brainshift::workflow {

/// The peer's settings (its parameter files are written from these).
struct ElastixOptions {
  int rigid_iterations = 500;     ///< per resolution
  int bspline_iterations = 500;   ///< per resolution
  int resolutions = 3;            ///< multi-resolution levels of each stage
  int samples = 4096;             ///< random spatial samples per iteration
  double grid_spacing_mm = 15.0;  ///< B-spline control-point spacing
  int threads = 2;
};

/// What one elastix run gives: the points mapped by the rigid stage alone and by rigid +
/// B-spline (#P×3 each, pre-operative frame, world RAS, mm), and its wall time.
struct ElastixResult {
  bool ok = false;
  std::string error;  ///< why not, one line
  MatrixX3d rigid, bspline;
  double seconds = 0.0;  ///< elastix and both transformix runs, wall
};

/// True when `elastix` and `transformix` are on the PATH.
bool elastix_available();

/// Registers `mra` (moving) onto `doppler` (fixed), masked with `bmode`'s swept region when it is
/// on the Doppler's grid, in `work` (created; kept), and maps `intra_points` (#P×3, the Doppler's
/// frame, world RAS, mm) through both stages. Never throws: a failure is ok = false and a reason.
ElastixResult elastix_register(const std::filesystem::path& mra,
                               const std::filesystem::path& doppler,
                               const std::filesystem::path& bmode, ConstRef<MatrixX3d> intra_points,
                               const std::filesystem::path& work, const ElastixOptions& options);

}  // namespace brainshift::workflow
