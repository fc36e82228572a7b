// BrainshiftRegister: `brainshift register` as a 3D Slicer command-line module.
//
//   BrainshiftRegister --xml                      (the module description Slicer reads)
//   BrainshiftRegister --model MODEL --doppler D.nrrd [--bmode B.nrrd] [--preopMRI M.nrrd]
//                      [--warpedMRI W.nrrd] [--preopToIntraop P.nrrd] [--intraopToPreop I.nrrd]
//                      [--reportFile R.json] [--init scene|rigid|identity] [--resultDirectory RES]
//
// The same functions as `brainshift register` (open_session, read_intraop, read_preop_mri,
// register_model, compute_result_fields), with the outputs at the paths Slicer gives, written all
// or none (staged_outputs.hpp). Progress goes to stdout in Slicer's <filter-progress> tags.
// Exit codes: 0 results written (also when the registration stopped without converging: Slicer
// loads outputs only after exit code 0, so that case is a warning line on stderr and in the
// report); 1 bad input (one line on stderr naming the file; nothing written).

#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>

#include "../cmd_register.hpp"
#include "../model_folder.hpp"
#include "../result_fields.hpp"
#include "core/error.hpp"
#include "imaging/io/atomic_write.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/nrrd_io.hpp"
#include "module_description.hpp"
#include "slicer_modules.hpp"
#include "staged_outputs.hpp"

namespace brainshift::apps::slicer {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

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

int register_body(const Values& v, const ProgressReport& progress) {
  const auto t0 = Clock::now();
  const std::filesystem::path model = v.at("model");
  const std::filesystem::path doppler = v.at("doppler");
  const auto bmode = optional_path(v, "bmode");
  const auto mri_path = optional_path(v, "preopMRI");
  const auto warped_path = optional_path(v, "warpedMRI");
  const auto to_intra_path = optional_path(v, "preopToIntraop");
  const auto to_pre_path = optional_path(v, "intraopToPreop");
  const auto report_path = optional_path(v, "reportFile");
  const auto result_dir = optional_path(v, "resultDirectory");

  // Everything that can be checked before the long work.
  BS_VERIFY(warped_path || to_intra_path || to_pre_path || report_path || result_dir,
            "no output requested: give at least one of --warpedMRI, --preopToIntraop, --intraopToPreop, "
            "--reportFile, --resultDirectory");
  BS_VERIFY(!warped_path || mri_path, warped_path->string() << ": the warped MRI needs the pre-operative MRI "
                                                               "(--preopMRI)");
  for (const auto& t : {to_intra_path, to_pre_path})
    if (t) BS_VERIFY(has_extension(*t, ".nrrd"), t->string() << ": a transform is written as a .nrrd displacement field");
  for (const auto& p : {warped_path, to_intra_path, to_pre_path, report_path})
    if (p) imaging::verify_writable(*p);
  if (result_dir) {
    verify_output_folder(*result_dir);
    verify_replaceable_folder(*result_dir, "report.json");
  }

  progress("loading the model " + model.string(), 0.05);
  Session s = open_session(model);
  progress("extracting vessels" + std::string(bmode ? " and the probe footprint" : ""), 0.25);
  const IntraopInputs in = read_intraop(s, doppler, bmode);
  const std::optional<imaging::VolumeF> mri =
      mri_path ? std::optional<imaging::VolumeF>(read_preop_mri(s, *mri_path)) : std::nullopt;
  constraints::RegistrationOptions options = s.loaded.scene.options;
  const std::string init = v.count("init") ? v.at("init") : "scene";
  if (init == "rigid") options.start = constraints::RigidStart::RIGID;
  if (init == "identity") options.start = constraints::RigidStart::IDENTITY;
  progress("registering (" + std::to_string(in.data.vessel_points.rows()) + " vessel points, " +
               std::to_string(in.data.footprint_points.rows()) + " footprint points)",
           0.4);
  const constraints::RegistrationResult r = constraints::register_model(*s.model, in.data, options);

  progress("computing the transforms" + std::string(mri ? " and the warped MRI" : ""), 0.7);
  const auto t_out = Clock::now();
  const ResultFields f = compute_result_fields(s, r, mri ? &*mri : nullptr);
  const double seconds_fields = since(t_out);
  progress("writing the outputs", 0.85);
  StagedOutputs outputs;
  if (warped_path) {
    outputs.add(*warped_path, [&](const std::filesystem::path& tmp) {
      // Slicer's own convention for NRRD volumes is LPS; other formats by their extension.
      if (has_extension(*warped_path, ".nrrd")) imaging::write_nrrd(tmp, *f.warped_mri, imaging::NrrdSpace::LPS);
      else imaging::write_volume(tmp, *f.warped_mri);
    });
  }
  if (to_intra_path)
    outputs.add(*to_intra_path, [&](const std::filesystem::path& tmp) {
      imaging::write_displacement_for_slicer(tmp, f.preop_to_intraop);
    });
  if (to_pre_path)
    outputs.add(*to_pre_path, [&](const std::filesystem::path& tmp) {
      imaging::write_displacement_for_slicer(tmp, f.intraop_to_preop);
    });
  const nlohmann::json extra = {{"slicer_module", "BrainshiftRegister"}};
  if (report_path) {
    nlohmann::json report = result_report(s, r, in, extra);
    report["timing"]["outputs"] = since(t_out);
    double total = 0;
    for (const char* k : {"load_model", "extraction", "registration", "outputs"}) total += report["timing"][k].get<double>();
    report["timing"]["total"] = total;
    outputs.add(*report_path, [&](const std::filesystem::path& tmp) {
      std::ofstream o(tmp);
      o << report.dump(2) << '\n';
      o.close();
      BS_VERIFY(o.good(), report_path->string() << ": cannot write the report");
    });
  }
  if (result_dir) write_result(*result_dir, s, r, in, mri ? &*mri : nullptr, f, extra, seconds_fields);
  outputs.commit();

  std::cout << "registered in " << r.iterations << " iterations (" << r.stop_reason << "); registration "
            << r.seconds.total << " s, total " << since(t0) << " s; max displacement "
            << (r.displacement.rows() ? r.displacement.rowwise().norm().maxCoeff() : 0.0) << " mm\n";
  if (!r.converged)
    std::cerr << "BrainshiftRegister: warning: the registration did not converge: " << r.stop_reason
              << " (results written; see the report)\n";
  return 0;
}

}  // namespace
}  // namespace brainshift::apps::slicer

int main(int argc, char** argv) {
  namespace slicer = brainshift::apps::slicer;
  return slicer::run_module(argc, argv, "BrainshiftRegister", slicer::register_module(), slicer::register_body);
}
