#pragma once
/// @file
/// @brief The global start's refinement terms (global_start.cpp, step 3): the point-to-line
/// residual of a pose and bulk shift, the Gaussian priors of the navigation's accuracy and of the
/// sag, and their weights. Internal to the global start (namespace detail). Millimetres and
/// radians, model frame.

#include "constraints/registration/start/global_start.hpp"

#include <ceres/rotation.h>

#include <cmath>

namespace brainshift::constraints::detail {

/// The lever of the navigation's rotation prior (mm): a rotation of a / kNavigationLeverMm rad
/// costs as much as a translation of a. RESECT's 22 navigation offsets: RMS 6.6 mm and 7.3°
/// (0.127 rad), so 52 mm (GlobalStartOptions::navigation_accuracy_mm).
constexpr double kNavigationLeverMm = 52.0;
/// The sag's prior with a navigation prior (RMS length, mm): brain shift after the dura is opened
/// is 5–25 mm (seed 002 and the phantoms' cases alike), so 15 mm. Near the probe a sag and a
/// translation move the points alike, and the split between them is the ratio of the priors'
/// variances (global_start.hpp).
constexpr double kSagPriorMm = 15.0;

/// Point-to-line residual P (R(w)(p − c) + t + (c − q) − B s).
struct LineResidual {
  Vector3d pc, cq;
  Matrix3d P, B;
  template <typename T>
  bool operator()(const T* w, const T* t, const T* s, T* r) const {
    const T p[3] = {T(pc.x()), T(pc.y()), T(pc.z())};
    T rp[3];
    ceres::AngleAxisRotatePoint(w, p, rp);
    T d[3];
    for (int i = 0; i < 3; ++i)
      d[i] = rp[i] + t[i] + T(cq[i]) - (T(B(i, 0)) * s[0] + T(B(i, 1)) * s[1] + T(B(i, 2)) * s[2]);
    for (int i = 0; i < 3; ++i) r[i] = T(P(i, 0)) * d[0] + T(P(i, 1)) * d[1] + T(P(i, 2)) * d[2];
    return true;
  }
};

/// Gaussian prior on one parameter block of three: r = k x (k = σ_data / σ per axis).
struct Prior {
  double k;
  template <typename T>
  bool operator()(const T* x, T* r) const {
    for (int i = 0; i < 3; ++i) r[i] = T(k) * x[i];
    return true;
  }
};

/// The priors' weights k = loss_scale_mm / σ per axis of the translation, the rotation (rad) and
/// the bulk shift (global_start.hpp, step 3). With a navigation prior (`map`): Gaussian priors
/// on all three, the bulk shift's of RMS length kSagPriorMm, and candidates compared by their
/// posterior. Without (a free pose): no prior on the pose, the bulk shift's weight grows with the
/// pairs (bulk_prior_mm, applied in refine()) and candidates compared by their data score.
struct PriorWeights {
  double t = 0, w = 0, s = 0;
  bool map = false;
  explicit PriorWeights(const GlobalStartOptions& o) {
    const double a = o.navigation_accuracy_mm / std::sqrt(3.0);
    if (!(a > 0)) return;
    map = true;
    t = o.loss_scale_mm / a;
    w = o.loss_scale_mm / (a / kNavigationLeverMm);
    s = o.loss_scale_mm / (kSagPriorMm / std::sqrt(3.0));
  }
  /// The priors' cost in the units of the fine score: a point at a small distance d loses
  /// d²/τ² of its kernel, and costs d²/loss² in the data's units. 0 without a navigation prior.
  [[nodiscard]] double penalty(const Vector3d& pt, const Vector3d& pw, const Vector3d& ps,
                               double fine_kernel_mm) const {
    const double r2 =
        t * t * pt.squaredNorm() + w * w * pw.squaredNorm() + s * s * ps.squaredNorm();
    return r2 / (fine_kernel_mm * fine_kernel_mm);
  }
};

}  // namespace brainshift::constraints::detail
