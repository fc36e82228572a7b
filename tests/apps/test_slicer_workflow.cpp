// The Slicer modules run as Slicer runs them: inputs as NRRD files in LPS (raw and gzip, as
// Slicer's storage nodes write them), outputs at paths the test chooses, flags built from the
// module descriptions the executables print. Then bad input through the module path: one error
// line naming the file, nothing at the output paths.

#include "test_slicer_helpers.hpp"

#include "imaging/io/image_io.hpp"
#include "imaging/io/nrrd_io.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <string>
#include <vector>
#include <zlib.h>

namespace brainshift {
namespace {

/// Rewrites a raw NRRD file with gzip-compressed data (`encoding: gzip`), as Slicer saves by
/// default.
void gzip_nrrd(const std::filesystem::path& path) {
  const std::string all = read_all(path);
  const auto end = all.find("\n\n");
  ASSERT_NE(end, std::string::npos);
  std::string header = all.substr(0, end + 2);
  const std::string raw = all.substr(end + 2);
  const auto at = header.find("encoding: raw");
  ASSERT_NE(at, std::string::npos);
  header.replace(at, 13, "encoding: gzip");
  z_stream z{};
  ASSERT_EQ(deflateInit2(&z, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::vector<unsigned char> packed(deflateBound(&z, uLong(raw.size())) + 64);
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(raw.data()));
  z.avail_in = uInt(raw.size());
  z.next_out = packed.data();
  z.avail_out = uInt(packed.size());
  ASSERT_EQ(deflate(&z, Z_FINISH), Z_STREAM_END);
  packed.resize(z.total_out);
  deflateEnd(&z);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << header;
  out.write(reinterpret_cast<const char*>(packed.data()), std::streamsize(packed.size()));
}

/// The phantom's images as Slicer hands them to a module: NRRD, LPS.
void to_slicer_nrrd(const std::filesystem::path& nifti, const std::filesystem::path& nrrd,
                    bool labels, bool gzip) {
  if (labels)
    imaging::write_nrrd(nrrd, imaging::read_labels(nifti), imaging::NrrdSpace::LPS);
  else
    imaging::write_nrrd(nrrd, imaging::read_volume(nifti), imaging::NrrdSpace::LPS);
  if (gzip) gzip_nrrd(nrrd);
}

std::size_t entries(const std::filesystem::path& dir) {
  return std::size_t(std::distance(std::filesystem::directory_iterator(dir),
                                   std::filesystem::directory_iterator{}));
}

/// One error line, "<module>: error: …", naming `needle`.
void expect_one_error_line(const CliRun& r, const std::string& module, const std::string& needle) {
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(r.err.rfind(module + ": error: ", 0), 0U) << r.err;
  EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
}

TEST(SlicerWorkflow, ModulesRunOnNrrdInputsWriteEveryDeclaredOutputAndRefuseBadInput) {
  const tests::TempFolder dir;
  const auto ph = dir / "phantom";
  const CliRun made = run_brainshift(dir, "phantom --case standard --seed 1 --out " + q(ph));
  ASSERT_EQ(made.exit_code, 0) << made.out << made.err;
  const auto in = dir / "slicer_in";
  std::filesystem::create_directory(in);
  to_slicer_nrrd(ph / "preop/labels.nii.gz", in / "labels.nrrd", true, false);
  to_slicer_nrrd(ph / "preop/mra.nii.gz", in / "mra.nrrd", false, true);
  to_slicer_nrrd(ph / "preop/mri.nii.gz", in / "mri.nrrd", false, true);
  to_slicer_nrrd(ph / "intraop/doppler.nii.gz", in / "doppler.nrrd", false, true);
  to_slicer_nrrd(ph / "intraop/bmode.nii.gz", in / "bmode.nrrd", false, false);
  to_slicer_nrrd(ph / "intraop/predura/doppler.nii.gz", in / "predura.nrrd", false, true);

  // BrainshiftPrepare into an empty folder (what Slicer's directory button gives).
  const tests::XmlModule prepare = tests::module_xml(dir, "BrainshiftPrepare");
  const auto model = dir / "model";
  std::filesystem::create_directory(model);
  CliRun r = tests::run_exe(dir, tests::slicer_module("BrainshiftPrepare"),
                            tests::slicer_command_line(prepare, {{"labels", in / "labels.nrrd"},
                                                                 {"mra", in / "mra.nrrd"},
                                                                 {"mri", in / "mri.nrrd"},
                                                                 {"model", model}}));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("<filter-start>"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("<filter-progress>"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("<filter-end>"), std::string::npos) << r.out;
  for (const char* f : {"model.json", "scene.json", "mesh.vtu", "compliance.bin"})
    EXPECT_TRUE(std::filesystem::exists(model / f)) << f;

  // BrainshiftRegister with every parameter it declares given a value (outputs in a fresh folder).
  const tests::XmlModule reg = tests::module_xml(dir, "BrainshiftRegister");
  const auto out = dir / "slicer_out";
  std::filesystem::create_directory(out);
  const std::map<std::string, std::filesystem::path> values = {
      {"model", model},
      {"doppler", in / "doppler.nrrd"},
      {"bmode", in / "bmode.nrrd"},
      {"preDura", in / "predura.nrrd"},
      {"preopMRI", in / "mri.nrrd"},
      {"warpedMRI", out / "warped.nrrd"},
      {"preopToIntraop", out / "preop_to_intraop.nrrd"},
      {"intraopToPreop", out / "intraop_to_preop.nrrd"},
      {"reportFile", out / "report.json"},
      {"init", "scene"},
      {"resultDirectory", out / "res"}};
  for (const auto& [name, p] : tests::parameters_by_name(reg))
    EXPECT_TRUE(values.count(name) || name == "preDuraPose")  // below: excludes preDura
        << name << " untested";
  r = tests::run_exe(dir, tests::slicer_module("BrainshiftRegister"),
                     tests::slicer_command_line(reg, values));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("<filter-progress>"), std::string::npos) << r.out;
  for (const auto& [name, p] : tests::parameters_by_name(reg))
    if (p.channel == "output") {
      EXPECT_TRUE(std::filesystem::exists(values.at(name))) << name;
    }
  const auto report = nlohmann::json::parse(read_all(out / "report.json"));
  EXPECT_TRUE(report.contains("converged"));
  EXPECT_TRUE(report["timing"].contains("total"));
  // The pose came from the pre-dura sweep (as `register --pre-dura`).
  EXPECT_TRUE(report["intraop"].contains("pre_dura")) << report["intraop"].dump();
  EXPECT_NE(report["rigid"]["stop_reason"].get<std::string>().find("given pose"),
            std::string::npos);
  for (const char* f : {"report.json", "deformed.vtu", "preop_to_intraop.nrrd",
                        "intraop_to_preop.nrrd", "warped_mri.nii.gz"})
    EXPECT_TRUE(std::filesystem::exists(out / "res" / f)) << f;
  // The warped MRI lies on the pre-operative MRI's grid (the LPS file read back into RAS).
  const imaging::VolumeF warped = imaging::read_volume(out / "warped.nrrd");
  const imaging::VolumeF mri = imaging::read_volume(ph / "preop/mri.nii.gz");
  EXPECT_EQ(warped.geometry.size, mri.geometry.size);
  // Grids agree to the 17 significant digits the NRRD header is written with.
  EXPECT_LT((warped.geometry.origin - mri.geometry.origin).norm(), 1e-9);
  EXPECT_EQ(entries(out), 5U) << "no temporaries left next to the outputs";

  // The pose measured on the pre-dura sweep is stored in the result directory; given back as
  // preDuraPose it is the same pose (no second extraction), and the registration the same.
  ASSERT_TRUE(std::filesystem::exists(out / "res" / "pre_dura_pose.json"));
  {
    const auto out2 = dir / "slicer_out_pose";
    std::filesystem::create_directory(out2);
    const std::map<std::string, std::filesystem::path> v2 = {
        {"model", model},
        {"doppler", in / "doppler.nrrd"},
        {"bmode", in / "bmode.nrrd"},
        {"preDuraPose", out / "res" / "pre_dura_pose.json"},
        {"reportFile", out2 / "report.json"}};
    r = tests::run_exe(dir, tests::slicer_module("BrainshiftRegister"),
                       tests::slicer_command_line(reg, v2));
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
    const auto report2 = nlohmann::json::parse(read_all(out2 / "report.json"));
    EXPECT_EQ(report2["intraop"]["pre_dura"]["source"], "pose_file");
    EXPECT_EQ(report2["intraop"]["pre_dura"]["model_from_intraop"],
              report["intraop"]["pre_dura"]["model_from_intraop"]);
    EXPECT_EQ(report2["rigid"]["model_from_intraop"], report["rigid"]["model_from_intraop"]);
    // Both at once: refused before any work.
    auto both = v2;
    both["preDura"] = in / "predura.nrrd";
    both["reportFile"] = out2 / "both.json";
    r = tests::run_exe(dir, tests::slicer_module("BrainshiftRegister"),
                       tests::slicer_command_line(reg, both));
    expect_one_error_line(r, "BrainshiftRegister", "not both");
    EXPECT_FALSE(std::filesystem::exists(out2 / "both.json"));
  }

  // Bad input: a truncated Doppler volume. One line naming it; nothing at the output paths.
  {
    const std::string full = read_all(in / "doppler.nrrd");
    std::ofstream(in / "broken.nrrd", std::ios::binary) << full.substr(0, full.size() / 2);
  }
  const auto bad = dir / "bad_out";
  std::filesystem::create_directory(bad);
  std::map<std::string, std::filesystem::path> bad_values = values;
  bad_values["doppler"] = in / "broken.nrrd";
  for (const char* o :
       {"warpedMRI", "preopToIntraop", "intraopToPreop", "reportFile", "resultDirectory"})
    bad_values[o] = bad / values.at(o).filename();
  r = tests::run_exe(dir, tests::slicer_module("BrainshiftRegister"),
                     tests::slicer_command_line(reg, bad_values));
  expect_one_error_line(r, "BrainshiftRegister", (in / "broken.nrrd").string());
  EXPECT_EQ(entries(bad), 0U) << "nothing written, not even a temporary";

  // The warped MRI without the MRI to warp: refused before any work.
  bad_values = values;
  bad_values.erase("preopMRI");
  for (const char* o :
       {"warpedMRI", "preopToIntraop", "intraopToPreop", "reportFile", "resultDirectory"})
    bad_values[o] = bad / values.at(o).filename();
  r = tests::run_exe(dir, tests::slicer_module("BrainshiftRegister"),
                     tests::slicer_command_line(reg, bad_values));
  expect_one_error_line(r, "BrainshiftRegister", "preopMRI");
  EXPECT_EQ(entries(bad), 0U);

  // Prepare into a folder of other files: refused, the folder left as it was.
  const auto foreign = dir / "my_documents";
  std::filesystem::create_directory(foreign);
  std::ofstream(foreign / "notes.txt") << "keep me\n";
  r = tests::run_exe(
      dir, tests::slicer_module("BrainshiftPrepare"),
      tests::slicer_command_line(
          prepare, {{"labels", in / "labels.nrrd"}, {"mra", in / "mra.nrrd"}, {"model", foreign}}));
  expect_one_error_line(r, "BrainshiftPrepare", foreign.string());
  EXPECT_EQ(read_all(foreign / "notes.txt"), "keep me\n");
  EXPECT_EQ(entries(foreign), 1U);

  // Prepare with a missing MRA: one line naming it, no model folder.
  r = tests::run_exe(dir, tests::slicer_module("BrainshiftPrepare"),
                     tests::slicer_command_line(prepare, {{"labels", in / "labels.nrrd"},
                                                          {"mra", in / "missing.nrrd"},
                                                          {"model", dir / "model2"}}));
  expect_one_error_line(r, "BrainshiftPrepare", (in / "missing.nrrd").string());
  EXPECT_FALSE(std::filesystem::exists(dir / "model2"));
}

}  // namespace
}  // namespace brainshift
