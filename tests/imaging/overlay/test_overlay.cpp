#include "expect_error.hpp"
#include "temp_folder.hpp"

#include "imaging/overlay/overlay.hpp"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>

namespace brainshift::imaging {
namespace {

using tests::expect_error;

/// 40 × 50 × 30 voxels of 1 mm, identity direction, voxel corners spanning exactly
/// R −20…20, A −25…25, S −15…15 mm.
ImageGeometry box_grid() {
  ImageGeometry g;
  g.size = Eigen::Vector3i(40, 50, 30);
  g.origin = Vector3d(-19.5, -24.5, -14.5);
  return g;
}

VolumeF make_volume(const ImageGeometry& g,
                    const std::function<float(int, int, int, const Vector3d&)>& f) {
  VolumeF v(g);
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i)
        v.at(i, j, k) = f(i, j, k, g.index_to_world(Vector3d(i, j, k)));
  return v;
}

/// Value = R index (0…39): a left-right ramp.
VolumeF ramp() {
  return make_volume(box_grid(), [](int i, int, int, const Vector3d&) { return float(i); });
}

cv::Mat read_png(const std::filesystem::path& path) {
  cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
  EXPECT_FALSE(image.empty()) << "cannot read " << path;
  return image;
}

/// Colour at image pixel (x, y) as (red, green, blue).
std::array<int, 3> rgb_at(const cv::Mat& image, int x, int y) {
  const cv::Vec3b p = image.at<cv::Vec3b>(y, x);
  return {p[2], p[1], p[0]};
}

TEST(Overlay, WritesAPngOfTheDocumentedSize) {
  const tests::TempFolder dir;
  const VolumeF pre = ramp(), warped = ramp();
  OverlayInput in;
  in.left = &pre;
  in.right = &warped;

  // Two volumes in columns: panels axial 40×50, coronal 40×30, sagittal 50×30 (1 mm pixels);
  // column width 50, row heights 16 + 50, 16 + 30, 16 + 30, gaps of 4 around and between.
  write_overlay_png(dir / "two.png", in);
  cv::Mat image = read_png(dir / "two.png");
  EXPECT_EQ(image.cols, 4 + 2 * (50 + 4));
  EXPECT_EQ(image.rows, 4 + (66 + 4) + (46 + 4) + (46 + 4));
  EXPECT_EQ(image.type(), CV_8UC3);
  EXPECT_EQ(dir.count(), 1u);  // no temporary left

  // One volume in a row, 2 mm pixels: panels 20×25, 20×15, 25×15.
  in.right = nullptr;
  OverlayOptions o;
  o.pixel_size_mm = 2.0;
  o.arrangement = OverlayArrangement::VOLUMES_IN_ROWS;
  write_overlay_png(dir / "one.png", in, o);
  image = read_png(dir / "one.png");
  EXPECT_EQ(image.cols, 4 + (20 + 4) + (20 + 4) + (25 + 4));
  EXPECT_EQ(image.rows, 4 + (16 + 25) + 4);
  const OverlayLayout layout = overlay_layout(in, o);
  EXPECT_EQ(layout.width, image.cols);
  EXPECT_EQ(layout.height, image.rows);
  EXPECT_EQ(layout.panel_origin[0][2],
            Eigen::Vector2i(4 + 24 + 24, 4 + 16));  // sagittal, third column
}

TEST(Overlay, WindowsToThePercentilesWithPatientRightOnTheScreenLeft) {
  const tests::TempFolder dir;
  const VolumeF v = ramp();  // values 0…39, each on 1,500 voxels: 1st percentile 0, 99th 39
  OverlayInput in;
  in.left = &v;
  OverlayOptions o;
  o.orientation_letters = false;
  write_overlay_png(dir / "o.png", in, o);
  const cv::Mat image = read_png(dir / "o.png");
  // Axial panel of the left volume at (4, 20). Panel column q has its centre at R = 20 − (q + ½),
  // i.e. voxel i = 39 − q: value 29 at q = 10, grey 255 · 29 / 39 = 189.6; ±1 for rounding.
  const auto c = rgb_at(image, 4 + 10, 20 + 25);
  EXPECT_NEAR(c[0], 190, 1);
  EXPECT_EQ(c[0], c[1]);
  EXPECT_EQ(c[1], c[2]);
  EXPECT_NEAR(rgb_at(image, 4 + 0, 20 + 25)[0], 255, 0);  // q = 0: the right-most voxel, i = 39
  EXPECT_NEAR(rgb_at(image, 4 + 39, 20 + 25)[0], 0, 0);   // q = 39: i = 0
}

TEST(Overlay, DrawsPointsInTheirColourOnTheSlicesTheyAreNear) {
  const tests::TempFolder dir;
  const VolumeF pre = ramp(), warped = ramp();
  OverlayInput in;
  in.left = &pre;
  in.right = &warped;
  in.target = Vector3d(0.0, 0.0, 0.0);
  // A pixel centre of the axial panel: R = 20 − 10.5, A = 25 − 29.5; 0.8 mm from the axial plane
  // (drawn, slab 1.5 mm), 4.5 mm from the coronal and 9.5 mm from the sagittal plane (not drawn).
  OverlayPoints yellow{MatrixX3d(2, 3), {255, 255, 0}};
  yellow.points << 9.5, -4.5, 0.8,  //
      -9.5, 4.5, 1.6;  // 1.6 mm from the axial plane (beyond the slab), 4.5 and 9.5 from the others
  in.point_sets.push_back(yellow);
  OverlayOptions o;
  o.orientation_letters = false;
  write_overlay_png(dir / "o.png", in, o);
  const cv::Mat image = read_png(dir / "o.png");
  const OverlayLayout layout = overlay_layout(in, o);

  // By hand: left axial panel at (4, 4 + 16), so the dot is centred at (4 + 10, 20 + 29).
  const std::array<int, 3> expected{255, 255, 0};
  EXPECT_EQ(rgb_at(image, 14, 49), expected);
  EXPECT_TRUE(layout.world_to_pixel(SliceView::AXIAL, 0, yellow.points.row(0).transpose())
                  .isApprox(Eigen::Vector2d(14, 49)));
  // Right column: the same point on the warped volume's axial panel (origin x = 4 + 50 + 4).
  EXPECT_EQ(rgb_at(image, 58 + 10, 49), expected);
  // Not drawn where it is farther than 1.5 mm from the plane: grey there (r = g = b).
  for (const SliceView view : {SliceView::CORONAL, SliceView::SAGITTAL}) {
    const Eigen::Vector2d xy = layout.world_to_pixel(view, 0, yellow.points.row(0).transpose());
    const auto c = rgb_at(image, int(std::lround(xy.x())), int(std::lround(xy.y())));
    EXPECT_TRUE(c[0] == c[1] && c[1] == c[2]) << "view " << int(view);
  }
  const Eigen::Vector2d far =
      layout.world_to_pixel(SliceView::AXIAL, 0, yellow.points.row(1).transpose());
  const auto c = rgb_at(image, int(std::lround(far.x())), int(std::lround(far.y())));
  EXPECT_TRUE(c[0] == c[1] && c[1] == c[2]);
}

/// Centroid (x, y) of the pixels with all channels ≥ 250 inside a panel, and how many there are.
std::pair<Eigen::Vector2d, int> bright_centroid(const cv::Mat& image, const Eigen::Vector2i& origin,
                                                const Eigen::Vector2i& size) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  int count = 0;
  for (int y = origin.y(); y < origin.y() + size.y(); ++y)
    for (int x = origin.x(); x < origin.x() + size.x(); ++x) {
      const auto c = rgb_at(image, x, y);
      if (c[0] >= 250 && c[1] >= 250 && c[2] >= 250) {
        sum += Eigen::Vector2d(x, y);
        ++count;
      }
    }
  return {count > 0 ? Eigen::Vector2d(sum / count) : Eigen::Vector2d::Constant(-1), count};
}

TEST(Overlay, ShowsABlobAtItsWorldPositionWhateverTheDirectionMatrix) {
  // Image axes: i → A, j → S, k → −R (a permuted, reflected grid, det −1), anisotropic voxels.
  ImageGeometry g;
  g.size = Eigen::Vector3i(50, 40, 36);
  g.spacing = Vector3d(1.0, 1.2, 0.9);
  g.direction << 0, 0, -1,  //
      1, 0, 0,              //
      0, 1, 0;
  g.origin = Vector3d(16.0, -24.0, -20.0);
  // An 8 mm ball at world (6, 9, 4) mm, well inside the grid and off every symmetry; 2.7 % of the
  // volume, so the 99th percentile (white) is the ball's value and the ramp below it stays grey.
  const Vector3d blob(6.0, 9.0, 4.0);
  const VolumeF v = make_volume(g, [&](int i, int, int, const Vector3d& p) {
    return (p - blob).norm() <= 8.0 ? 1000.0F : 100.0F + 0.5F * float(i);
  });
  ASSERT_GT(double(std::count(v.data.begin(), v.data.end(), 1000.0F)),
            0.015 * double(v.data.size()));

  const tests::TempFolder dir;
  OverlayInput in;
  in.left = &v;
  in.target = blob;
  OverlayOptions o;
  o.orientation_letters = false;
  write_overlay_png(dir / "o.png", in, o);
  const cv::Mat image = read_png(dir / "o.png");
  const OverlayLayout layout = overlay_layout(in, o);
  for (const SliceView view : {SliceView::AXIAL, SliceView::CORONAL, SliceView::SAGITTAL}) {
    SCOPED_TRACE(int(view));
    const auto [centroid, count] = bright_centroid(image, layout.panel_origin[0][std::size_t(view)],
                                                   layout.panel_size[std::size_t(view)]);
    // White (≥ 250 of 255, i.e. ≥ 98 % of the ball's value) where all 8 trilinear neighbours lie
    // in the ball: a disc of radius ≈ 7–8 mm at 1 mm pixels, π · 8² ≈ 201 pixels at most.
    EXPECT_GE(count, 90);
    EXPECT_LE(count, 230);
    // Its centroid within 1 pixel of the documented position (the voxelised ball is not exactly
    // round; a wrong flip or axis swap would move it by ≥ 6 pixels).
    EXPECT_LE((centroid - layout.world_to_pixel(view, 0, blob)).norm(), 1.0)
        << centroid.transpose() << " vs " << layout.world_to_pixel(view, 0, blob).transpose();
  }
  // The axial position by hand: the box's high R and A corners are 16 + ½ · 0.9 = 16.45 mm
  // (k → −R) and −24 + 49.5 = 25.5 mm (i → A), and the axial panel sits at (4, 4 + 16), so the
  // blob at R = 6, A = 9 lands at (4 + 16.45 − 6 − ½, 20 + 25.5 − 9 − ½) = (13.95, 36).
  EXPECT_NEAR(layout.hi.x(), 16.45, 1e-9);
  EXPECT_NEAR(layout.hi.y(), 25.5, 1e-9);
  EXPECT_TRUE(layout.world_to_pixel(SliceView::AXIAL, 0, blob)
                  .isApprox(Eigen::Vector2d(13.95, 36.0), 1e-12));
}

TEST(Overlay, AnUnwritableTargetNamesThePathAndLeavesNothingBehind) {
  const tests::TempFolder dir;
  const VolumeF v = ramp();
  OverlayInput in;
  in.left = &v;
  const auto missing = dir / "missing" / "o.png";
  expect_error([&] { write_overlay_png(missing, in); }, {missing.string(), "does not exist"});
  EXPECT_EQ(dir.count(), 0u);
  std::ofstream(dir / "blocker") << "x";  // a file where a folder is expected
  const auto under_file = dir / "blocker" / "o.png";
  expect_error([&] { write_overlay_png(under_file, in); }, {under_file.string()});
  EXPECT_EQ(dir.count(), 1u);
  expect_error([&] { write_overlay_png(dir / "o.jpg", in); }, {"o.jpg", ".png"});
  EXPECT_EQ(dir.count(), 1u);
}

TEST(Overlay, RejectsBadInputInOneLine) {
  const tests::TempFolder dir;
  const VolumeF v = ramp();
  const auto path = dir / "o.png";
  OverlayInput in;
  expect_error([&] { write_overlay_png(path, in); }, {"no left volume"});
  const VolumeF empty;
  in.left = &empty;
  expect_error([&] { write_overlay_png(path, in); }, {"left volume is empty"});
  in.left = &v;
  in.right = &empty;
  expect_error([&] { write_overlay_png(path, in); }, {"right volume is empty"});
  in.right = nullptr;
  in.target = Vector3d(0.0, std::numeric_limits<double>::quiet_NaN(), 0.0);
  expect_error([&] { write_overlay_png(path, in); }, {"target", "not finite"});
  in.target = Vector3d(0.0, 0.0, 40.0);
  expect_error([&] { write_overlay_png(path, in); }, {"target", "outside"});
  in.target = Vector3d::Zero();
  in.point_sets.push_back(
      {MatrixX3d::Constant(1, 3, std::numeric_limits<double>::infinity()), {0, 255, 0}});
  expect_error([&] { write_overlay_png(path, in); }, {"point 0 of point set 0", "not finite"});
  in.point_sets.clear();
  OverlayOptions o;
  o.pixel_size_mm = 0.0;
  expect_error([&] { write_overlay_png(path, in, o); }, {"pixel_size_mm"});
  o.pixel_size_mm = 0.001;  // 40,000 pixels across
  expect_error([&] { write_overlay_png(path, in, o); }, {"max_panel_px"});
  EXPECT_EQ(dir.count(), 0u);
}

}  // namespace
}  // namespace brainshift::imaging
