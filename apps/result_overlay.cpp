#include "result_overlay.hpp"

#include <cmath>

#include "imaging/overlay/overlay.hpp"

namespace brainshift::apps {

void write_result_overlay(const std::filesystem::path& path, const imaging::VolumeF* mri,
                          const imaging::VolumeF* warped, const imaging::VolumeF& displacement,
                          const constraints::IntraopData& data) {
  // The intra-operative points are in the intra-operative frame, as is the warped MRI.
  imaging::VolumeF magnitude;
  imaging::OverlayInput in;
  imaging::OverlayOptions o;
  if (mri && warped) {
    in.left = mri;
    in.right = warped;
  } else {
    magnitude = imaging::VolumeF(displacement.geometry);
    for (std::size_t v = 0; v < magnitude.data.size(); ++v)
      magnitude.data[v] = std::hypot(displacement.data[3 * v], displacement.data[3 * v + 1], displacement.data[3 * v + 2]);
    in.left = &magnitude;
    o.left_label = "displacement |u|";
  }
  const MatrixX3d& v = data.vessel_points;
  in.target = v.rows() > 0 ? Vector3d(v.colwise().mean().transpose())
                           : displacement.geometry.index_to_world(0.5 * (displacement.geometry.size.cast<double>() -
                                                                         Vector3d::Ones()));
  if (v.rows() > 0) in.point_sets.push_back({v, {0, 255, 0}});
  if (data.footprint_points.rows() > 0) in.point_sets.push_back({data.footprint_points, {255, 255, 0}});
  imaging::write_overlay_png(path, in, o);
}

}  // namespace brainshift::apps
