#include "cmd_extract.hpp"

#include "core/error.hpp"
#include "core/timing.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/skeleton_io.hpp"
#include "imaging/overlay/png_encode.hpp"
#include "imaging/vessels/vessel_extraction.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <vector>

namespace brainshift::apps {
namespace {

/// Writes `bytes` to `path` atomically.
void write_bytes(const std::filesystem::path& path, const std::string& bytes) {
  imaging::write_atomically(path, [&](const std::filesystem::path& temporary) {
    std::ofstream file(temporary, std::ios::binary);
    file.write(bytes.data(), std::streamsize(bytes.size()));
    file.close();
    BS_VERIFY(file.good(), path.string() << ": cannot write");
  });
}

/// PNG bytes of the maximum-intensity projection of `image` along the index axis closest to the
/// world S axis, pixels square (the finer in-plane spacing), grey from the finite minimum to the
/// maximum, with the branches of `graph` drawn in red.
std::string mip_png(const imaging::VolumeF& image, const imaging::VesselGraph& graph) {
  const imaging::ImageGeometry& g = image.geometry;
  int axis = 0;
  g.direction.row(2).cwiseAbs().maxCoeff(&axis);
  const int u = axis == 0 ? 1 : 0, v = axis == 2 ? 1 : 2;
  cv::Mat mip(g.size[v], g.size[u], CV_32F, cv::Scalar(-std::numeric_limits<float>::infinity()));
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        const float x = image.at(i, j, k);
        if (!std::isfinite(x)) continue;
        const int ijk[3] = {i, j, k};
        float& m = mip.at<float>(ijk[v], ijk[u]);
        m = std::max(m, x);
      }
  double lo = 0.0, hi = 0.0;
  cv::Mat finite = mip > -std::numeric_limits<float>::infinity();
  cv::minMaxLoc(mip, &lo, &hi, nullptr, nullptr, finite);
  mip.setTo(lo, ~finite);
  cv::Mat grey;
  mip.convertTo(grey, CV_8U, hi > lo ? 255.0 / (hi - lo) : 0.0,
                hi > lo ? -255.0 * lo / (hi - lo) : 0.0);
  // Square pixels of the finer in-plane spacing, at least 512 and at most 2048 on the long side.
  const double h = std::min(g.spacing[u], g.spacing[v]);
  double su = g.spacing[u] / h, sv = g.spacing[v] / h;
  const double longest = std::max(su * g.size[u], sv * g.size[v]);
  const double zoom = std::clamp(512.0 / longest, 1.0, 2048.0 / std::max(longest, 1.0));
  su *= zoom;
  sv *= zoom;
  cv::Mat shown;
  cv::resize(grey, shown,
             cv::Size(std::max(1, int(std::lround(su * g.size[u]))),
                      std::max(1, int(std::lround(sv * g.size[v])))),
             0, 0, cv::INTER_LINEAR);
  cv::cvtColor(shown, shown, cv::COLOR_GRAY2BGR);
  const auto pixel = [&](const Vector3d& p) {
    const Vector3d ijk = g.world_to_index(p);
    return cv::Point2d((ijk[u] + 0.5) * su, (ijk[v] + 0.5) * sv);
  };
  for (const auto& b : graph.branches) {
    std::vector<cv::Point> line;
    for (const auto& p : b.points) {
      const cv::Point2d q = pixel(p);
      line.emplace_back(int(std::lround(q.x)), int(std::lround(q.y)));
    }
    cv::polylines(shown, line, false, cv::Scalar(0, 0, 255), 1, cv::LINE_AA);
  }
  std::vector<unsigned char> bytes;
  BS_VERIFY(imaging::encode_png(shown, bytes),
            "cannot encode the maximum-intensity projection as PNG");
  return {bytes.begin(), bytes.end()};
}

}  // namespace

CLI::App* add_extract_command(CLI::App& app) {
  CLI::App* c =
      app.add_subcommand("extract", "One extraction alone, to check an input: vessels (and more)");
  c->require_subcommand(1);
  return c;
}

CLI::App* add_extract_vessels_command(CLI::App& extract, ExtractVesselsArgs& args) {
  CLI::App* c = extract.add_subcommand("vessels",
                                       "Vessel skeleton of an MRA, CTA or power Doppler "
                                       "(polylines, RAS mm, as prepare's vessels.vtp)");
  c->add_option("--image", args.image,
                "angiogram or power-Doppler volume (.nii, .nii.gz, .mha, .nrrd, .vti)")
      ->required();
  c->add_option("--out", args.out, "skeleton .vtp to write")->required();
  c->add_option("--report", args.report,
                "report .json to write (branches, length_mm, points, threshold, seconds, ...)");
  c->add_option("--png", args.png,
                "maximum-intensity projection with the skeleton drawn over it (.png)");
  c->add_option("--prefilter", args.prefilter_mm, "Gaussian pre-filter sigma, mm (0: none)")
      ->check(CLI::Range(0.0, 5.0))
      ->capture_default_str();
  return c;
}

int run_extract_vessels(const ExtractVesselsArgs& args, std::ostream& out) {
  imaging::verify_writable(args.out);
  if (args.report) imaging::verify_writable(*args.report);
  if (args.png) imaging::verify_writable(*args.png);
  const std::string file = args.image.string();
  std::string header_note;
  const imaging::VolumeF image = imaging::read_volume(args.image, &header_note);
  BS_VERIFY(image.components == 1,
            file << ": expected a scalar image, got " << image.components << " components");

  imaging::VesselExtractionOptions options;
  options.prefilter_sigma_mm = args.prefilter_mm;
  const core::Stopwatch watch;
  const imaging::VesselExtractionResult r = imaging::extract_vessels(image, options);
  const double seconds = watch.seconds();
  BS_VERIFY(r.non_finite_voxels < image.geometry.voxel_count(),
            file << ": every voxel is NaN or infinite");
  BS_VERIFY(r.status == imaging::VesselStatus::OK,
            file << ": no vessels found (" << r.message << ")");

  const core::Skeleton skeleton = imaging::to_skeleton(r.graph);
  std::vector<std::string> warnings = r.warnings;
  const auto json_or_null = [](double x) {
    return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
  };
  nlohmann::json report = {
      {"image",
       {{"file", std::filesystem::absolute(args.image).string()},
        {"size", {image.geometry.size[0], image.geometry.size[1], image.geometry.size[2]}},
        {"spacing_mm",
         {image.geometry.spacing[0], image.geometry.spacing[1], image.geometry.spacing[2]}}}},
      {"branches", r.branch_count},
      {"length_mm", r.total_length_mm},
      {"points", skeleton.points.rows()},
      {"threshold", r.threshold},
      {"threshold_rule", r.threshold_rule},
      {"vessel_level", json_or_null(r.vessel_level)},
      {"background_level", json_or_null(r.noise_median)},
      {"noise_sigma", json_or_null(r.noise_sigma)},
      {"background_suppressed", r.background_suppressed},
      {"masked_fraction", r.masked_fraction},
      {"junctions", r.junction_count},
      {"points_at_support_edge", r.points_at_support_edge},
      {"endpoints", r.endpoint_count},
      {"components",
       {{"found", r.components_found},
        {"kept", r.components_kept},
        {"not_tubular", r.components_not_tubular}}},
      {"nan_voxels", r.non_finite_voxels},
      {"prefilter_mm", args.prefilter_mm},
      {"seconds", seconds},
      {"header_notes",
       header_note.empty() ? nlohmann::json::array() : nlohmann::json::array({header_note})},
      {"warnings", warnings}};

  imaging::write_skeleton_vtp(args.out, r.graph);
  if (args.report) write_bytes(*args.report, report.dump(2) + "\n");
  if (args.png) write_bytes(*args.png, mip_png(image, r.graph));
  for (const std::string& w : warnings)
    std::cerr << "brainshift: warning: " << file << ": " << w << '\n';
  out << "extracted " << args.out.string() << ": " << r.branch_count << " branches, "
      << static_cast<int>(std::lround(r.total_length_mm)) << " mm, " << skeleton.points.rows()
      << " points, threshold " << r.threshold << " (" << r.threshold_rule << ") in " << seconds
      << " s\n";
  return 0;
}

}  // namespace brainshift::apps
