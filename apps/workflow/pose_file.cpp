#include "apps/workflow/pose_file.hpp"

#include "apps/workflow/model_folder.hpp"
#include "apps/workflow/result_report.hpp"
#include "core/error.hpp"
#include "imaging/io/atomic_write.hpp"

#include <cmath>
#include <fstream>
#include <string>

namespace brainshift::workflow {
namespace {

/// The 4×4 matrix under `key`, or an error naming the file.
Eigen::Matrix4d matrix_from_json(const nlohmann::json& j, const std::string& file) {
  BS_VERIFY(j.is_array() && j.size() == 4,
            file << ": 'model_from_intraop' must be 4 rows of 4 numbers");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    const nlohmann::json& row = j[static_cast<std::size_t>(r)];
    BS_VERIFY(row.is_array() && row.size() == 4,
              file << ": 'model_from_intraop' row " << r << " must be 4 numbers");
    for (int c = 0; c < 4; ++c) {
      const nlohmann::json& v = row[static_cast<std::size_t>(c)];
      BS_VERIFY(v.is_number() && std::isfinite(v.get<double>()),
                file << ": 'model_from_intraop' (" << r << "," << c << ") is not a finite number");
      m(r, c) = v.get<double>();
    }
  }
  return m;
}

}  // namespace

nlohmann::json pose_json(const Session& s, const Eigen::Isometry3d& model_from_intraop,
                         const nlohmann::json& report) {
  return {{"format", pose_format},
          {"version", pose_version},
          {"frame", "world RAS, mm; p_model = model_from_intraop * p_intraop"},
          {"model_from_intraop", matrix_json(model_from_intraop.matrix())},
          {"preop_grid", grid_to_json(s.loaded.preop_grid)},
          {"pre_dura", report}};
}

void write_pose_file(const std::filesystem::path& path, const nlohmann::json& pose) {
  imaging::write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream f(tmp);
    f << pose.dump(2) << '\n';
    BS_VERIFY(f.good(), tmp.string() << ": write failed");
  });
}

StoredPose read_pose_file(const std::filesystem::path& path, const Session* s) {
  const std::string file = path.string();
  std::ifstream in(path);
  BS_VERIFY(in.good(), file << ": cannot open the pose file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception&) {
    BS_THROW(file << ": not valid JSON (a pose file from brainshift pre-dura)");
  }
  BS_VERIFY(j.is_object() && j.value("format", "") == pose_format,
            file << ": not a brainshift pose file (format '"
                 << (j.is_object() ? j.value("format", "") : "") << "', expected '" << pose_format
                 << "')");
  const nlohmann::json version = j.value("version", nlohmann::json());
  BS_VERIFY(version.is_number_integer() && version.get<int>() == pose_version,
            file << ": pose file version " << version.dump() << ", this brainshift reads version "
                 << pose_version);
  BS_VERIFY(j.contains("model_from_intraop"), file << ": missing key 'model_from_intraop'");
  const Eigen::Matrix4d m = matrix_from_json(j["model_from_intraop"], file);
  BS_VERIFY((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() < 1e-9,
            file << ": 'model_from_intraop' last row must be 0 0 0 1");
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  BS_VERIFY((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 &&
                r.determinant() > 0,
            file << ": 'model_from_intraop' is not a rigid transform (its 3x3 block is not a "
                    "rotation)");
  const double shift = m.topRightCorner<3, 1>().norm();
  BS_VERIFY(shift < 1000.0, file << ": 'model_from_intraop' translates by " << shift
                                 << " mm (over 1 m: not a navigation offset)");
  if (s) {
    BS_VERIFY(j.contains("preop_grid"),
              file << ": missing key 'preop_grid' (the model the pose was measured for)");
    imaging::ImageGeometry g;
    try {
      g = grid_from_json(j["preop_grid"]);
    } catch (const nlohmann::json::exception&) {
      BS_THROW(file << ": bad 'preop_grid'");
    }
    BS_VERIFY(same_grid(g, s->loaded.preop_grid),
              file << ": measured for another model (its 'preop_grid' is not this model's grid: "
                      "another patient or scan?)");
  }
  StoredPose p;
  p.model_from_intraop.matrix() = m;
  p.pre_dura = j.value("pre_dura", nlohmann::json::object());
  return p;
}

std::optional<Eigen::Isometry3d> given_pose(const Session& s,
                                            const std::optional<std::filesystem::path>& pre_dura,
                                            const std::optional<std::filesystem::path>& pose_file,
                                            const constraints::RegistrationOptions& options,
                                            nlohmann::json& report, nlohmann::json& measured) {
  BS_VERIFY(!(pre_dura && pose_file), pose_file->string()
                                          << ": give a pre-dura sweep or a stored pose, not both");
  measured = nullptr;
  if (pre_dura) {
    const Eigen::Isometry3d pose = pose_from_pre_dura(s, *pre_dura, options, report);
    report["source"] = "measured";
    measured = pose_json(s, pose, report);
    return pose;
  }
  if (pose_file) {
    const StoredPose p = read_pose_file(*pose_file, &s);
    report = p.pre_dura.is_object() ? p.pre_dura : nlohmann::json::object();
    report["source"] = "pose_file";
    report["pose_file"] = pose_file->string();
    report["model_from_intraop"] = matrix_json(p.model_from_intraop.matrix());
    return p.model_from_intraop;
  }
  return std::nullopt;
}

}  // namespace brainshift::workflow
