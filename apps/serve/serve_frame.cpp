#include "apps/serve/serve_frame.hpp"

#include "apps/serve/igtl_messages.hpp"
#include "apps/workflow/intraop_frame.hpp"
#include "apps/workflow/model_folder.hpp"
#include "apps/workflow/pose_file.hpp"
#include "apps/workflow/result_fields.hpp"
#include "apps/workflow/result_report.hpp"
#include "apps/workflow/result_uncertainty.hpp"
#include "apps/workflow/user_error.hpp"
#include "core/error.hpp"
#include "core/logger.hpp"
#include "core/timing.hpp"
#include "imaging/io/image_io.hpp"
#include "imaging/io/nrrd_io.hpp"

#include <cstdio>
#include <regex>

namespace brainshift::serve {
namespace {

using core::Clock;
using core::seconds_since;

constexpr const char* status_device = "BrainshiftStatus";
constexpr const char* progress_device = "BrainshiftProgress";

std::string frame_name(int n) {
  char b[32];
  std::snprintf(b, sizeof b, "frame_%04d", n);
  return b;
}

/// The first frame number after those already in `dir` (a session continues, never overwrites).
int next_frame_number(const std::filesystem::path& dir) {
  int last = 0;
  const std::regex pattern("frame_([0-9]+)");
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    std::smatch m;
    const std::string name = e.path().filename().string();
    if (std::regex_match(name, m, pattern)) last = std::max(last, std::stoi(m[1].str()));
  }
  return last + 1;
}

/// The tumour's boundary (faces of its tetrahedra that no other tumour tetrahedron shares).
core::TriangleMatrix tumour_surface(const workflow::Session& s) {
  const std::vector<index_t> tets = workflow::tumour_tets(s);
  if (tets.empty()) return {};
  const core::TetMesh& mesh = s.model->mesh();
  MatrixX4i sub(Eigen::Index(tets.size()), 4);
  for (std::size_t t = 0; t < tets.size(); ++t) sub.row(Eigen::Index(t)) = mesh.tets().row(tets[t]);
  return core::boundary_faces(core::TetMesh(mesh.nodes(), sub));
}

/// The used nodes of `faces` (mesh node indices) at `positions`, and the faces re-indexed.
void compact(const MatrixX3d& positions, const core::TriangleMatrix& faces, MatrixX3d& points,
             core::TriangleMatrix& local) {
  std::vector<index_t> index(std::size_t(positions.rows()), -1);
  std::vector<index_t> used;
  local.resize(faces.rows(), 3);
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      index_t& i = index[std::size_t(faces(f, c))];
      if (i < 0) {
        i = index_t(used.size());
        used.push_back(faces(f, c));
      }
      local(f, c) = i;
    }
  points.resize(Eigen::Index(used.size()), 3);
  for (std::size_t v = 0; v < used.size(); ++v)
    points.row(Eigen::Index(v)) = positions.row(used[v]);
}

}  // namespace

FrameRegistrar::FrameRegistrar(const ServeOptions& o, const workflow::Progress& progress)
    : m_options(o), m_progress(progress) {
  workflow::verify_output_folder(o.out);
  m_lock = std::make_unique<imaging::OutputLock>(o.out);
  m_progress.stage("loading the model " + o.model.string());
  m_session = workflow::open_session(o.model);
  if (o.mri) m_mri = workflow::read_preop_mri(m_session, *o.mri);
  // A restarted server resumes its session: the pose it measured before, unless one is given.
  const std::filesystem::path stored = o.out / workflow::pose_file_name;
  std::optional<std::filesystem::path> pose_file = o.pre_dura_pose;
  if (!pose_file && std::filesystem::exists(stored)) {
    pose_file = stored;
    m_progress.stage("resuming with the pose stored in " + stored.string());
  }
  if (pose_file) {
    const workflow::StoredPose p = workflow::read_pose_file(*pose_file, &m_session);
    m_pose = p.model_from_intraop;
    m_pose_report = p.pre_dura.is_object() ? p.pre_dura : nlohmann::json::object();
    m_pose_report["source"] = "pose_file";
    m_pose_report["pose_file"] = pose_file->string();
    m_pose_report["model_from_intraop"] = workflow::matrix_json(p.model_from_intraop.matrix());
  }
  m_tumour_faces = tumour_surface(m_session);
  m_next_frame = next_frame_number(o.out);
}

void FrameRegistrar::make_folders() const {
  // Made at the first result, not at start: a server that fails to start leaves nothing.
  std::error_code ec;
  std::filesystem::create_directories(m_options.out / "received", ec);
  BS_VERIFY(std::filesystem::is_directory(m_options.out / "received"),
            m_options.out.string() << ": cannot create the folder (" << ec.message() << ")");
}

void FrameRegistrar::set_connection(std::shared_ptr<Connection> connection) {
  const std::lock_guard<std::mutex> lock(m_mutex);
  m_connection = std::move(connection);
}

void FrameRegistrar::send(igtl::MessageBase* message) {
  std::shared_ptr<Connection> c;
  {
    const std::lock_guard<std::mutex> lock(m_mutex);
    c = m_connection;
  }
  if (c) c->send(message);
}

void FrameRegistrar::progress(int percent, const std::string& what) {
  m_progress.stage(what);
  send(status_message(igtl::StatusMessage::STATUS_OK, percent, "progress", what, progress_device));
}

void FrameRegistrar::fail(const std::string& name, const std::exception& e) {
  const std::string message = workflow::user_message(e);
  logger().warn("{}: not registered: {}", name, message);
  send(status_message(igtl::StatusMessage::STATUS_CONFIG_ERROR, 0, "failed", message,
                      status_device));
}

bool FrameRegistrar::measure_pose(const imaging::VolumeF& doppler, const std::string& name) {
  try {
    progress(0, "measuring the navigation offset on " + name);
    const workflow::Session& s = m_session;
    nlohmann::json report;
    const Eigen::Isometry3d pose = workflow::pose_from_pre_dura(
        s, workflow::extract_doppler(doppler, name), s.loaded.scene.options, report);
    report["source"] = "measured";
    make_folders();
    const std::filesystem::path file = m_options.out / workflow::pose_file_name;
    workflow::write_pose_file(file, workflow::pose_json(s, pose, report));
    m_pose = pose;
    m_pose_report = report;
    m_pose_report["pose_file"] = file.string();
    m_pose_report["model_from_intraop"] = workflow::matrix_json(pose.matrix());
    send(transform_message(pose, "IntraopToPreop"));
    send(string_message(nlohmann::json({{"pre_dura", m_pose_report}}).dump(), "BrainshiftReport"));
    char said[512];
    std::snprintf(said, sizeof said, "pre-dura pose from %s: %.2f mm, %.2f deg (%s); stored in %s",
                  name.c_str(), report["translation_mm"].get<double>(),
                  report["rotation_deg"].get<double>(),
                  report.value("message", std::string()).c_str(), file.string().c_str());
    m_progress.stage(said);
    send(status_message(igtl::StatusMessage::STATUS_OK, 100, "pose", said, status_device));
    return true;
  } catch (const std::exception& e) {
    fail(name, e);
    return false;
  }
}

void FrameRegistrar::prepare_footprint(const imaging::VolumeF& bmode, const std::string& name) {
  if (m_footprint && m_footprint_of == name) return;
  try {
    const auto t0 = Clock::now();
    m_footprint = workflow::footprint_from_bmode(bmode, name);
    m_footprint_of = name;
    m_progress.stage("probe footprint of " + name + ": " +
                     std::to_string(m_footprint->points.rows()) + " points (" +
                     std::to_string(seconds_since(t0)).substr(0, 4) + " s)");
  } catch (const std::exception& e) {
    m_footprint.reset();
    m_footprint_of.clear();
    fail(name, e);
  }
}

bool FrameRegistrar::register_frame(const imaging::VolumeF& doppler, const std::string& name,
                                    const imaging::VolumeF* bmode, const std::string& bmode_name,
                                    Clock::time_point received) {
  const workflow::Session& s = m_session;
  const std::string frame = frame_name(m_next_frame);
  const std::filesystem::path dir = m_options.out / frame;
  try {
    progress(5, frame + ": extracting vessels from " + name +
                    (bmode ? " and the probe footprint from " + bmode_name : std::string()));
    // The footprint of the B-mode: extracted once for every Doppler volume that uses it.
    if (bmode) prepare_footprint(*bmode, bmode_name);
    const bool with_footprint = bmode && m_footprint && m_footprint_of == bmode_name;
    workflow::IntraopInputs in = workflow::read_intraop(s, workflow::extract_doppler(doppler, name),
                                                        with_footprint ? &*m_footprint : nullptr);
    if (m_pose) {
      in.data.pose = m_pose;
      in.report["pre_dura"] = m_pose_report;
    }
    progress(30, frame + ": registering (" + std::to_string(in.data.vessel_points.rows()) +
                     " vessel points, " + std::to_string(in.data.footprint_points.rows()) +
                     " footprint points)");
    const constraints::RegistrationResult r =
        constraints::register_model(*s.model, in.data, s.loaded.scene.options);
    send(transform_message(r.start.transform, "IntraopToPreop"));
    const double latency = seconds_since(received);
    const MatrixX3d vessels =
        workflow::to_intraop_frame(r, s.model->skeleton_mapping().apply(r.positions));
    send(lines_message(vessels, s.model->skeleton().segments, "DeformedVessels"));
    if (m_tumour_faces.rows() > 0) {
      MatrixX3d points;
      core::TriangleMatrix faces;
      compact(workflow::to_intraop_frame(r, r.positions), m_tumour_faces, points, faces);
      send(surface_message(points, faces, "DeformedTumour"));
    }

    progress(70, frame + ": writing " + dir.string());
    make_folders();
    const auto t_fields = Clock::now();
    const workflow::ResultFields fields =
        workflow::compute_result_fields(s, r, m_mri ? &*m_mri : nullptr);
    // What was received, as a replayable recording (`replay --sequence DIR/received`); NRRD keeps
    // the geometry to 17 digits, so `register` on it sees exactly what serve registered.
    workflow::write_folder_atomically(
        m_options.out / "received" / frame, [&](const std::filesystem::path& tmp) {
          imaging::write_nrrd(tmp / "doppler.nrrd", doppler, imaging::NrrdSpace::RAS);
          if (bmode) imaging::write_nrrd(tmp / "bmode.nrrd", *bmode, imaging::NrrdSpace::RAS);
        });
    const double max_displacement =
        r.displacement.rows() ? r.displacement.rowwise().norm().maxCoeff() : 0.0;
    workflow::write_result(dir, s, r, in, m_mri ? &*m_mri : nullptr, fields,
                           {{"frame", frame},
                            {"serve",
                             {{"doppler", name},
                              {"bmode", bmode ? nlohmann::json(bmode_name) : nullptr},
                              {"latency_to_transform_s", latency}}}},
                           seconds_since(t_fields));
    ++m_next_frame;
    if (fields.warped_mri) send(image_message(*fields.warped_mri, "WarpedMRI"));

    const std::string stop = constraints::to_string(r.stop);
    nlohmann::json summary = {
        {"frame", frame},
        {"folder", std::filesystem::absolute(dir).string()},
        {"doppler", name},
        {"bmode", bmode ? nlohmann::json(bmode_name) : nullptr},
        {"converged", r.converged},
        {"stop", stop},
        {"iterations", r.iterations},
        {"registration_s", r.seconds.total},
        {"latency_to_transform_s", latency},
        {"latency_s", seconds_since(received)},
        {"max_displacement_mm", max_displacement},
        {"model_from_intraop", workflow::matrix_json(r.start.transform.matrix())}};
    if (fields.uncertainty.computed) {  // as report.json has it, without reading it back
      const nlohmann::json u = workflow::uncertainty_report(s, fields.uncertainty, in.data);
      nlohmann::json e = nlohmann::json::object();
      for (const char* k : {"median_mm", "p95_mm", "at_tumour_mm"})
        if (u.contains(k)) e[k] = u[k];
      summary["predicted_error_mm"] = e;
    }
    send(string_message(summary.dump(), "BrainshiftReport"));
    char said[512];
    std::snprintf(said, sizeof said,
                  "%s: %s after %d iterations; transform sent %.2f s after the "
                  "volume; results in %s",
                  frame.c_str(), stop.c_str(), r.iterations, latency, dir.string().c_str());
    m_progress.stage(said);
    send(status_message(
        r.converged ? igtl::StatusMessage::STATUS_OK : igtl::StatusMessage::STATUS_UNKNOWN_ERROR,
        100, stop, said, status_device));
    return true;
  } catch (const std::exception& e) {
    fail(name, e);
    return false;
  }
}

}  // namespace brainshift::serve
