#include "apps/workflow/result_overlay.hpp"

#include "imaging/overlay/overlay.hpp"

#include <cmath>
#include <future>

namespace brainshift::workflow {

void write_result_overlay(const std::filesystem::path& path, const imaging::VolumeF* mri,
                          const imaging::VolumeF* warped, const imaging::VolumeF& displacement,
                          const constraints::IntraopData& data,
                          const imaging::VolumeF* uncertainty) {
  // The intra-operative points are in the intra-operative frame, as is the warped MRI.
  imaging::VolumeF magnitude;
  imaging::OverlayInput in;
  imaging::OverlayOptions o;
  const MatrixX3d& v = data.vessel_points;
  in.target = v.rows() > 0
                  ? Vector3d(v.colwise().mean().transpose())
                  : displacement.geometry.index_to_world(
                        0.5 * (displacement.geometry.size.cast<double>() - Vector3d::Ones()));
  if (v.rows() > 0) in.point_sets.push_back({v, {0, 255, 0}});
  if (data.footprint_points.rows() > 0)
    in.point_sets.push_back({data.footprint_points, {255, 255, 0}});
  auto magnitude_panel = [&](imaging::OverlayInput& panel, imaging::OverlayOptions& opt) {
    magnitude = imaging::VolumeF(displacement.geometry);
    for (std::size_t k = 0; k < magnitude.data.size(); ++k)
      magnitude.data[k] = std::hypot(displacement.data[3 * k], displacement.data[3 * k + 1],
                                     displacement.data[3 * k + 2]);
    panel.left = &magnitude;
    opt.left_label = "displacement |u|";
    if (uncertainty) {
      panel.right = uncertainty;
      opt.right_label = "predicted error";
    }
  };
  if (mri && warped) {
    in.left = mri;
    in.right = warped;
    // The two images are independent: the predicted-error one on a second thread.
    std::future<void> second;
    if (uncertainty)
      second = std::async(std::launch::async, [&, u = in]() mutable {
        imaging::OverlayOptions uo;
        u.right = nullptr;
        magnitude_panel(u, uo);
        imaging::write_overlay_png(path.parent_path() / "overlay_uncertainty.png", u, uo);
      });
    imaging::write_overlay_png(path, in, o);
    if (second.valid()) second.get();
    return;
  }
  magnitude_panel(in, o);
  imaging::write_overlay_png(path, in, o);
}

}  // namespace brainshift::workflow
