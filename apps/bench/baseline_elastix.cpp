#include "apps/bench/baseline_elastix.hpp"

#include "core/timing.hpp"
#include "imaging/io/image_io.hpp"

#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>

namespace brainshift::workflow {
namespace {

/// The settings both stages share (elastix's parameter-file syntax).
std::string common_parameters(const ElastixOptions& o) {
  std::ostringstream p;
  p << "(FixedInternalImagePixelType \"float\")\n(MovingInternalImagePixelType \"float\")\n"
    << "(FixedImageDimension 3)\n(MovingImageDimension 3)\n(UseDirectionCosines \"true\")\n"
    << "(Registration \"MultiResolutionRegistration\")\n"
    << "(Interpolator \"BSplineInterpolator\")\n(BSplineInterpolationOrder 1)\n"
    << "(ResampleInterpolator \"FinalBSplineInterpolator\")\n(FinalBSplineInterpolationOrder 3)\n"
    << "(Resampler \"DefaultResampler\")\n"
    << "(FixedImagePyramid \"FixedSmoothingImagePyramid\")\n"
    << "(MovingImagePyramid \"MovingSmoothingImagePyramid\")\n"
    << "(Optimizer \"AdaptiveStochasticGradientDescent\")\n"
    << "(Metric \"AdvancedMattesMutualInformation\")\n(NumberOfHistogramBins 32)\n"
    << "(NumberOfResolutions " << o.resolutions << ")\n"
    << "(ImageSampler \"RandomCoordinate\")\n(NumberOfSpatialSamples " << o.samples << ")\n"
    << "(NewSamplesEveryIteration \"true\")\n(ErodeMask \"false\")\n"
    << "(HowToCombineTransforms \"Compose\")\n(WriteResultImage \"false\")\n"
    << "(DefaultPixelValue 0)\n";
  return p.str();
}

void write_text(const std::filesystem::path& p, const std::string& text) {
  std::ofstream f(p);
  f << text;
}

/// Runs a shell command with its output in `log`; true on exit status 0.
bool run(const std::string& command, const std::filesystem::path& log) {
  const std::string line = command + " > \"" + log.string() + "\" 2>&1";
  return std::system(line.c_str()) == 0;
}

/// transformix of `points_file` through `parameters` into `dir`; the mapped points in RAS.
MatrixX3d transform_points(const std::filesystem::path& points_file,
                           const std::filesystem::path& parameters,
                           const std::filesystem::path& dir, Eigen::Index count,
                           std::string& error) {
  std::filesystem::create_directories(dir);
  if (!run("transformix -def \"" + points_file.string() + "\" -tp \"" + parameters.string() +
               "\" -out \"" + dir.string() + "\"",
           dir / "transformix.out")) {
    error = "transformix failed (see " + (dir / "transformix.out").string() + ")";
    return {};
  }
  std::ifstream in(dir / "outputpoints.txt");
  const std::regex out(R"(OutputPoint = \[ ([^ ]+) ([^ ]+) ([^ ]+) \])");
  MatrixX3d p(count, 3);
  std::string line;
  Eigen::Index i = 0;
  while (std::getline(in, line) && i < count) {
    std::smatch m;
    if (!std::regex_search(line, m, out)) continue;
    // ITK's physical space is LPS: back to RAS.
    p.row(i++) << -std::stod(m[1]), -std::stod(m[2]), std::stod(m[3]);
  }
  if (i != count) {
    error = "transformix mapped " + std::to_string(i) + " of " + std::to_string(count) + " points";
    return {};
  }
  return p;
}

}  // namespace

bool elastix_available() {
  return std::system(
             "command -v elastix > /dev/null 2>&1 && command -v transformix > /dev/null "
             "2>&1") == 0;
}

ElastixResult elastix_register(const std::filesystem::path& mra,
                               const std::filesystem::path& doppler,
                               const std::filesystem::path& bmode, ConstRef<MatrixX3d> intra_points,
                               const std::filesystem::path& work, const ElastixOptions& o) {
  ElastixResult r;
  const core::Stopwatch watch;
  try {
    std::filesystem::create_directories(work / "out");
    // The mask: the sweep's region on the fixed image's grid.
    imaging::VolumeF fixed = imaging::read_volume(doppler);
    std::filesystem::path mask;
    if (std::filesystem::exists(bmode)) {
      imaging::VolumeF b = imaging::read_volume(bmode);
      if (b.geometry.size == fixed.geometry.size &&
          (b.geometry.origin - fixed.geometry.origin).norm() < 1e-6)
        fixed = std::move(b);
    }
    for (float& v : fixed.data) v = v > 0.0F ? 1.0F : 0.0F;
    mask = work / "mask.nii.gz";
    imaging::write_volume(mask, fixed);

    const std::string common = common_parameters(o);
    write_text(work / "rigid.txt", common +
                                       "(Transform \"EulerTransform\")\n"
                                       "(AutomaticScalesEstimation \"true\")\n"
                                       "(AutomaticTransformInitialization \"false\")\n"
                                       "(MaximumNumberOfIterations " +
                                       std::to_string(o.rigid_iterations) + ")\n");
    std::ostringstream spacing;
    spacing << o.grid_spacing_mm;
    write_text(work / "bspline.txt", common +
                                         "(Transform \"BSplineTransform\")\n"
                                         "(FinalGridSpacingInPhysicalUnits " +
                                         spacing.str() +
                                         ")\n"
                                         "(MaximumNumberOfIterations " +
                                         std::to_string(o.bspline_iterations) + ")\n");
    {
      std::ofstream pts(work / "points.txt");
      pts.precision(10);
      pts << "point\n" << intra_points.rows() << "\n";
      for (Eigen::Index i = 0; i < intra_points.rows(); ++i)  // RAS → ITK's LPS
        pts << -intra_points(i, 0) << ' ' << -intra_points(i, 1) << ' ' << intra_points(i, 2)
            << '\n';
    }
    if (!run("elastix -f \"" + doppler.string() + "\" -m \"" + mra.string() + "\" -fMask \"" +
                 mask.string() + "\" -p \"" + (work / "rigid.txt").string() + "\" -p \"" +
                 (work / "bspline.txt").string() + "\" -out \"" + (work / "out").string() +
                 "\" -threads " + std::to_string(o.threads),
             work / "elastix.out")) {
      r.error = "elastix failed (see " + (work / "elastix.out").string() + ")";
      return r;
    }
    r.rigid = transform_points(work / "points.txt", work / "out/TransformParameters.0.txt",
                               work / "rigid", intra_points.rows(), r.error);
    if (r.error.empty())
      r.bspline = transform_points(work / "points.txt", work / "out/TransformParameters.1.txt",
                                   work / "bspline", intra_points.rows(), r.error);
    r.ok = r.error.empty() && r.rigid.allFinite() && r.bspline.allFinite();
    if (!r.ok && r.error.empty()) r.error = "elastix gave non-finite points";
  } catch (const std::exception& e) {
    r.error = e.what();
  }
  r.seconds = watch.seconds();
  return r;
}

}  // namespace brainshift::workflow
