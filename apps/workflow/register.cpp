#include "apps/workflow/register.hpp"

#include "apps/workflow/intraop_frame.hpp"
#include "apps/workflow/model_folder.hpp"
#include "apps/workflow/pose_file.hpp"
#include "apps/workflow/result_report.hpp"
#include "apps/workflow/session.hpp"
#include "core/error.hpp"
#include "imaging/evaluation/metrics.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/landmark_files.hpp"
#include "imaging/io/output_guard.hpp"

#include <exception>
#include <future>
#include <optional>
#include <string>

namespace brainshift::workflow {
namespace {

/// What register reads without the model: the Doppler's vessels and the MRI (its read error
/// kept, to be reported after the Doppler's, as a serial run does).
struct Images {
  DopplerExtraction doppler;
  std::optional<imaging::VolumeF> mri;
  std::exception_ptr mri_failure;
};

/// The landmark pairs of `register --landmarks` (RegisterOptions::landmarks) into the data:
/// the pre-operative set as model points, the intra-operative one as their targets.
void add_landmarks(const std::vector<std::filesystem::path>& files, IntraopInputs& in) {
  BS_VERIFY(files.size() == 1 || files.size() == 2,
            "--landmarks: give one file of pairs (a two-volume .tag) or two files (pre-operative, "
            "intra-operative), not "
                << files.size());
  const imaging::Landmarks pre =
      imaging::read_landmark_file(files.front(), imaging::TagVolume::FIRST);
  const imaging::Landmarks intra =
      imaging::read_landmark_file(files.back(), imaging::TagVolume::SECOND);
  BS_VERIFY(files.size() == 2 || pre.points != intra.points,
            files.front().string()
                << ": one set of points, not pairs (give a two-volume .tag, or a second file)");
  const imaging::LandmarkPairs pairs =
      imaging::match_landmarks_by_id(pre.ids, pre.points, intra.ids, intra.points);
  BS_VERIFY(!pairs.ids.empty(), files.front().string() << " and " << files.back().string()
                                                       << ": no landmark id in common");
  in.data.landmark_model_points = pairs.a;
  in.data.landmark_targets = pairs.b;
  nlohmann::json names = nlohmann::json::array();
  for (const auto& f : files) names.push_back(f.string());
  in.report["landmarks"] = {
      {"files", names}, {"pairs", pairs.ids.size()}, {"unpaired", pairs.warnings}};
}

}  // namespace

RegisterOutcome register_and_write(const RegisterOptions& args, const Progress& progress) {
  BS_VERIFY(!(args.pre_dura && args.pre_dura_pose),
            args.pre_dura_pose->string() << ": give a pre-dura sweep or a stored pose, not both");
  verify_output_folder(args.out);
  const imaging::OutputLock lock(args.out);  // one run writes RES at a time
  progress.stage("loading the model " + args.model.string());
  // The images do not need the model: the Doppler is read and its vessels extracted, and the MRI
  // read, on a second thread while the model loads. Errors come in a serial run's order: the
  // model's (the future waits for the images when it propagates), the Doppler's, the MRI's.
  std::future<Images> reading = std::async(std::launch::async, [&args] {
    Images im;
    im.doppler = extract_doppler(args.doppler);
    try {
      if (args.mri) im.mri = imaging::read_volume(*args.mri);
    } catch (...) {
      im.mri_failure = std::current_exception();
    }
    return im;
  });
  Session s = open_session(args.model);
  progress.stage("extracting vessels" + std::string(args.bmode ? " and the probe footprint" : ""));
  Images images = reading.get();
  IntraopInputs in = read_intraop(s, images.doppler, args.bmode);
  if (!args.landmarks.empty()) add_landmarks(args.landmarks, in);
  if (images.mri_failure) std::rethrow_exception(images.mri_failure);
  const std::optional<imaging::VolumeF> mri =
      args.mri
          ? std::optional<imaging::VolumeF>(read_preop_mri(s, *args.mri, std::move(*images.mri)))
          : std::nullopt;
  images.mri.reset();
  constraints::RegistrationOptions options = s.loaded.scene.options;
  if (args.init == "rigid") options.start = constraints::RigidStart::RIGID;
  if (args.init == "identity") options.start = constraints::RigidStart::IDENTITY;
  if (args.pre_dura)
    progress.stage("the navigation offset from the pre-dura sweep " + args.pre_dura->string());
  if (args.pre_dura_pose)
    progress.stage("the navigation offset stored in " + args.pre_dura_pose->string());
  if (args.pre_dura || args.pre_dura_pose)
    in.data.pose = given_pose(s, args.pre_dura, args.pre_dura_pose, options, in.report["pre_dura"],
                              in.measured_pose);
  progress.stage("registering (" + std::to_string(in.data.vessel_points.rows()) +
                 " vessel points, " + std::to_string(in.data.footprint_points.rows()) +
                 " footprint points)");
  RegisterOutcome o;
  o.result = constraints::register_model(*s.model, in.data, options);
  progress.stage("writing " + args.out.string());
  // The wall time until the outputs begin (the parts' times overlap: the model loads while the
  // Doppler is read); write_result adds the outputs' for timing.elapsed.
  write_result(args.out, s, o.result, in, mri ? &*mri : nullptr,
               {{"timing", {{"elapsed_before_outputs", progress.seconds()}}}});
  const constraints::RegistrationResult& r = o.result;
  o.max_displacement_mm = r.displacement.rows() ? r.displacement.rowwise().norm().maxCoeff() : 0.0;
  o.fixed_base_note = fixed_base_note(fixed_base_motion(r, *s.model), in.data.pose.has_value(),
                                      navigation_yardstick_mm(options));
  return o;
}

}  // namespace brainshift::workflow
