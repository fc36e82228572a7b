// `brainshift serve` driven over a loopback socket by a client written from the OpenIGTLink
// specification in another language (tests/apps/igtl_client.py: its own NIfTI reader, CRC-64 and
// message packing; nothing of brainshift or libopenigtlink), on the `standard` phantom.
// The server's answers are checked against `brainshift register` run on the same inputs.

#include "cli_helpers.hpp"

#include "imaging/io/image_io.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <set>
#include <string>
#include <thread>

namespace brainshift {
namespace {

nlohmann::json read_json(const std::filesystem::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

/// A `brainshift serve` in the background (by default `--listen 0`, its port read from its
/// progress lines).
class Server {
 public:
  Server(const tests::TempFolder& dir, const std::string& name, const std::string& args,
         bool listen = true)
      : m_err(dir / (name + ".stderr")), m_pid_file(dir / (name + ".pid")) {
    const std::string command =
        q(tests::brainshift_exe) + " serve " + (listen ? "--listen 0 " : "") + args + " >" +
        q(dir / (name + ".stdout")) + " 2>" + q(m_err) + " & echo $! >" + q(m_pid_file);
    EXPECT_EQ(std::system(command.c_str()), 0);
    const std::regex listening("listening on port ([0-9]+)");
    for (int i = 0; i < 1200 && m_port == 0 && listen; ++i) {  // the model loads first (≈ 5 s)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      std::smatch m;
      const std::string err = read_all(m_err);
      if (std::regex_search(err, m, listening)) m_port = std::stoi(m[1].str());
    }
    m_pid = std::stoi(read_all(m_pid_file));
  }
  ~Server() {
    if (running()) ::kill(m_pid, SIGKILL);
  }
  [[nodiscard]] int port() const { return m_port; }
  [[nodiscard]] std::string err() const { return read_all(m_err); }
  [[nodiscard]] bool running() const { return m_pid > 0 && ::kill(m_pid, 0) == 0; }
  /// SIGINT, then waits (up to 60 s) for the process to end; true when it did.
  bool interrupt() {
    ::kill(m_pid, SIGINT);
    for (int i = 0; i < 600 && running(); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      (void)std::system("true");  // lets the shell reap the finished background job
    }
    return !running();
  }

 private:
  std::filesystem::path m_err, m_pid_file;
  int m_port = 0;
  int m_pid = 0;
};

int run_client(const tests::TempFolder& dir, const std::string& args,
               const std::string& background = "") {
  const std::string client = std::string(tests::source_dir) + "/tests/apps/igtl_client.py";
  const std::string command =
      "python3 " + q(client) + " " + args + " 2>" + q(dir / "client.err") + background;
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class Serve : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir = new tests::TempFolder;
    ph = *dir / "phantom";
    model = *dir / "model";
    CliRun r = run_brainshift(*dir, "phantom --case standard --seed 1 --out " + q(ph));
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
    r = run_brainshift(*dir, "prepare --labels " + q(ph / "preop/labels.nii.gz") + " --mra " +
                                 q(ph / "preop/mra.nii.gz") + " --out " + q(model));
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  }
  static void TearDownTestSuite() { delete dir; }
  static inline tests::TempFolder* dir = nullptr;
  static inline std::filesystem::path ph, model;
};

TEST_F(Serve, ASessionOverOpenIGTLinkMatchesRegisterOnTheSameInputs) {
  const auto out = *dir / "served";
  Server server(
      *dir, "session",
      "--model " + q(model) + " --mri " + q(ph / "preop/mri.nii.gz") + " --out " + q(out));
  ASSERT_GT(server.port(), 0) << server.err();
  const auto result = *dir / "session.json";
  ASSERT_EQ(run_client(*dir, "session --port " + std::to_string(server.port()) + " --pre-dura " +
                                 q(ph / "intraop/predura/doppler.nii.gz") + " --bmode " +
                                 q(ph / "intraop/bmode.nii.gz") + " --doppler " +
                                 q(ph / "intraop/doppler.nii.gz") + " --mri " +
                                 q(ph / "preop/mri.nii.gz") + " --out " + q(result)),
            0)
      << read_all(*dir / "client.err") << server.err();
  const auto s = read_json(result);

  // The pre-dura sweep: the pose measured, stored and announced.
  EXPECT_EQ(s["pose_status"]["code"], 1) << s["pose_status"].dump();
  EXPECT_TRUE(std::filesystem::exists(out / "pre_dura_pose.json"));

  // The registration's replies: progress, then the transform and the deformed structures, the
  // warped MRI, the report naming the frame folder, the final status.
  std::vector<std::string> order;
  std::vector<long long> progress;
  nlohmann::json transform, image;
  for (const auto& m : s["messages"]) {
    const std::string key = m["type"].get<std::string>() + " " + m["device"].get<std::string>();
    if (m["device"] == "BrainshiftProgress") {
      progress.push_back(m["subcode"].get<long long>());
      continue;
    }
    order.push_back(key);
    if (m["type"] == "TRANSFORM") transform = m;
    if (m["type"] == "IMAGE") image = m;
    if (m["type"] == "POLYDATA") {
      EXPECT_GT(m["points"].get<int>(), 10) << key;
      EXPECT_TRUE(m["finite"].get<bool>()) << key;
      EXPECT_GT(m[m["device"] == "DeformedVessels" ? "lines" : "polygons"].get<int>(), 0) << key;
    }
  }
  const std::vector<std::string> expected = {"TRANSFORM IntraopToPreop", "POLYDATA DeformedVessels",
                                             "POLYDATA DeformedTumour",  "IMAGE WarpedMRI",
                                             "STRING BrainshiftReport",  "STATUS BrainshiftStatus"};
  EXPECT_EQ(order, expected);
  ASSERT_GE(progress.size(), 3u);
  EXPECT_TRUE(std::is_sorted(progress.begin(), progress.end()));
  const nlohmann::json& report = s["report"];
  ASSERT_TRUE(report.is_object()) << s.dump();
  EXPECT_EQ(report["frame"], "frame_0001");
  EXPECT_EQ(s["status"]["code"], report["converged"].get<bool>() ? 1 : 2) << s["status"].dump();

  // The frame folder is complete, as register writes RES, and what was received is kept.
  const auto frame = out / "frame_0001";
  for (const char* f :
       {"report.json", "deformed.vtu", "displacement.nii.gz", "preop_to_intraop.nrrd",
        "intraop_to_preop.nrrd", "warped_mri.nii.gz", "overlay.png", "uncertainty.nii.gz"})
    EXPECT_TRUE(std::filesystem::exists(frame / f)) << f;
  const auto received = out / "received/frame_0001";
  ASSERT_TRUE(std::filesystem::exists(received / "doppler.nrrd"));
  ASSERT_TRUE(std::filesystem::exists(received / "bmode.nrrd"));

  // The received Doppler is the file the client read: voxels exactly, the grid to the float32
  // rounding of the IMAGE position (the centre, |p| ≈ 100 mm: 1e-5 mm; bar 1e-4 mm).
  const imaging::VolumeF sent = imaging::read_volume(ph / "intraop/doppler.nii.gz");
  const imaging::VolumeF got = imaging::read_volume(received / "doppler.nrrd");
  ASSERT_EQ(got.geometry.size, sent.geometry.size);
  EXPECT_EQ(got.data, sent.data);
  EXPECT_LT((got.geometry.origin - sent.geometry.origin).norm(), 1e-4);
  EXPECT_LT((got.geometry.spacing - sent.geometry.spacing).norm(), 1e-6);
  EXPECT_LT((got.geometry.direction - sent.geometry.direction).norm(), 1e-6);

  // `register` on the same inputs (the received volumes, the stored pose) gives the same
  // registration: the rigid part within 1e-6 (doubles through JSON), and the TRANSFORM carries
  // it in float32 (|t| ≤ 100 mm: ≤ 1e-5 mm; bar 1e-4).
  const auto res = *dir / "register_same_inputs";
  const CliRun r = run_brainshift(*dir, "register --model " + q(model) + " --doppler " +
                                            q(received / "doppler.nrrd") + " --bmode " +
                                            q(received / "bmode.nrrd") + " --pre-dura-pose " +
                                            q(out / "pre_dura_pose.json") + " --out " + q(res));
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 2) << r.out << r.err;
  const auto reg = read_json(res / "report.json");
  const auto served = read_json(frame / "report.json");
  EXPECT_EQ(served["iterations"], reg["iterations"]);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      const double want = reg["rigid"]["model_from_intraop"][i][j].get<double>();
      EXPECT_NEAR(served["rigid"]["model_from_intraop"][i][j].get<double>(), want, 1e-6);
      EXPECT_NEAR(transform["matrix"][i][j].get<double>(), want, 1e-4) << i << "," << j;
    }
  EXPECT_NEAR(served["max_displacement_mm"].get<double>(), reg["max_displacement_mm"].get<double>(),
              1e-6);
  // The warped MRI travels on the MRI's grid, as the client reads it from the MRI's file itself:
  // the same size and IMAGE matrix (t, s, n, centre; float32: 1e-4 mm).
  const auto& want = s["expected_warped_mri"];
  EXPECT_EQ(image["size"], want["size"]);
  for (int i = 0; i < 12; ++i)
    EXPECT_NEAR(image["matrix"][i].get<double>(), want["matrix"][i].get<double>(), 1e-4) << i;
  const imaging::VolumeF mri = imaging::read_volume(ph / "preop/mri.nii.gz");
  EXPECT_EQ(image["data_bytes"].get<long long>(), 4 * mri.geometry.voxel_count());

  // SIGINT: a clean stop (exit 0), no temporary folder left.
  ASSERT_TRUE(server.interrupt()) << server.err();
  const std::string log = server.err();
  EXPECT_EQ(log.find("brainshift: error"), std::string::npos) << log;
  for (const auto& e : std::filesystem::recursive_directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
  // Started again on the same folder, the server resumes with the pose it stored.
  {
    Server again(*dir, "session_again", "--model " + q(model) + " --out " + q(out));
    ASSERT_GT(again.port(), 0) << again.err();
    EXPECT_NE(again.err().find("resuming with the pose stored in"), std::string::npos)
        << again.err();
    EXPECT_TRUE(again.interrupt());
  }
  // The recording replays (`replay --sequence DIR/received`).
  const CliRun rr =
      run_brainshift(*dir, "replay --model " + q(model) + " --sequence " + q(out / "received") +
                               " --pre-dura-pose " + q(out / "pre_dura_pose.json") +
                               " --uncertainty none --out " + q(*dir / "replayed"));
  EXPECT_TRUE(rr.exit_code == 0 || rr.exit_code == 2) << rr.out << rr.err;
  EXPECT_TRUE(std::filesystem::exists(*dir / "replayed/frame_0001/report.json"));
}

TEST_F(Serve, MalformedMessagesAreAnsweredAndTheServerGoesOn) {
  Server server(*dir, "malformed", "--model " + q(model) + " --out " + q(*dir / "served_bad"));
  ASSERT_GT(server.port(), 0) << server.err();
  const auto result = *dir / "malformed.json";
  ASSERT_EQ(run_client(*dir, "malformed --port " + std::to_string(server.port()) + " --doppler " +
                                 q(ph / "intraop/doppler.nii.gz") + " --out " + q(result)),
            0)
      << read_all(*dir / "client.err") << server.err();
  const auto s = read_json(result);
  const auto& a = s["answers"];
  // Each bad message: an error STATUS (code ≠ 1) whose text says what was wrong. Codes from the
  // specification: 12 unknown instruction, 9 checksum, 17 unknown version, 8 overflow, 10
  // configuration (what the volume or its header says).
  const std::map<std::string, std::pair<int, std::string>> want = {
      {"unknown_type", {12, "unknown message type"}},
      {"bad_crc", {9, "CRC64"}},
      {"short_data", {10, "bytes"}},
      {"scalar_type_13", {10, "scalar type 13"}},
      {"sheared_matrix", {10, "matrix"}},
      {"zero_size", {10, "0x4x4"}},
      {"header_version_3", {17, "header version 3"}},
      {"v2_bad_extended_header", {10, "extended header of 60000 bytes"}},
      {"short_body", {10, "shorter than the IMAGE header"}},
      {"huge_body", {8, "BRAINSHIFT_MAX_VOLUME_GB"}},
      {"new_client", {12, "unknown message type"}},
  };
  for (const auto& [name, w] : want) {
    ASSERT_TRUE(a.contains(name)) << name;
    EXPECT_EQ(a[name]["code"], w.first) << name << ": " << a[name].dump();
    EXPECT_NE(a[name]["text"].get<std::string>().find(w.second), std::string::npos)
        << name << ": " << a[name].dump();
  }
  // A good volume after all of them is still registered (sent with header version 2 and metadata,
  // as Slicer sends by default), and the connection is closed after a body too large to read.
  EXPECT_TRUE(a["valid_after"]["code"] == 1 || a["valid_after"]["code"] == 2)
      << a["valid_after"].dump();
  EXPECT_NE(a["valid_after"]["text"].get<std::string>().find("frame_0001"), std::string::npos)
      << a["valid_after"].dump();
  EXPECT_TRUE(s["closed_after_huge_body"].get<bool>());
  EXPECT_TRUE(std::filesystem::exists(*dir / "served_bad/frame_0001/report.json"));
  EXPECT_TRUE(server.running());
  EXPECT_TRUE(server.interrupt()) << server.err();
}

TEST_F(Serve, VolumesQueueTheLatestWinsAndSigintFinishesTheFrameInProgress) {
  const auto out = *dir / "served_queue";
  Server server(*dir, "queue", "--model " + q(model) + " --out " + q(out));
  ASSERT_GT(server.port(), 0) << server.err();
  const auto result = *dir / "queue.json";
  ASSERT_EQ(run_client(*dir,
                       "queue --port " + std::to_string(server.port()) + " --doppler " +
                           q(ph / "intraop/doppler.nii.gz") + " --out " + q(result),
                       " &"),
            0);
  // Three volumes arrive while the first is registered: the third replaces the second. SIGINT
  // while the second frame is being registered: it is finished, answered and written.
  bool second = false;
  for (int i = 0; i < 1200 && !second; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    second =
        server.err().find("frame_0002: extracting vessels from Doppler #3") != std::string::npos;
  }
  ASSERT_TRUE(second) << server.err();
  ASSERT_TRUE(server.interrupt()) << server.err();
  for (int i = 0; i < 600 && !std::filesystem::exists(result); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_TRUE(std::filesystem::exists(result)) << read_all(*dir / "client.err") << server.err();
  const auto s = read_json(result);
  ASSERT_EQ(s["finals"].size(), 2u);
  EXPECT_NE(s["finals"][0]["text"].get<std::string>().find("frame_0001"), std::string::npos);
  EXPECT_NE(s["finals"][1]["text"].get<std::string>().find("frame_0002"), std::string::npos);
  const std::string log = server.err();
  EXPECT_NE(log.find("Doppler #3 replaces Doppler #2"), std::string::npos) << log;
  EXPECT_NE(log.find("stopping after the frame in progress"), std::string::npos) << log;
  for (const char* f : {"frame_0001", "frame_0002"})
    EXPECT_TRUE(std::filesystem::exists(out / f / "report.json")) << f;
  EXPECT_FALSE(std::filesystem::exists(out / "frame_0003"));
  for (const auto& e : std::filesystem::directory_iterator(out))
    EXPECT_NE(e.path().filename().string()[0], '.') << e.path();  // no temporary, no lock
}

TEST_F(Serve, StartErrorsAreOneLineAndLeaveNothing) {
  const auto out = *dir / "never";
  expect_one_line_error(
      run_brainshift(*dir, "serve --listen 0 --model " + q(model) + " --mri " +
                               q(ph / "intraop/doppler.nii.gz") + " --out " + q(out)),
      "not on the grid of the model's labels");
  expect_one_line_error(
      run_brainshift(*dir, "serve --model " + q(model) + " --connect nohost --out " + q(out)),
      "expected HOST:PORT");
  expect_one_line_error(
      run_brainshift(*dir, "serve --listen 0 --model " + q(ph) + " --out " + q(out)),
      "not a brainshift model folder");
  EXPECT_FALSE(std::filesystem::exists(out));
  for (const auto& e : std::filesystem::directory_iterator(dir->path()))
    EXPECT_NE(e.path().filename().string().rfind(".never", 0), 0u) << e.path();  // no lock left
}

TEST_F(Serve, AsAClientOfAPlusServerItRegistersTheReconstructedVolume) {
  // The client plays PLUS: it listens, brainshift connects, the volume arrives as
  // RecVol_Reference (PLUS's default device name of a reconstructed volume).
  const auto port_file = *dir / "plus.port", result = *dir / "plus.json";
  ASSERT_EQ(run_client(*dir,
                       "plus --port-file " + q(port_file) + " --doppler " +
                           q(ph / "intraop/doppler.nii.gz") + " --out " + q(result),
                       " & echo $! >" + q(*dir / "plus.pid")),
            0);
  for (int i = 0; i < 300 && !std::filesystem::exists(port_file); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_TRUE(std::filesystem::exists(port_file)) << read_all(*dir / "client.err");
  Server server(*dir, "connect",
                "--connect 127.0.0.1:" + read_all(port_file) +
                    " --doppler-device RecVol_Reference" + " --model " + q(model) + " --out " +
                    q(*dir / "served_plus"),
                false);
  for (int i = 0; i < 1800 && !std::filesystem::exists(result); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_TRUE(std::filesystem::exists(result)) << read_all(*dir / "client.err") << server.err();
  const auto s = read_json(result);
  EXPECT_TRUE(s["status"]["code"] == 1 || s["status"]["code"] == 2) << s["status"].dump();
  EXPECT_NE(s["status"]["text"].get<std::string>().find("frame_0001"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(*dir / "served_plus/frame_0001/report.json"));
  EXPECT_TRUE(server.interrupt()) << server.err();
}

}  // namespace
}  // namespace brainshift
