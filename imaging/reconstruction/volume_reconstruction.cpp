#include "imaging/reconstruction/volume_reconstruction.hpp"

#include "core/error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace brainshift::imaging {

VolumeF reconstruct_volume(const PlusSequence& sequence,
                           const std::vector<std::optional<Eigen::Matrix4d>>& image_to_world,
                           const ReconstructionOptions& options, const std::string& file,
                           ReconstructionReport* report, Volume<std::uint8_t>* coverage) {
  BS_VERIFY(options.spacing_mm > 0 && std::isfinite(options.spacing_mm),
            file << ": the reconstruction spacing must be > 0 mm, got " << options.spacing_mm);
  BS_VERIFY(image_to_world.size() == sequence.frames.size(),
            file << ": " << image_to_world.size() << " transforms for " << sequence.frames.size()
                 << " frames");
  ReconstructionReport rep;
  rep.frames = int(sequence.frames.size());
  const int w = sequence.columns, h = sequence.rows;
  // The bounding box of the placed frames' pixel centres, and the frames' centres.
  Vector3d lo = Vector3d::Constant(std::numeric_limits<double>::infinity());
  Vector3d hi = -lo;
  std::vector<Vector3d> centres;
  for (const auto& m : image_to_world) {
    if (!m) continue;
    for (const double i : {0.0, double(w - 1)})
      for (const double j : {0.0, double(h - 1)}) {
        const Vector3d p = (*m * Eigen::Vector4d(i, j, 0, 1)).head<3>();
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
    centres.push_back((*m * Eigen::Vector4d(0.5 * (w - 1), 0.5 * (h - 1), 0, 1)).head<3>());
  }
  rep.frames_placed = int(centres.size());
  rep.frames_skipped = rep.frames - rep.frames_placed;
  BS_VERIFY(!centres.empty(), file << ": no frame to reconstruct (" << rep.frames
                                   << " frames, none with a valid transform and image)");
  const double s = options.spacing_mm;
  ImageGeometry g;
  g.spacing = Vector3d::Constant(s);
  g.origin = lo;
  g.direction.setIdentity();
  double voxels = 1;
  for (int a = 0; a < 3; ++a) {
    g.size[a] = int(std::floor((hi[a] - lo[a]) / s + 1e-9)) + 1;
    voxels *= double(g.size[a]);
  }
  BS_VERIFY(voxels <= options.max_voxels,
            file << ": a " << g.size[0] << " x " << g.size[1] << " x " << g.size[2] << " grid at "
                 << s << " mm is more than " << options.max_voxels << " voxels; use a spacing of "
                 << "at least " << s * std::cbrt(voxels / options.max_voxels) << " mm");
  const std::size_t n = std::size_t(voxels);
  const std::size_t nx = std::size_t(g.size[0]), ny = std::size_t(g.size[1]);
  std::vector<double> sum(n, 0.0);
  std::vector<std::uint32_t> hits(n, 0);

  // Nearest neighbour: each pixel centre into the voxel it falls in.
  for (std::size_t f = 0; f < sequence.frames.size(); ++f) {
    if (!image_to_world[f]) continue;
    const Eigen::Matrix4d& m = *image_to_world[f];
    const Vector3d o = (m.col(3).head<3>() - g.origin) / s;
    const Vector3d di = m.col(0).head<3>() / s, dj = m.col(1).head<3>() / s;
    for (int j = 0; j < h; ++j) {
      const Vector3d row = o + double(j) * dj;
      for (int i = 0; i < w; ++i) {
        const Vector3d q = row + double(i) * di;
        const long x = std::lround(q[0]), y = std::lround(q[1]), z = std::lround(q[2]);
        if (x < 0 || y < 0 || z < 0 || x >= g.size[0] || y >= g.size[1] || z >= g.size[2]) continue;
        const std::size_t v = (std::size_t(z) * ny + std::size_t(y)) * nx + std::size_t(x);
        sum[v] += double(sequence.at(f, i, j));
        ++hits[v];
        ++rep.pixels_inserted;
      }
    }
  }
  VolumeF out(g, 1);
  std::vector<bool> filled(n, false);
  for (std::size_t v = 0; v < n; ++v)
    if (hits[v]) {
      out.data[v] = float(sum[v] / double(hits[v]));
      ++rep.voxels_hit;
    }

  // Hole filling between data, along each axis (see the header).
  double gap = 0;
  for (std::size_t k = 1; k < centres.size(); ++k)
    gap = std::max(gap, (centres[k] - centres[k - 1]).norm());
  rep.fill_radius = std::min(options.max_fill_radius, int(std::ceil(gap / s)) + 1);
  if (rep.fill_radius > 0) {
    std::vector<float> fill_sum(n, 0.0f);
    std::vector<std::uint8_t> fill_count(n, 0);
    const long size[3] = {g.size[0], g.size[1], g.size[2]};
    const std::size_t stride[3] = {1, nx, nx * ny};
    for (int a = 0; a < 3; ++a) {
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      for (long u = 0; u < size[b]; ++u)
        for (long t = 0; t < size[c]; ++t) {
          const std::size_t base = std::size_t(u) * stride[b] + std::size_t(t) * stride[c];
          long last = -1;
          for (long x = 0; x < size[a]; ++x) {
            const std::size_t v = base + std::size_t(x) * stride[a];
            if (!hits[v]) continue;
            if (last >= 0 && x - last > 1 && x - last <= rep.fill_radius + 1) {
              const std::size_t v0 = base + std::size_t(last) * stride[a];
              for (long y = last + 1; y < x; ++y) {
                const float wgt = float(y - last) / float(x - last);
                const std::size_t e = base + std::size_t(y) * stride[a];
                fill_sum[e] += (1.0f - wgt) * out.data[v0] + wgt * out.data[v];
                ++fill_count[e];
              }
            }
            last = x;
          }
        }
    }
    for (std::size_t v = 0; v < n; ++v)
      if (!hits[v] && fill_count[v]) {
        out.data[v] = fill_sum[v] / float(fill_count[v]);
        filled[v] = true;
        ++rep.voxels_filled;
      }
  }
  if (coverage) {
    *coverage = Volume<std::uint8_t>(g, 1);
    for (std::size_t v = 0; v < n; ++v) coverage->data[v] = hits[v] ? 1 : filled[v] ? 2 : 0;
  }
  rep.voxels = (long long)n;
  rep.spacing_mm = s;
  rep.voxels_empty = rep.voxels - rep.voxels_hit - rep.voxels_filled;
  if (report) *report = rep;
  return out;
}

VolumeF reconstruct_sequence_file(const std::filesystem::path& path,
                                  const SequenceReconstructionOptions& options,
                                  ReconstructionReport* report, Volume<std::uint8_t>* coverage) {
  const std::string file = path.string();
  const PlusSequence seq = read_plus_sequence(path);
  BS_VERIFY(!seq.frames.empty(), file << ": the sequence holds no frame");
  const auto placed = image_to_world(seq, file, options.calibration, options.transform);
  std::vector<double> pixel;
  Vector3d lo = Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const auto& m : placed) {
    if (!m) continue;
    pixel.push_back(0.5 * (m->col(0).head<3>().norm() + m->col(1).head<3>().norm()));
    for (const double i : {0.0, double(seq.columns - 1)})
      for (const double j : {0.0, double(seq.rows - 1)}) {
        const Vector3d p = (*m * Eigen::Vector4d(i, j, 0, 1)).head<3>();
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
  }
  std::nth_element(pixel.begin(), pixel.begin() + std::ptrdiff_t(pixel.size() / 2), pixel.end());
  const double pixel_mm = pixel[pixel.size() / 2];
  ReconstructionOptions ro;
  if (options.spacing_mm) {
    ro.spacing_mm = *options.spacing_mm;
  } else {
    const Vector3d extent = hi - lo;
    const double fit = std::cbrt((extent[0] + pixel_mm) * (extent[1] + pixel_mm) *
                                 (extent[2] + pixel_mm) / options.max_default_voxels);
    ro.spacing_mm = std::max(pixel_mm, fit);
  }
  ReconstructionReport rep;
  VolumeF v = reconstruct_volume(seq, placed, ro, file, &rep, coverage);
  rep.pixel_mm = pixel_mm;
  if (report) *report = rep;
  return v;
}

}  // namespace brainshift::imaging
