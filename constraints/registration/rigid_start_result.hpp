#pragma once
/// @file
/// @brief The rigid part of the registration's start, as the loop and the report see it
/// (RegistrationResult::rigid, report.json `rigid`). Positions in mm, world (RAS) frame.

#include "core/config.hpp"

#include <string>

namespace brainshift::constraints {

/// The start's rigid pose. Numbers are always finite.
struct RigidStartResult {
  /// Maps intra-operative points into the pre-operative frame: p_pre ≈ transform · p_intra.
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  int iterations = 0;          ///< refinement rounds of the global start
  bool converged = false;      ///< the pose was accepted (or given, or warm-started)
  std::string stop_reason;     ///< how the pose was obtained, or why none was
  double rms_before_mm = 0.0;  ///< RMS point-to-feature distance of the pairs at the identity
  double rms_after_mm = 0.0;   ///< same at the final transform (outliers included)
  index_t pairs_used = 0;      ///< vessel pairs of the refinement's last round
  std::string weak_dofs;       ///< weakly determined directions, e.g. "rotation about (0, 0, 1)";
                               ///< empty when none was found
};

}  // namespace brainshift::constraints
