#pragma once
/// @file
/// @brief The work `brainshift serve` does for each volume received (server.hpp): the model opened
/// once, a pre-dura sweep turned into the stored pose, a Doppler volume registered, answered over
/// the connection and written to DIR/frame_NNNN/. Positions in world RAS, mm.

#include "apps/serve/igtl_connection.hpp"
#include "apps/serve/server.hpp"
#include "apps/workflow/session.hpp"
#include "core/mesh/boundary.hpp"
#include "imaging/io/output_guard.hpp"

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace brainshift::serve {

class FrameRegistrar {
 public:
  /// Opens the model, reads the MRI and the stored pose, and numbers new frames after those
  /// already in DIR (created with the first result). \throws brainshift::Error, one line, naming
  /// what is wrong.
  FrameRegistrar(const ServeOptions& options, const workflow::Progress& progress);

  /// Where replies go (null: nowhere; results are still written).
  void set_connection(std::shared_ptr<Connection> connection);

  /// Measures the pose on a pre-dura sweep, stores it as DIR/pre_dura_pose.json and answers.
  /// False (answered with an error STATUS) when it cannot be measured.
  bool measure_pose(const imaging::VolumeF& doppler, const std::string& name);

  /// Extracts the probe footprint of a B-mode volume and keeps it for the Doppler volumes that
  /// follow (done while no Doppler waits, so that a frame does not pay for it). A B-mode without
  /// a footprint is kept too (its report says why); an unreadable one is answered with an error.
  void prepare_footprint(const imaging::VolumeF& bmode, const std::string& name);

  /// Registers a Doppler volume (with the latest B-mode, may be null), answers, writes the frame.
  /// `received`: when its last byte arrived (the latency's start). False (answered with an error
  /// STATUS) when it cannot be registered; nothing is written then.
  bool register_frame(const imaging::VolumeF& doppler, const std::string& name,
                      const imaging::VolumeF* bmode, const std::string& bmode_name,
                      std::chrono::steady_clock::time_point received);

 private:
  void make_folders() const;
  void send(igtl::MessageBase* message);
  void progress(int percent, const std::string& what);
  void fail(const std::string& name, const std::exception& e);

  const ServeOptions& m_options;
  const workflow::Progress& m_progress;
  std::unique_ptr<imaging::OutputLock> m_lock;  ///< one server writes DIR at a time
  workflow::Session m_session;
  std::optional<imaging::VolumeF> m_mri;
  std::optional<Eigen::Isometry3d> m_pose;
  nlohmann::json m_pose_report;
  core::TriangleMatrix m_tumour_faces;  ///< mesh node indices
  std::string m_footprint_of;           ///< the B-mode whose footprint m_footprint is
  std::optional<workflow::IntraopFootprint> m_footprint;
  int m_next_frame = 1;

  std::mutex m_mutex;
  std::shared_ptr<Connection> m_connection;
};

}  // namespace brainshift::serve
