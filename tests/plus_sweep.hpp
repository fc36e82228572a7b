#pragma once
// A tracked ultrasound sweep cut from a volume and written as a PLUS sequence file by a writer that
// follows PLUS's published format (vtkPlusSequenceIO), independent of brainshift's reader: for the
// tests of imaging/io/plus_sequence and imaging/reconstruction, and of the commands using them.
#include "imaging/io/volume.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include <zlib.h>

namespace brainshift::tests {

using imaging::ImageGeometry;
using imaging::VolumeF;
using Matrix4d = Eigen::Matrix4d;

/// Trilinear value of `v` at world point `p` (NaN outside): this test's own interpolation.
inline double sample(const VolumeF& v, const Vector3d& p) {
  const Vector3d x = v.geometry.world_to_index(p);
  const Eigen::Vector3i i0 = x.array().floor().cast<int>();
  const Vector3d f = x - i0.cast<double>();
  for (int a = 0; a < 3; ++a)
    if (i0[a] < 0 || i0[a] + 1 >= v.geometry.size[a]) return std::nan("");
  double s = 0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    const double w = (dx ? f[0] : 1 - f[0]) * (dy ? f[1] : 1 - f[1]) * (dz ? f[2] : 1 - f[2]);
    s += w * double(v.at(i0[0] + dx, i0[1] + dy, i0[2] + dz));
  }
  return s;
}

/// A tracked sweep through `volume`: frames of `columns` × `rows` pixels of `pixel_mm`, the image
/// plane along the volume's first and third index axes, moving along its second by `step_mm`
/// per frame and tilting by up to ±6° about the first. Probe = image plane centre; the
/// calibration maps MF pixels (i, j) to the probe frame. Pixel values: `scale` × the volume's,
/// rounded to 0…255 (PLUS's MET_UCHAR).
struct Sweep {
  int columns = 0, rows = 0, frames = 0;
  Matrix4d calibration;  // Image to Probe
  std::vector<Matrix4d> probe_to_tracker;
  std::vector<std::vector<std::uint8_t>> pixels;  // MF, row-major
  std::vector<bool> valid;
};

inline Sweep cut_sweep(const VolumeF& volume, double pixel_mm, double step_mm, int frames,
                       const std::vector<int>& invalid, double scale = 1.0) {
  Sweep s;
  const ImageGeometry& g = volume.geometry;
  const Vector3d extent = g.spacing.cwiseProduct((g.size.array() - 1).cast<double>().matrix());
  // The plane spans 60 % of the first and third axes; the sweep 60 % of the second.
  s.columns = int(0.6 * extent[0] / pixel_mm);
  s.rows = int(0.6 * extent[2] / pixel_mm);
  s.frames = frames;
  Matrix4d c = Matrix4d::Identity();
  c.block<3, 1>(0, 0) = Vector3d(pixel_mm, 0, 0);
  c.block<3, 1>(0, 1) = Vector3d(0, 0, -pixel_mm);  // rows go down, into the tissue
  c.block<3, 1>(0, 3) =
      Vector3d(-0.5 * pixel_mm * (s.columns - 1), 0, 0.5 * pixel_mm * (s.rows - 1));
  s.calibration = c;
  const Vector3d centre = g.index_to_world(0.5 * (g.size.array() - 1).cast<double>().matrix());
  const double sweep = 0.6 * extent[1];
  for (int n = 0; n < frames; ++n) {
    const double t = frames > 1 ? double(n) / (frames - 1) : 0.5;
    Matrix4d probe = Matrix4d::Identity();
    // Probe axes in world: x along the volume's i axis, z along its k axis (so the image rows,
    // −z, run against k), y along j; tilted about x.
    Eigen::Matrix3d axes;
    axes.col(0) = g.direction.col(0);
    axes.col(1) = g.direction.col(1);
    axes.col(2) = g.direction.col(2);
    const double tilt = 6.0 * M_PI / 180.0 * std::sin(2 * M_PI * t);
    probe.topLeftCorner<3, 3>() =
        axes * Eigen::AngleAxisd(tilt, Vector3d::UnitX()).toRotationMatrix();
    probe.block<3, 1>(0, 3) =
        centre + g.direction.col(1) * ((t - 0.5) * std::min(sweep, step_mm * (frames - 1)));
    s.probe_to_tracker.push_back(probe);
    const bool ok = std::find(invalid.begin(), invalid.end(), n) == invalid.end();
    s.valid.push_back(ok);
    std::vector<std::uint8_t> image(std::size_t(s.columns) * std::size_t(s.rows), 255);
    if (ok) {
      const Matrix4d m = probe * c;
      for (int j = 0; j < s.rows; ++j)
        for (int i = 0; i < s.columns; ++i) {
          const double v = scale * sample(volume, (m * Eigen::Vector4d(i, j, 0, 1)).head<3>());
          image[std::size_t(j) * std::size_t(s.columns) + std::size_t(i)] =
              std::uint8_t(std::isfinite(v) ? std::clamp(std::lround(v), 0L, 255L) : 0);
        }
    }  // an invalid frame's image is all 255: it must not be inserted
    s.pixels.push_back(std::move(image));
  }
  return s;
}

inline std::string matrix_text(const Matrix4d& m) {
  std::ostringstream o;
  o.precision(17);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) o << (r || c ? " " : "") << m(r, c);
  return o.str();
}

/// Writes `s` as PLUS writes a sequence file (vtkPlusSequenceIO: a MetaImage header, the
/// per-frame fields Seq_FrameNNNN_*, ElementDataFile = LOCAL last, raw uchar frames) in the
/// orientation `orientation` (MF or UF here; UF stores each row mirrored).
inline void write_plus_sequence(const std::filesystem::path& path, const Sweep& s,
                                const std::string& orientation, bool image_to_reference = false,
                                bool calibration_in_frames = false) {
  std::ostringstream h;
  h << "ObjectType = Image\nNDims = 3\nAnatomicalOrientation = RAI\nBinaryData = True\n"
    << "BinaryDataByteOrderMSB = False\nCenterOfRotation = 0 0 0\nCompressedData = False\n"
    << "DimSize = " << s.columns << ' ' << s.rows << ' ' << s.frames << '\n'
    << "ElementNumberOfChannels = 1\nElementSpacing = 1 1 1\nElementType = MET_UCHAR\n"
    << "Offset = 0 0 0\nTransformMatrix = 1 0 0 0 1 0 0 0 1\n"
    << "UltrasoundImageOrientation = " << orientation << '\n'
    << "UltrasoundImageType = BRIGHTNESS\n";
  const std::string name = image_to_reference ? "ImageToReference" : "ProbeToTracker";
  for (int n = 0; n < s.frames; ++n) {
    char p[32];
    std::snprintf(p, sizeof p, "Seq_Frame%04d_", n);
    h << p << "FrameNumber = " << n << '\n'
      << p << name << "Transform = "
      << matrix_text(image_to_reference
                         ? Matrix4d(s.probe_to_tracker[std::size_t(n)] * s.calibration)
                         : s.probe_to_tracker[std::size_t(n)])
      << '\n'
      << p << name << "TransformStatus = " << (s.valid[std::size_t(n)] ? "OK" : "INVALID") << '\n'
      << (calibration_in_frames
              ? std::string(p) + "ImageToProbeTransform = " + matrix_text(s.calibration) + "\n"
              : std::string())
      << p << "Timestamp = " << 0.05 * n << '\n'
      << p << "UnfilteredTimestamp = " << 0.05 * n << '\n'
      << p << "ImageStatus = OK\n";
  }
  h << "ElementDataFile = LOCAL\n";
  std::ofstream out(path, std::ios::binary);
  out << h.str();
  for (const auto& image : s.pixels)
    for (int j = 0; j < s.rows; ++j)
      for (int i = 0; i < s.columns; ++i) {
        // Stored pixel (i, j) holds the MF pixel mirrored as the orientation says.
        const int mi = orientation[0] == 'U' ? s.columns - 1 - i : i;
        const int mj = orientation[1] == 'N' ? s.rows - 1 - j : j;
        out.put(char(image[std::size_t(mj) * std::size_t(s.columns) + std::size_t(mi)]));
      }
}

/// `raw` deflated: gzip (window bits 15 + 16) or zlib (15).
inline std::string deflate_bytes(const std::string& raw, bool gzip) {
  z_stream z{};
  deflateInit2(&z, 6, Z_DEFLATED, gzip ? 15 + 16 : 15, 8, Z_DEFAULT_STRATEGY);
  std::string out(deflateBound(&z, uLong(raw.size())) + 64, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(raw.data()));
  z.avail_in = uInt(raw.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = uInt(out.size());
  deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

/// The MF pixels of `s`, frame after frame, as stored for `orientation`.
inline std::string stored_pixels(const Sweep& s, const std::string& orientation) {
  std::string bytes;
  for (const auto& image : s.pixels)
    for (int j = 0; j < s.rows; ++j)
      for (int i = 0; i < s.columns; ++i) {
        const int mi = orientation[0] == 'U' ? s.columns - 1 - i : i;
        const int mj = orientation[1] == 'N' ? s.rows - 1 - j : j;
        bytes.push_back(char(image[std::size_t(mj) * std::size_t(s.columns) + std::size_t(mi)]));
      }
  return bytes;
}

/// Writes `s` as PLUS's NRRD sequence (vtkPlusNrrdSequenceIO): NRRD0004, type, dimension 3,
/// sizes columns rows frames with kinds "domain domain list", gzip encoding, the orientation and
/// each frame's fields as key/value pairs.
inline void write_plus_sequence_nrrd(const std::filesystem::path& path, const Sweep& s,
                                     const std::string& orientation) {
  std::ostringstream h;
  h << "NRRD0004\n# Complete NRRD file format specification at:\n"
    << "# http://teem.sourceforge.net/nrrd/format.html\n"
    << "type: unsigned char\ndimension: 3\nsizes: " << s.columns << ' ' << s.rows << ' ' << s.frames
    << "\nkinds: domain domain list\nendian: little\nencoding: gzip\n"
    << "ultrasound image orientation:=" << orientation << "\n"
    << "ultrasound image type:=BRIGHTNESS\n";
  for (int n = 0; n < s.frames; ++n) {
    char p[32];
    std::snprintf(p, sizeof p, "Seq_Frame%04d_", n);
    h << p << "ProbeToTrackerTransform:=" << matrix_text(s.probe_to_tracker[std::size_t(n)]) << '\n'
      << p << "ProbeToTrackerTransformStatus:=" << (s.valid[std::size_t(n)] ? "OK" : "INVALID")
      << '\n'
      << p << "Timestamp:=" << 0.05 * n << '\n'
      << p << "ImageStatus:=OK\n";
  }
  h << '\n';
  std::ofstream out(path, std::ios::binary);
  out << h.str() << deflate_bytes(stored_pixels(s, orientation), true);
}

}  // namespace brainshift::tests
