// BrainshiftRegister: `brainshift register` as a 3D Slicer command-line module.
//
//   BrainshiftRegister --xml                      (the module description Slicer reads)
//   BrainshiftRegister --model MODEL --doppler D.nrrd [--bmode B.nrrd]
//                      [--preDura P.nrrd | --preDuraPose POSE.json]
//                      [--preopMRI M.nrrd]
//                      [--warpedMRI W.nrrd] [--preopToIntraop P.nrrd] [--intraopToPreop I.nrrd]
//                      [--reportFile R.json] [--init scene|rigid|identity] [--resultDirectory RES]
//
// The same functions as `brainshift register` (open_session, read_intraop, read_preop_mri,
// register_model, compute_result_fields), with the outputs at the paths Slicer gives, written all
// or none (staged_outputs.hpp). Progress goes to stdout in Slicer's <filter-progress> tags.
// Exit codes: 0 results written (also when the registration stopped without converging: Slicer
// loads outputs only after exit code 0, so that case is a warning line on stderr and in the
// report); 1 bad input (one line on stderr naming the file; nothing written).

#include "../cmd_register.hpp"
#include "module_description.hpp"
#include "slicer_modules.hpp"
#include "staged_outputs.hpp"

#include "apps/workflow/model_folder.hpp"
#include "apps/workflow/pose_file.hpp"
#include "apps/workflow/result_fields.hpp"
#include "core/blas_threads.hpp"
#include "core/error.hpp"
#include "core/process_memory.hpp"
#include "core/timing.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/nrrd_io.hpp"

#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>

namespace brainshift::apps::slicer {
namespace {

using core::Clock;
using core::seconds_since;

std::optional<std::filesystem::path> optional_path(const Values& v, const char* name) {
  const auto it = v.find(name);
  if (it == v.end() || it->second.empty()) return std::nullopt;
  return std::filesystem::path(it->second);
}

bool has_extension(const std::filesystem::path& p, const std::string& ext) {
  std::string name = p.filename().string();
  for (char& c : name) c = char(std::tolower(static_cast<unsigned char>(c)));
  return name.size() >= ext.size() && name.compare(name.size() - ext.size(), ext.size(), ext) == 0;
}

/// The module's paths (absent: not given).
struct RegisterPaths {
  std::filesystem::path model, doppler;
  std::optional<std::filesystem::path> bmode, pre_dura, pre_dura_pose, mri, warped, to_intra,
      to_pre, report, result_dir;
};

RegisterPaths paths_of(const Values& v) {
  RegisterPaths p;
  p.model = v.at("model");
  p.doppler = v.at("doppler");
  p.bmode = optional_path(v, "bmode");
  p.pre_dura = optional_path(v, "preDura");
  p.pre_dura_pose = optional_path(v, "preDuraPose");
  p.mri = optional_path(v, "preopMRI");
  p.warped = optional_path(v, "warpedMRI");
  p.to_intra = optional_path(v, "preopToIntraop");
  p.to_pre = optional_path(v, "intraopToPreop");
  p.report = optional_path(v, "reportFile");
  p.result_dir = optional_path(v, "resultDirectory");
  return p;
}

/// Everything that can be checked before the long work. \throws brainshift::Error, one line.
void check_outputs(const RegisterPaths& p) {
  BS_VERIFY(
      p.warped || p.to_intra || p.to_pre || p.report || p.result_dir,
      "no output requested: give at least one of --warpedMRI, --preopToIntraop, --intraopToPreop, "
      "--reportFile, --resultDirectory");
  BS_VERIFY(!(p.pre_dura && p.pre_dura_pose),
            p.pre_dura_pose->string() << ": give a pre-dura Doppler or a stored pose, not both");
  BS_VERIFY(!p.warped || p.mri, p.warped->string()
                                    << ": the warped MRI needs the pre-operative MRI (--preopMRI)");
  for (const auto& t : {p.to_intra, p.to_pre})
    if (t)
      BS_VERIFY(has_extension(*t, ".nrrd"),
                t->string() << ": a transform is written as a .nrrd displacement field");
  for (const auto& f : {p.warped, p.to_intra, p.to_pre, p.report})
    if (f) imaging::verify_writable(*f);
  if (p.result_dir) {
    workflow::verify_output_folder(*p.result_dir);
    verify_replaceable_folder(*p.result_dir, "report.json");
  }
}

/// Writes the requested outputs, all or none.
void write_outputs(const RegisterPaths& p, const workflow::Session& s,
                   const constraints::RegistrationResult& r, const workflow::IntraopInputs& in,
                   const imaging::VolumeF* mri, const workflow::ResultFields& f,
                   Clock::time_point t_out, double seconds_fields) {
  StagedOutputs outputs;
  if (p.warped) {
    outputs.add(*p.warped, [&](const std::filesystem::path& tmp) {
      // Slicer's own convention for NRRD volumes is LPS; other formats by their extension.
      if (has_extension(*p.warped, ".nrrd"))
        imaging::write_nrrd(tmp, *f.warped_mri, imaging::NrrdSpace::LPS);
      else
        imaging::write_volume(tmp, *f.warped_mri);
    });
  }
  if (p.to_intra)
    outputs.add(*p.to_intra, [&](const std::filesystem::path& tmp) {
      imaging::write_displacement_for_slicer(tmp, f.preop_to_intraop);
    });
  if (p.to_pre)
    outputs.add(*p.to_pre, [&](const std::filesystem::path& tmp) {
      imaging::write_displacement_for_slicer(tmp, f.intraop_to_preop);
    });
  const nlohmann::json extra = {{"slicer_module", "BrainshiftRegister"}};
  if (p.report) {
    nlohmann::json report = workflow::result_report(s, r, in, extra);
    report["timing"]["outputs"] = seconds_since(t_out);
    double total = 0;
    for (const char* k : {"load_model", "extraction", "registration", "outputs"})
      total += report["timing"][k].get<double>();
    report["timing"]["total"] = total;
    outputs.add(*p.report, [&](const std::filesystem::path& tmp) {
      std::ofstream o(tmp);
      o << report.dump(2) << '\n';
      o.close();
      BS_VERIFY(o.good(), p.report->string() << ": cannot write the report");
    });
  }
  if (p.result_dir) workflow::write_result(*p.result_dir, s, r, in, mri, f, extra, seconds_fields);
  outputs.commit();
}

int register_body(const Values& v, const ProgressReport& progress) {
  const auto t0 = Clock::now();
  const RegisterPaths p = paths_of(v);
  check_outputs(p);
  progress("loading the model " + p.model.string(), 0.05);
  workflow::Session s = workflow::open_session(p.model);
  progress("extracting vessels" + std::string(p.bmode ? " and the probe footprint" : ""), 0.25);
  workflow::IntraopInputs in = workflow::read_intraop(s, p.doppler, p.bmode);
  const std::optional<imaging::VolumeF> mri =
      p.mri ? std::optional<imaging::VolumeF>(workflow::read_preop_mri(s, *p.mri)) : std::nullopt;
  constraints::RegistrationOptions options = s.loaded.scene.options;
  const std::string init = v.count("init") ? v.at("init") : "scene";
  if (init == "rigid") options.start = constraints::RigidStart::RIGID;
  if (init == "identity") options.start = constraints::RigidStart::IDENTITY;
  if (p.pre_dura || p.pre_dura_pose) {  // the navigation offset before the dura was opened
    progress("the navigation offset from the pre-dura sweep", 0.35);
    // A measured pose is stored in the result directory (when one is given), as register does.
    in.data.pose = workflow::given_pose(s, p.pre_dura, p.pre_dura_pose, options,
                                        in.report["pre_dura"], in.measured_pose);
  }
  progress("registering (" + std::to_string(in.data.vessel_points.rows()) + " vessel points, " +
               std::to_string(in.data.footprint_points.rows()) + " footprint points)",
           0.4);
  const constraints::RegistrationResult r = constraints::register_model(*s.model, in.data, options);

  progress("computing the transforms" + std::string(mri ? " and the warped MRI" : ""), 0.7);
  const auto t_out = Clock::now();
  const workflow::ResultFields f = workflow::compute_result_fields(s, r, mri ? &*mri : nullptr);
  progress("writing the outputs", 0.85);
  write_outputs(p, s, r, in, mri ? &*mri : nullptr, f, t_out, seconds_since(t_out));

  std::cout << "registered in " << r.iterations << " iterations (" << r.stop_reason
            << "); registration " << r.seconds.total << " s, total " << seconds_since(t0)
            << " s; max displacement "
            << (r.displacement.rows() ? r.displacement.rowwise().norm().maxCoeff() : 0.0)
            << " mm\n";
  if (!r.converged)
    std::cerr << "BrainshiftRegister: warning: the registration did not converge: " << r.stop_reason
              << " (results written; see the report)\n";
  return 0;
}

}  // namespace
}  // namespace brainshift::apps::slicer

int main(int argc, char** argv) {
  namespace slicer = brainshift::apps::slicer;
  // Allocates and frees volumes of tens of MB and ends soon after: reuse freed memory instead of
  // faulting in fresh pages for each (core/process_memory.hpp).
  (void)brainshift::core::keep_freed_memory_for_reuse();
  (void)brainshift::core::one_blas_thread_unless_set();  // core/blas_threads.hpp
  return slicer::run_module(argc, argv, "BrainshiftRegister", slicer::register_module(),
                            slicer::register_body);
}
