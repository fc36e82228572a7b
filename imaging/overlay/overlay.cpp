#include "imaging/overlay/overlay.hpp"

#include "core/error.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/overlay/png_encode.hpp"
#include "imaging/warping/warp_image.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

namespace brainshift::imaging {
namespace {

/// World axes (0 R, 1 A, 2 S) of a view: screen horizontal, screen vertical, slice normal.
struct ViewAxes {
  int horizontal;
  int vertical;
  int normal;
};

ViewAxes axes_of(SliceView v) {
  switch (v) {
    case SliceView::AXIAL:
      return {0, 1, 2};
    case SliceView::CORONAL:
      return {0, 2, 1};
    case SliceView::SAGITTAL:
      return {1, 2, 0};
  }
  BS_UNREACHABLE();
}

constexpr std::array<SliceView, 3> kViews{SliceView::AXIAL, SliceView::CORONAL,
                                          SliceView::SAGITTAL};
constexpr std::array<const char*, 3> kViewNames{"axial", "coronal", "sagittal"};
/// Screen-edge letters of each view: left, right, top, bottom.
constexpr std::array<std::array<const char*, 4>, 3> kEdgeLetters{
    {{"R", "L", "A", "P"}, {"R", "L", "S", "I"}, {"A", "P", "S", "I"}}};
constexpr std::array<char, 3> kAxisLetters{'R', 'A', 'S'};

cv::Scalar bgr(const std::array<std::uint8_t, 3>& rgb) {
  return {double(rgb[2]), double(rgb[1]), double(rgb[0])};
}

void verify_volume(const VolumeF& v, const char* which) {
  BS_VERIFY(
      !v.empty() && v.geometry.size.minCoeff() > 0,
      "overlay: the " << which << " volume is empty (size " << v.geometry.size.transpose() << ")");
  BS_VERIFY(v.components == 1, "overlay: the " << which << " volume has " << v.components
                                               << " components, expected 1 (a scalar image)");
  BS_VERIFY(v.data.size() == std::size_t(v.geometry.voxel_count()),
            "overlay: the " << which << " volume holds " << v.data.size() << " values for "
                            << v.geometry.voxel_count() << " voxels");
  BS_VERIFY(v.geometry.spacing.allFinite() && v.geometry.spacing.minCoeff() > 0 &&
                v.geometry.origin.allFinite() && v.geometry.direction.allFinite() &&
                std::abs(v.geometry.direction.determinant()) > 1e-6,
            "overlay: the " << which << " volume has an invalid geometry (spacing "
                            << v.geometry.spacing.transpose()
                            << ", singular or non-finite direction)");
}

/// Grows [lo, hi] by the world bounding box of the voxel corners of `g`.
void add_bounds(const ImageGeometry& g, Vector3d& lo, Vector3d& hi) {
  for (int corner = 0; corner < 8; ++corner) {
    Vector3d ijk;
    for (int d = 0; d < 3; ++d) ijk[d] = ((corner >> d) & 1) ? g.size[d] - 0.5 : -0.5;
    const Vector3d p = g.index_to_world(ijk);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
}

/// Intensities at the low and high percentiles of the finite voxel values (nearest rank).
std::pair<float, float> intensity_window(const VolumeF& v, double low_pct, double high_pct,
                                         const char* which) {
  std::vector<float> values;
  values.reserve(v.data.size());
  for (const float x : v.data)
    if (std::isfinite(x)) values.push_back(x);
  BS_VERIFY(!values.empty(), "overlay: the " << which << " volume has no finite voxel value");
  const auto rank = [&](double pct) {
    return values.begin() + std::ptrdiff_t(std::llround(pct / 100.0 * double(values.size() - 1)));
  };
  const auto lo_it = rank(low_pct);
  std::nth_element(values.begin(), lo_it, values.end());
  const float lo = *lo_it;
  const auto hi_it = rank(high_pct);
  std::nth_element(lo_it, hi_it,
                   values.end());  // hi_it ≥ lo_it: the high rank lies in [lo_it, end)
  return {lo, *hi_it};
}

/// Grey level of `value` in the window [lo, hi]; a window of zero width shows values above it
/// white.
std::uint8_t grey(float value, float lo, float hi) {
  if (!(hi > lo)) return value > lo ? 255 : 0;
  const double t = std::clamp((double(value) - lo) / (double(hi) - lo), 0.0, 1.0);
  return std::uint8_t(std::lround(255.0 * t));
}

void draw_text(cv::Mat& roi, const std::string& text, cv::Point at, double scale,
               const cv::Scalar& colour) {
  cv::putText(roi, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

std::string caption(const std::string& label, SliceView v, const Vector3d& target) {
  const int n = axes_of(v).normal;
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(1);
  s << label << (label.empty() ? "" : " ") << kViewNames[std::size_t(v)] << ' '
    << kAxisLetters[std::size_t(n)] << '=' << target[n];
  return s.str();
}

/// Draws one volume's three panels (slices, captions, letters, points) into `image`.
void draw_volume(cv::Mat& image, const OverlayLayout& layout, int c, const VolumeF& volume,
                 const std::string& label, const OverlayInput& input, const OverlayOptions& o) {
  const auto [lo, hi] =
      intensity_window(volume, o.low_percentile, o.high_percentile, c == 0 ? "left" : "right");
  const float outside = std::numeric_limits<float>::quiet_NaN();
  for (const SliceView v : kViews) {
    const auto vi = std::size_t(v);
    const Eigen::Vector2i origin = layout.panel_origin[std::size_t(c)][vi];
    const Eigen::Vector2i size = layout.panel_size[vi];
    cv::Mat panel = image(cv::Rect(origin.x(), origin.y(), size.x(), size.y()));
    for (int py = 0; py < size.y(); ++py) {
      auto* row = panel.ptr<cv::Vec3b>(py);
      for (int px = 0; px < size.x(); ++px) {
        const Vector3d p = layout.panel_pixel_to_world(v, px, py);
        const float s = sample_trilinear(volume, volume.geometry.world_to_index(p), outside);
        if (std::isfinite(s)) {
          const std::uint8_t g = grey(s, lo, hi);
          row[px] = cv::Vec3b(g, g, g);
        }
      }
    }
    if (o.orientation_letters && size.minCoeff() >= 24) {
      const cv::Scalar colour(0, 200, 255);  // BGR: orange
      const auto& letters = kEdgeLetters[vi];
      draw_text(panel, letters[0], {2, size.y() / 2 + 4}, 0.35, colour);
      draw_text(panel, letters[1], {size.x() - 9, size.y() / 2 + 4}, 0.35, colour);
      draw_text(panel, letters[2], {size.x() / 2 - 3, 10}, 0.35, colour);
      draw_text(panel, letters[3], {size.x() / 2 - 3, size.y() - 3}, 0.35, colour);
    }
    if (o.label_height_px > 0) {
      cv::Mat strip =
          image(cv::Rect(origin.x(), origin.y() - o.label_height_px, size.x(), o.label_height_px));
      draw_text(strip, caption(label, v, input.target), {2, o.label_height_px - 4}, 0.4,
                cv::Scalar(235, 235, 235));
    }
    const int normal = axes_of(v).normal;
    for (const OverlayPoints& set : input.point_sets) {
      const cv::Scalar colour = bgr(set.rgb);
      for (Eigen::Index i = 0; i < set.points.rows(); ++i) {
        const Vector3d p = set.points.row(i).transpose();
        if (std::abs(p[normal] - input.target[normal]) > o.slab_mm) continue;
        const Eigen::Vector2d xy = layout.world_to_pixel(v, c, p) - origin.cast<double>();
        if (!(xy.array().abs() < 1e6).all()) continue;  // far off the panel: nothing to draw
        cv::circle(panel, cv::Point(int(std::lround(xy.x())), int(std::lround(xy.y()))),
                   o.dot_radius_px, colour, cv::FILLED, cv::LINE_8);
      }
    }
  }
}

cv::Mat render(const OverlayLayout& layout, const OverlayInput& input, const OverlayOptions& o) {
  cv::Mat image(layout.height, layout.width, CV_8UC3, bgr(o.background_rgb));
  draw_volume(image, layout, 0, *input.left, o.left_label, input, o);
  if (input.right != nullptr) draw_volume(image, layout, 1, *input.right, o.right_label, input, o);
  return image;
}

}  // namespace

std::string OverlayOptions::validate() const {
  std::ostringstream s;
  if (!(std::isfinite(pixel_size_mm) && pixel_size_mm > 0))
    s << "pixel_size_mm must be > 0, got " << pixel_size_mm;
  else if (!(slab_mm >= 0 && std::isfinite(slab_mm)))
    s << "slab_mm must be finite and ≥ 0, got " << slab_mm;
  else if (dot_radius_px < 1)
    s << "dot_radius_px must be ≥ 1, got " << dot_radius_px;
  else if (!(low_percentile >= 0 && low_percentile < high_percentile && high_percentile <= 100))
    s << "percentiles must satisfy 0 ≤ low < high ≤ 100, got low " << low_percentile << ", high "
      << high_percentile;
  else if (label_height_px < 0)
    s << "label_height_px must be ≥ 0, got " << label_height_px;
  else if (gap_px < 0)
    s << "gap_px must be ≥ 0, got " << gap_px;
  else if (max_panel_px < 1)
    s << "max_panel_px must be ≥ 1, got " << max_panel_px;
  return s.str();
}

Eigen::Vector2d OverlayLayout::world_to_pixel(SliceView v, int c, const Vector3d& p) const {
  const ViewAxes a = axes_of(v);
  const Eigen::Vector2i origin = panel_origin[std::size_t(c)][std::size_t(v)];
  return {origin.x() + (hi[a.horizontal] - p[a.horizontal]) / pixel_size_mm - 0.5,
          origin.y() + (hi[a.vertical] - p[a.vertical]) / pixel_size_mm - 0.5};
}

Vector3d OverlayLayout::panel_pixel_to_world(SliceView v, int px, int py) const {
  const ViewAxes a = axes_of(v);
  Vector3d p = target;
  p[a.horizontal] = hi[a.horizontal] - (px + 0.5) * pixel_size_mm;
  p[a.vertical] = hi[a.vertical] - (py + 0.5) * pixel_size_mm;
  return p;
}

OverlayLayout overlay_layout(const OverlayInput& input, const OverlayOptions& options) {
  const std::string bad = options.validate();
  BS_VERIFY(bad.empty(), "overlay: invalid options: " << bad);
  BS_VERIFY(input.left != nullptr, "overlay: no left volume given (OverlayInput::left is null)");
  verify_volume(*input.left, "left");
  if (input.right != nullptr) verify_volume(*input.right, "right");
  BS_VERIFY(input.target.allFinite(),
            "overlay: the target " << input.target.transpose() << " is not finite");
  for (std::size_t s = 0; s < input.point_sets.size(); ++s) {
    const MatrixX3d& P = input.point_sets[s].points;
    for (Eigen::Index i = 0; i < P.rows(); ++i)
      BS_VERIFY(P.row(i).allFinite(), "overlay: point " << i << " of point set " << s
                                                        << " is not finite (" << P.row(i) << ")");
  }

  OverlayLayout L;
  L.lo = Vector3d::Constant(std::numeric_limits<double>::infinity());
  L.hi = -L.lo;
  add_bounds(input.left->geometry, L.lo, L.hi);
  if (input.right != nullptr) add_bounds(input.right->geometry, L.lo, L.hi);
  BS_VERIFY(
      (input.target.array() >= L.lo.array()).all() && (input.target.array() <= L.hi.array()).all(),
      "overlay: the target (" << input.target.transpose()
                              << ") mm lies outside the volumes' extent [" << L.lo.transpose()
                              << "] – [" << L.hi.transpose() << "] mm");
  L.pixel_size_mm = options.pixel_size_mm;
  L.target = input.target;

  Eigen::Vector3i n;
  for (int d = 0; d < 3; ++d) {
    const double count = std::ceil((L.hi[d] - L.lo[d]) / L.pixel_size_mm - 1e-9);
    BS_VERIFY(count <= options.max_panel_px,
              "overlay: a slice would be "
                  << count << " pixels along " << kAxisLetters[std::size_t(d)]
                  << " (more than max_panel_px " << options.max_panel_px
                  << "); choose a larger pixel_size_mm than " << L.pixel_size_mm);
    n[d] = std::max(1, int(count));
  }
  for (const SliceView v : kViews) {
    const ViewAxes a = axes_of(v);
    L.panel_size[std::size_t(v)] = {n[a.horizontal], n[a.vertical]};
  }

  const int volumes = input.right != nullptr ? 2 : 1;
  const bool in_columns = options.arrangement == OverlayArrangement::VOLUMES_IN_COLUMNS;
  L.columns = in_columns ? volumes : 3;
  L.rows = in_columns ? 3 : volumes;
  std::vector<int> col_width(std::size_t(L.columns), 0), row_height(std::size_t(L.rows), 0);
  const auto grid = [&](int c, SliceView v) {
    return in_columns ? std::pair{c, int(v)} : std::pair{int(v), c};  // (column, row)
  };
  for (int c = 0; c < volumes; ++c)
    for (const SliceView v : kViews) {
      const auto [col, row] = grid(c, v);
      const Eigen::Vector2i s = L.panel_size[std::size_t(v)];
      col_width[std::size_t(col)] = std::max(col_width[std::size_t(col)], s.x());
      row_height[std::size_t(row)] =
          std::max(row_height[std::size_t(row)], options.label_height_px + s.y());
    }
  const int g = options.gap_px;
  std::vector<int> col_x(std::size_t(L.columns)), row_y(std::size_t(L.rows));
  L.width = g;
  for (int col = 0; col < L.columns; ++col) {
    col_x[std::size_t(col)] = L.width;
    L.width += col_width[std::size_t(col)] + g;
  }
  L.height = g;
  for (int row = 0; row < L.rows; ++row) {
    row_y[std::size_t(row)] = L.height;
    L.height += row_height[std::size_t(row)] + g;
  }
  for (int c = 0; c < volumes; ++c)
    for (const SliceView v : kViews) {
      const auto [col, row] = grid(c, v);
      L.panel_origin[std::size_t(c)][std::size_t(v)] = {
          col_x[std::size_t(col)], row_y[std::size_t(row)] + options.label_height_px};
    }
  return L;
}

void write_overlay_png(const std::filesystem::path& path, const OverlayInput& input,
                       const OverlayOptions& options) {
  std::string extension = path.extension().string();
  for (char& ch : extension) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  BS_VERIFY(extension == ".png",
            "cannot write overlay " << path.string() << ": the file name must end in .png");
  const OverlayLayout layout = overlay_layout(input, options);
  const cv::Mat image = render(layout, input, options);
  write_atomically(path, [&](const std::filesystem::path& temporary) {
    // cv::imwrite picks the encoder from the file name's extension, which the temporary name
    // does not end in: encode in memory, then write the bytes.
    std::vector<unsigned char> bytes;
    bool encoded = false;
    try {
      encoded = encode_png(image, bytes);  // one encoding at a time (png_encode.hpp)
    } catch (const cv::Exception& e) {
      BS_THROW("cannot write overlay " << path.string() << ": PNG encoding failed (" << e.err
                                       << ")");
    }
    BS_VERIFY(encoded, "cannot write overlay " << path.string() << ": PNG encoding failed");
    std::ofstream file(temporary, std::ios::binary);
    file.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    file.close();
    BS_VERIFY(file.good(), "cannot write overlay " << path.string() << ": writing " << bytes.size()
                                                   << " bytes failed");
  });
}

}  // namespace brainshift::imaging
