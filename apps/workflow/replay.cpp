#include "apps/workflow/replay.hpp"

#include "apps/workflow/model_folder.hpp"
#include "apps/workflow/pose_file.hpp"
#include "apps/workflow/result_report.hpp"
#include "apps/workflow/session.hpp"
#include "core/error.hpp"
#include "imaging/evaluation/metrics.hpp"
#include "imaging/io/output_guard.hpp"
#include "imaging/io/plus_sequence.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <iostream>
#include <optional>
#include <vector>

namespace brainshift::workflow {
namespace {

/// p-th percentile of the latencies (0 when there are none: every frame failed).
double latency_percentile(const std::vector<double>& v, double p) {
  return v.empty() ? 0.0 : imaging::percentile(v, p);
}

/// folder/stem+ext for the first extension present, else with the last one (named in the error).
std::filesystem::path first_present(const std::filesystem::path& folder, const std::string& stem,
                                    const std::vector<std::string>& extensions) {
  for (const std::string& e : extensions)
    if (std::filesystem::exists(folder / (stem + e))) return folder / (stem + e);
  return folder / (stem + extensions.back());
}

}  // namespace

ReplayResult replay_sequence(const ReplayOptions& args, const Progress& progress) {
  std::error_code ec;
  BS_VERIFY(std::filesystem::is_directory(args.sequence, ec), args.sequence.string()
                                                                  << ": no such folder");
  // The sweeps: frame_*/ folders (doppler.nii.gz, doppler.seq.mha or doppler.nrrd — as `serve`
  // records what it received — optional bmode.nii.gz or bmode.nrrd),
  // else the folder's PLUS sequence files (*.seq.mha, *.seq.nrrd; one sweep each), in name order.
  std::vector<std::filesystem::path> frames;
  for (const auto& e : std::filesystem::directory_iterator(args.sequence, ec))
    if (e.is_directory() && e.path().filename().string().rfind("frame_", 0) == 0)
      frames.push_back(e.path());
  if (frames.empty())
    for (const auto& e : std::filesystem::directory_iterator(args.sequence, ec))
      if (e.is_regular_file() && imaging::is_plus_sequence(e.path())) frames.push_back(e.path());
  std::sort(frames.begin(), frames.end());
  BS_VERIFY(!frames.empty(),
            args.sequence.string()
                << ": no frame_* folders and no PLUS sequence files (*.seq.mha, *.seq.nrrd)");
  BS_VERIFY(!(args.pre_dura && args.pre_dura_pose),
            args.pre_dura_pose->string() << ": give a pre-dura sweep or a stored pose, not both");
  verify_output_folder(args.out);
  const imaging::OutputLock lock(args.out);  // one run writes RES at a time
  progress.stage("loading the model " + args.model.string());
  Session s = open_session(args.model);

  nlohmann::json summary = {{"model", args.model.string()},
                            {"sequence", args.sequence.string()},
                            {"frames", nlohmann::json::array()}};
  // The navigation offset from the pre-dura sweep, once, before anything is written.
  if (args.pre_dura)
    progress.stage("the navigation offset from the pre-dura sweep " + args.pre_dura->string());
  if (args.pre_dura_pose)
    progress.stage("the navigation offset stored in " + args.pre_dura_pose->string());
  nlohmann::json measured_pose;
  const std::optional<Eigen::Isometry3d> pose =
      args.pre_dura || args.pre_dura_pose
          ? given_pose(s, args.pre_dura, args.pre_dura_pose, s.loaded.scene.options,
                       summary["pre_dura"], measured_pose)
          : std::nullopt;
  std::vector<double> latency;
  int failed = 0, unconverged = 0;
  std::optional<constraints::RegistrationResult> previous;
  write_folder_atomically(args.out, [&](const std::filesystem::path& dir) {
    for (const auto& f : frames) {
      const bool sweep_file = imaging::is_plus_sequence(f);
      std::string name = f.filename().string();
      if (sweep_file) {  // without .seq.mha / .seq.nrrd (any case)
        std::string lower = name;
        for (char& c : lower) c = char(std::tolower(static_cast<unsigned char>(c)));
        name.resize(lower.rfind(".seq."));
      }
      progress.stage(name);
      nlohmann::json entry = {{"frame", name}};
      try {
        const std::filesystem::path bmode = first_present(f, "bmode", {".nii.gz", ".nrrd"});
        const std::filesystem::path doppler =
            sweep_file ? f : first_present(f, "doppler", {".seq.mha", ".nrrd", ".nii.gz"});
        IntraopInputs in = read_intraop(s, doppler,
                                        !sweep_file && std::filesystem::exists(bmode)
                                            ? std::optional<std::filesystem::path>(bmode)
                                            : std::nullopt);
        in.data.pose = pose;
        const constraints::RegistrationResult r = constraints::register_model(
            *s.model, in.data, s.loaded.scene.options, previous ? &*previous : nullptr);
        const bool with_uncertainty =
            args.uncertainty == "every" || (args.uncertainty == "last" && f == frames.back());
        write_result(dir / name, s, r, in, nullptr,
                     {{"frame", name}, {"warm_start", previous.has_value()}}, with_uncertainty);
        const double seconds = in.seconds + r.seconds.total;
        latency.push_back(seconds);
        entry.update({{"status", r.converged ? "ok" : "not_converged"},
                      {"iterations", r.iterations},
                      {"stop", constraints::to_string(r.stop)},
                      {"stop_reason", r.stop_reason},
                      {"cold_retry", r.cold_retry},
                      {"latency_s", seconds},
                      {"warm_start", previous.has_value()},
                      {"uncertainty", with_uncertainty}});
        if (!r.converged) ++unconverged;
        if (r.converged) previous = r;  // warm-start only from a trustworthy frame
      } catch (const Error& e) {
        ++failed;
        entry.update({{"status", "failed"}, {"error", e.what()}});
        std::cerr << "brainshift replay: " << name << " failed: " << e.what() << "\n";
      }
      summary["frames"].push_back(entry);
    }
    summary["latency_s"] = {
        {"median", latency_percentile(latency, 50)},
        {"p95", latency_percentile(latency, 95)},
        {"max", latency.empty() ? 0.0 : *std::max_element(latency.begin(), latency.end())}};
    summary["failed"] = failed;
    summary["not_converged"] = unconverged;
    std::ofstream(dir / "replay.json") << summary.dump(2) << '\n';
    if (!measured_pose.is_null())
      std::ofstream(dir / pose_file_name) << measured_pose.dump(2) << '\n';
  });
  ReplayResult result;
  result.summary = std::move(summary);
  result.frames = static_cast<int>(frames.size());
  result.failed = failed;
  result.unconverged = unconverged;
  return result;
}

}  // namespace brainshift::workflow
