/// @file
/// @brief Benchmarks of the imaging stages that run intra-operatively or while preparing a case:
/// vessel extraction from a 256³ power-Doppler-like volume (synthetic tubes in speckle), warping
/// a 256³ MRI through a ≈2k-node deformed mesh, and meshing the brain phantom's label volume
/// (140 × 170 × 120 mm at 1 mm, tumour and ventricles) at the coarse (≈2k nodes) and a refined
/// (≈18k nodes) size, register's forward fields (one pass against two) and the .nii.gz
/// compression levels. Inputs are built once in static fixtures (not timed); every run is one
/// call, timed in wall-clock (UseRealTime: warping uses threads). See docs/BENCHMARKS.md.
///
/// Targets (issue 6): vessel extraction < 2 s, warping < 2 s, coarse meshing < 30 s.

#include "core/mesh/tet_mesh.hpp"
#include "data_synth/geometry/brain_phantom.hpp"
#include "data_synth/geometry/structured_mesh.hpp"
#include "imaging/filters/gaussian.hpp"
#include "imaging/filters/separable.hpp"
#include "imaging/io/gzip_file.hpp"
#include "imaging/io/volume.hpp"
#include "imaging/meshing/label_mesher.hpp"
#include "imaging/vessels/vessel_extraction.hpp"
#include "imaging/warping/warp_image.hpp"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>
#include <vector>

namespace brainshift::bench {
namespace {

using imaging::ImageGeometry;
using imaging::VolumeF;

/// 256³ voxels of `spacing` mm centred on the world origin, identity direction.
ImageGeometry cube_256(double spacing) {
  ImageGeometry g;
  g.size = Eigen::Vector3i::Constant(256);
  g.spacing = Vector3d::Constant(spacing);
  g.origin = Vector3d::Constant(-0.5 * 255 * spacing);
  return g;
}

/// Marks the voxels within `radius` mm of p (world) with `value`.
void paint_ball(VolumeF& v, const Vector3d& p, double radius, float value) {
  const ImageGeometry& g = v.geometry;
  const Vector3d c = g.world_to_index(p);  // identity direction: index axes = world axes
  const Vector3d r = Vector3d::Constant(radius).cwiseQuotient(g.spacing);
  Eigen::Vector3i lo, hi;
  for (int d = 0; d < 3; ++d) {
    lo[d] = std::max(0, int(std::floor(c[d] - r[d])));
    hi[d] = std::min(g.size[d] - 1, int(std::ceil(c[d] + r[d])));
  }
  for (int k = lo[2]; k <= hi[2]; ++k)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int i = lo[0]; i <= hi[0]; ++i)
        if ((g.index_to_world(Vector3d(i, j, k)) - p).squaredNorm() <= radius * radius)
          v.at(i, j, k) = value;
}

/// A power-Doppler-like volume, 256³ at 0.5 mm (128 mm across): 12 tortuous tubes of radius
/// 0.8–2 mm (flow signal ≈ 200 with ±30 % speckle) in Rayleigh speckle of scale 12 (tissue,
/// no flow), fixed seed.
const VolumeF& doppler_volume() {
  static const VolumeF volume = [] {
    std::mt19937 rng(6);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    VolumeF v(cube_256(0.5), 1, 0.0F);
    const float VESSEL = -1.0F;  // marker, replaced by flow signal below
    for (int t = 0; t < 12; ++t) {
      // A line through a random point near the centre, bent by two sinusoids.
      const Vector3d centre(40 * (u(rng) - 0.5), 40 * (u(rng) - 0.5), 40 * (u(rng) - 0.5));
      const Vector3d dir = Vector3d(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5).normalized();
      const Vector3d n1 = dir.unitOrthogonal(), n2 = dir.cross(n1);
      const double radius = 0.8 + 1.2 * u(rng);
      const double phase = 2 * std::numbers::pi * u(rng);
      for (double s = -55.0; s <= 55.0; s += 0.25) {
        const Vector3d p = centre + s * dir + 6.0 * std::sin(s / 15.0 + phase) * n1 +
                           4.0 * std::cos(s / 11.0) * n2;
        paint_ball(v, p, radius, VESSEL);
      }
    }
    for (float& x : v.data) {
      const double rayleigh = 12.0 * std::sqrt(-2.0 * std::log(1.0 - u(rng)));
      x = x == VESSEL ? float(200.0 * (0.7 + 0.6 * u(rng))) : float(rayleigh);
    }
    return v;
  }();
  return volume;
}

void BM_ExtractVessels256(benchmark::State& state) {
  const VolumeF& image = doppler_volume();
  imaging::VesselExtractionResult r;
  for (auto _ : state) {
    r = imaging::extract_vessels(image);
    benchmark::DoNotOptimize(r.graph);
  }
  if (r.status != imaging::VesselStatus::OK) state.SkipWithError(r.message.c_str());
  state.counters["voxels"] = double(image.geometry.voxel_count());
  state.counters["threshold"] = r.threshold;
  state.counters["components"] = r.components_kept;
  state.counters["branches"] = r.branch_count;
  state.counters["length_mm"] = r.total_length_mm;
}

/// A 256³ MRI-like volume at 0.8 mm (205 mm across): the brain phantom's labels as intensities
/// (brain 100, tumour 160, ventricles 30) plus a smooth bias and fine texture, so the samples
/// are not constant.
const VolumeF& mri_volume() {
  static const VolumeF volume = [] {
    const data_synth::PhantomGeometry phantom;
    VolumeF v(cube_256(0.8));
    const ImageGeometry& g = v.geometry;
    for (int k = 0; k < g.size[2]; ++k)
      for (int j = 0; j < g.size[1]; ++j)
        for (int i = 0; i < g.size[0]; ++i) {
          const Vector3d p = g.index_to_world(Vector3d(i, j, k));
          static constexpr float level[] = {0.0F, 100.0F, 160.0F, 30.0F};
          const float base = level[phantom.label_at(p)];
          v.at(i, j, k) = base * float(1.0 + 0.1 * std::sin(p.x() / 20.0) +
                                       0.05 * std::sin(p.y() * 1.3 + p.z()));
        }
    return v;
  }();
  return volume;
}

/// The phantom's brain as a 12-cell ellipsoid mesh (2,197 nodes, 10,368 tets) and a smooth
/// brain-shift-like displacement: a sag of up to 8 mm at the top with a sideways drift.
struct WarpScene {
  core::TetMesh mesh;
  MatrixX3d displacement;
};

const WarpScene& warp_scene() {
  static const WarpScene scene = [] {
    const data_synth::PhantomGeometry phantom;
    WarpScene s;
    s.mesh = data_synth::make_ellipsoid_mesh(phantom.semi_axes, /*cells=*/12, phantom.centre);
    s.displacement.resize(s.mesh.num_nodes(), 3);
    for (index_t n = 0; n < s.mesh.num_nodes(); ++n) {
      const Vector3d X = s.mesh.nodes().row(n).transpose() - phantom.centre;
      const double w = std::pow(std::clamp((X.z() + 60.0) / 120.0, 0.0, 1.0), 2.0);
      s.displacement.row(n) =
          Eigen::RowVector3d(2.0 * w * std::sin(X.y() / 25.0), 1.5 * w, -8.0 * w);
    }
    return s;
  }();
  return scene;
}

void BM_WarpImage256(benchmark::State& state) {
  const VolumeF& image = mri_volume();
  const WarpScene& s = warp_scene();
  imaging::WarpOptions options;
  options.threads = int(state.range(0));
  for (auto _ : state) {
    VolumeF out = imaging::warp_image(image, s.mesh, s.displacement, options);
    benchmark::DoNotOptimize(out.data.data());
  }
  state.counters["voxels"] = double(image.geometry.voxel_count());
  state.counters["nodes"] = double(s.mesh.num_nodes());
  state.counters["tets"] = double(s.mesh.num_tets());
}

/// register's forward fields on the 256³ grid: range(0) = 0, the two displacement_field() calls
/// (no extension, then extended: the former path); 1, displacement_fields() (one rasterisation).
void BM_ForwardFields256(benchmark::State& state) {
  const ImageGeometry& g = mri_volume().geometry;
  const WarpScene& s = warp_scene();
  imaging::DisplacementFieldOptions options;
  options.extension_mm = imaging::trilinear_support_mm(g);
  for (auto _ : state) {
    if (state.range(0) == 0) {
      imaging::DisplacementFieldOptions exact = options;
      exact.extension_mm = 0.0;
      VolumeF a = imaging::displacement_field(s.mesh, s.displacement, g, exact);
      VolumeF b = imaging::displacement_field(s.mesh, s.displacement, g, options);
      benchmark::DoNotOptimize(a.data.data());
      benchmark::DoNotOptimize(b.data.data());
    } else {
      imaging::ForwardDisplacementFields f =
          imaging::displacement_fields(s.mesh, s.displacement, g, options);
      benchmark::DoNotOptimize(f.exact.data.data());
    }
  }
  state.counters["voxels"] = double(g.voxel_count());
}

/// gzip of the 256³ MRI-like volume as float (64 MiB): range(0) = zlib level, range(1) = 1 for
/// the run-length strategy, range(2) = threads (imaging::gzip_buffer, as .nii.gz files are
/// written).
void BM_Gzip256(benchmark::State& state) {
  const VolumeF& image = mri_volume();
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() / "brainshift_bench_gzip.gz";
  imaging::GzipOptions o;
  o.level = int(state.range(0));
  o.run_length = state.range(1) != 0;
  o.threads = int(state.range(2));
  for (auto _ : state)
    imaging::gzip_buffer(image.data.data(), image.data.size() * sizeof(float), out, o);
  state.counters["ratio"] =
      double(std::filesystem::file_size(out)) / double(image.data.size() * sizeof(float));
  std::filesystem::remove(out);
}

/// One pass of the separable filter (a σ = 1.5-voxel Gaussian, 11 taps, renormalised at the
/// faces) along axis range(0) of the 256³ Doppler volume: the kernel of the vessel prefilter and
/// of the Hessian filters. Axis 0 reads contiguous lines; axes 1 and 2 strided ones.
void BM_FilterAxis256(benchmark::State& state) {
  const VolumeF& image = doppler_volume();
  const std::vector<double> kernel = imaging::filters::gaussian_kernel(1.5, 0);
  std::vector<float> data;
  for (auto _ : state) {
    state.PauseTiming();
    data = image.data;
    state.ResumeTiming();
    imaging::filters::filter_axis(data, image.geometry.size, int(state.range(0)), kernel,
                                  imaging::filters::MissingData::RENORMALISE);
    benchmark::DoNotOptimize(data.data());
  }
  state.counters["taps"] = double(kernel.size());
}

/// The default brain phantom's label volume at 1 mm (brain 140 × 170 × 120 mm before the base
/// cut, tumour r = 12 mm, two lateral ventricles).
const imaging::LabelVolume& brain_labels() {
  static const imaging::LabelVolume labels =
      data_synth::make_label_volume(data_synth::PhantomGeometry{});
  return labels;
}

/// range(0) = 0: MeshingOptions::coarse(); otherwise refined(range(0) / 10).
void BM_MeshLabels(benchmark::State& state) {
  const imaging::LabelVolume& labels = brain_labels();
  const imaging::MeshingOptions options =
      state.range(0) == 0 ? imaging::MeshingOptions::coarse()
                          : imaging::MeshingOptions::refined(double(state.range(0)) / 10.0);
  imaging::MeshingResult r;
  for (auto _ : state) {
    r = imaging::mesh_labels(labels, options);
    benchmark::DoNotOptimize(r.mesh);
  }
  state.counters["voxels"] = double(labels.geometry.voxel_count());
  state.counters["nodes"] = double(r.mesh.num_nodes());
  state.counters["tets"] = double(r.mesh.num_tets());
  state.counters["min_dihedral_deg"] = r.quality.min_dihedral_deg;
  state.counters["slivers"] = double(r.quality.sliver_count);  // tets with a dihedral angle < 5°
}

BENCHMARK(BM_ExtractVessels256)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1)
    ->Repetitions(5);
BENCHMARK(BM_FilterAxis256)
    ->ArgName("axis")
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1)
    ->Repetitions(5);
BENCHMARK(BM_WarpImage256)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1)
    ->Repetitions(5);
BENCHMARK(BM_ForwardFields256)
    ->ArgName("one_pass")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1)
    ->Repetitions(5);
BENCHMARK(BM_Gzip256)
    ->ArgNames({"level", "rle", "threads"})
    ->Args({6, 0, 1})
    ->Args({1, 0, 1})
    ->Args({1, 1, 1})
    ->Args({1, 1, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1)
    ->Repetitions(3);
BENCHMARK(BM_MeshLabels)
    ->ArgName("refine_x10")
    ->Arg(0)
    ->Arg(25)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1)
    ->Repetitions(3);

}  // namespace
}  // namespace brainshift::bench

BENCHMARK_MAIN();
