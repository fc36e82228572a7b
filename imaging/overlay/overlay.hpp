#pragma once
/// @file
/// @brief Quality-control overlay: a PNG with the three orthogonal slices (axial, coronal,
/// sagittal) through a world point of one or two volumes (e.g. the pre-operative MRI and the
/// MRI warped by the registration), with world points drawn as coloured dots.
///
/// Slices are resampled on a world-aligned grid (RAS, mm), not along the image axes, so a volume
/// with any direction matrix (oblique, LPS-stored, permuted axes) is displayed the same way:
///
/// | view     | plane                | screen left → right | screen top → bottom |
/// |----------|----------------------|---------------------|---------------------|
/// | axial    | S = target.S         | R → L               | A → P               |
/// | coronal  | A = target.A         | R → L               | S → I               |
/// | sagittal | R = target.R         | A → P               | S → I               |
///
/// This is the radiological convention: the axial slice is seen from the feet, the coronal from
/// the front and the sagittal from the patient's left, so the patient's right is on the screen's
/// left. Orientation letters are drawn at the edges of every slice.
///
/// Pixel geometry: the shown world box [lo, hi] (RAS, mm) is the union of the volumes' bounding
/// boxes (voxel corners, i.e. centres ± half a voxel, over all 8 corners of each grid). Along a
/// world axis a with n_a = ⌈(hi_a − lo_a) / h⌉ pixels of size h, the pixel with index q (0 at the
/// screen's left or top) has its centre at world coordinate hi_a − (q + ½) h: every screen axis
/// runs from the high world coordinate (R, A, S) to the low one.

#include "core/config.hpp"
#include "imaging/io/volume.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace brainshift::imaging {

/// The three orthogonal views, in their order in the overlay.
enum class SliceView { AXIAL = 0, CORONAL = 1, SAGITTAL = 2 };

/// World points drawn as filled dots on every slice they lie within OverlayOptions::slab_mm of.
struct OverlayPoints {
  MatrixX3d points;                            ///< #P×3 world RAS, mm; must be finite
  std::array<std::uint8_t, 3> rgb{0, 255, 0};  ///< dot colour (red, green, blue)
};

/// What the overlay shows. Pointers are not owned; they must outlive the call only.
struct OverlayInput {
  const VolumeF* left = nullptr;   ///< one-component volume, e.g. the pre-operative MRI; required
  const VolumeF* right = nullptr;  ///< one-component volume, e.g. the warped MRI; may be null
  Vector3d target = Vector3d::Zero();  ///< world RAS mm; the three slices pass through it
  /// Drawn in order (later sets over earlier ones), e.g. intra-operative vessel points in green,
  /// footprint points in yellow.
  std::vector<OverlayPoints> point_sets;
};

/// How the panels are arranged.
enum class OverlayArrangement {
  VOLUMES_IN_COLUMNS,  ///< 3 rows (axial, coronal, sagittal) × 1 or 2 columns (left, right volume)
  VOLUMES_IN_ROWS,     ///< 1 or 2 rows (left, right volume) × 3 columns (axial, coronal, sagittal)
};

/// Look of the overlay. Lengths in mm, sizes in pixels.
struct OverlayOptions {
  double pixel_size_mm = 1.0;  ///< side of a (square) pixel, mm, > 0
  double slab_mm =
      1.5;  ///< a point is drawn on a slice when its distance to the plane is ≤ this, mm
  int dot_radius_px = 3;  ///< radius of the filled dots, pixels, ≥ 1
  /// Intensity window: the low and high percentiles of the finite voxel values of each volume
  /// (computed per volume) map to black and white; 0 ≤ low < high ≤ 100.
  double low_percentile = 1.0;
  double high_percentile = 99.0;
  std::string left_label = "pre-op";   ///< caption of the left volume's panels
  std::string right_label = "warped";  ///< caption of the right volume's panels
  OverlayArrangement arrangement = OverlayArrangement::VOLUMES_IN_COLUMNS;
  int label_height_px = 16;         ///< caption strip above every panel, pixels, ≥ 0
  int gap_px = 4;                   ///< space around and between panels, pixels, ≥ 0
  bool orientation_letters = true;  ///< R/L, A/P, S/I at the edges of every slice
  /// Colour of pixels outside the volume and of the gaps and caption strips (red, green, blue).
  std::array<std::uint8_t, 3> background_rgb{0, 0, 0};
  int max_panel_px =
      4096;  ///< largest allowed panel side, pixels (guards against tiny pixel sizes)

  /// Empty when valid, else one line naming the first bad field and its value.
  [[nodiscard]] std::string validate() const;
};

/// Where everything lands in the overlay image. Image pixel coordinates (x, y): x to the right,
/// y down, pixel (x, y) covers [x − ½, x + ½] × [y − ½, y + ½] (its centre is at integers).
struct OverlayLayout {
  Vector3d lo = Vector3d::Zero();  ///< low corner of the shown world box, RAS mm
  Vector3d hi = Vector3d::Zero();  ///< high corner of the shown world box, RAS mm
  double pixel_size_mm = 1.0;
  Vector3d target = Vector3d::Zero();  ///< world RAS mm
  int columns = 0;                     ///< panel columns of the image
  int rows = 0;                        ///< panel rows of the image
  int width = 0;                       ///< image width, pixels
  int height = 0;                      ///< image height, pixels
  /// Top-left pixel of the slice area (below its caption) of view v of volume c
  /// (0 left, 1 right): panel_origin[c][v].
  std::array<std::array<Eigen::Vector2i, 3>, 2> panel_origin{};
  /// Width and height of view v's slice area, pixels (the same for both volumes).
  std::array<Eigen::Vector2i, 3> panel_size{};

  /// Continuous image pixel coordinates (x, y) of the projection of world point p onto view v of
  /// volume c; may lie outside the panel.
  [[nodiscard]] Eigen::Vector2d world_to_pixel(SliceView v, int c, const Vector3d& p) const;
  /// World RAS mm of the centre of panel pixel (px, py) of view v (px, py: 0 at the panel's
  /// top-left pixel); the coordinate across the slice is the target's.
  [[nodiscard]] Vector3d panel_pixel_to_world(SliceView v, int px, int py) const;
};

/// The layout write_overlay_png() uses for `input` and `options` (validates both).
/// \throws brainshift::Error as write_overlay_png(), except for file-system errors.
OverlayLayout overlay_layout(const OverlayInput& input, const OverlayOptions& options = {});

/// Writes the overlay as an 8-bit RGB PNG (written atomically: a temporary file in the same folder,
/// renamed when complete). Each slice is sampled with sample_trilinear() at its pixel centres
/// (see the file comment for the geometry); intensities are windowed per volume to
/// [low_percentile, high_percentile] and mapped linearly to grey 0–255 (a constant volume shows
/// black). Points are drawn on both volumes' panels.
/// @param[in] path     target file, must end in ".png"; its folder must exist.
/// @param[in] input    volumes, target and points.
/// @param[in] options  see OverlayOptions.
/// \throws brainshift::Error (one line) when options are invalid, the left volume is missing,
/// a volume is empty, multi-component or has no finite voxel, the target or a point is not
/// finite, the target lies outside the shown world box, a panel would exceed max_panel_px, or
/// the file cannot be written (the message names `path`; nothing is left behind).
void write_overlay_png(const std::filesystem::path& path, const OverlayInput& input,
                       const OverlayOptions& options = {});

}  // namespace brainshift::imaging
