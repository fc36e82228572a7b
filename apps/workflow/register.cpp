#include "apps/workflow/register.hpp"

#include "apps/workflow/model_folder.hpp"
#include "apps/workflow/result_report.hpp"
#include "apps/workflow/session.hpp"

#include <string>

namespace brainshift::workflow {

RegisterOutcome register_and_write(const RegisterOptions& args, const Progress& progress) {
  verify_output_folder(args.out);
  progress.stage("loading the model " + args.model.string());
  Session s = open_session(args.model);
  progress.stage("extracting vessels" + std::string(args.bmode ? " and the probe footprint" : ""));
  IntraopInputs in = read_intraop(s, args.doppler, args.bmode);
  const std::optional<imaging::VolumeF> mri =
      args.mri ? std::optional<imaging::VolumeF>(read_preop_mri(s, *args.mri)) : std::nullopt;
  constraints::RegistrationOptions options = s.loaded.scene.options;
  if (args.init == "rigid") options.start = constraints::RigidStart::RIGID;
  if (args.init == "identity") options.start = constraints::RigidStart::IDENTITY;
  if (args.pre_dura) {
    progress.stage("the navigation offset from the pre-dura sweep " + args.pre_dura->string());
    in.data.pose = pose_from_pre_dura(s, *args.pre_dura, options, in.report["pre_dura"]);
  }
  progress.stage("registering (" + std::to_string(in.data.vessel_points.rows()) +
                 " vessel points, " + std::to_string(in.data.footprint_points.rows()) +
                 " footprint points)");
  RegisterOutcome o;
  o.result = constraints::register_model(*s.model, in.data, options);
  progress.stage("writing " + args.out.string());
  write_result(args.out, s, o.result, in, mri ? &*mri : nullptr, {});
  const constraints::RegistrationResult& r = o.result;
  o.max_displacement_mm = r.displacement.rows() ? r.displacement.rowwise().norm().maxCoeff() : 0.0;
  return o;
}

}  // namespace brainshift::workflow
