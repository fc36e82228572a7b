#pragma once
/// @file
/// @brief `brainshift serve`: registrations driven over OpenIGTLink, as a server for 3D Slicer
/// (listen) or a client of a PLUS server (connect). The model is loaded once; every power-Doppler
/// volume that arrives is registered and answered, and its results written like `register`'s.
///
/// Received (IMAGE, by device name; the names are options):
/// - the Doppler device (default `Doppler`): a power-Doppler volume; each one is registered.
/// - the B-mode device (default `BMode`): kept; the latest is used for the probe footprint.
/// - the pre-dura device (default `PreDuraDoppler`): the pose is measured on it and stored as
///   DIR/pre_dura_pose.json (as `brainshift pre-dura`); later frames use it.
/// While a registration runs, what arrives is queued, the latest of each device winning.
///
/// Sent for each registration, in this order: STATUS `BrainshiftProgress` (percentage in the
/// subcode) while it runs; TRANSFORM `IntraopToPreop` (the rigid part, intra-operative →
/// pre-operative, world RAS mm); POLYDATA `DeformedVessels` (lines) and `DeformedTumour` (surface,
/// when the model has a tumour) in the intra-operative frame; IMAGE `WarpedMRI` (with an MRI);
/// STRING `BrainshiftReport` (JSON: frame, folder, stop, iterations, times, predicted error);
/// STATUS `BrainshiftStatus` (OK when converged, else an error code and the reason). A bad
/// message gets STATUS `BrainshiftStatus` with an error code and a one-line reason, and the server
/// goes on.
///
/// A server started again on the same DIR resumes: frames numbered after those there, and the pose
/// DIR/pre_dura_pose.json reused unless --pre-dura-pose is given.
///
/// Written: DIR/frame_NNNN/ as `register` writes RES (report.json, the fields, the Slicer
/// transforms; atomically), and what was received as DIR/received/frame_NNNN/doppler.nrrd (and
/// bmode.nrrd): `brainshift replay --sequence DIR/received` registers the session again.

#include "apps/workflow/progress.hpp"

#include <atomic>
#include <filesystem>
#include <optional>
#include <string>

namespace brainshift::serve {

struct ServeOptions {
  std::filesystem::path model;                         ///< MODEL folder from prepare
  std::optional<std::filesystem::path> mri;            ///< pre-operative MRI to warp
  std::optional<std::filesystem::path> pre_dura_pose;  ///< a stored pose (pose_file.hpp)
  std::filesystem::path out;                           ///< DIR: frames and the stored pose
  std::optional<int> listen;                           ///< port to listen on (0: any free one)
  std::string connect;                                 ///< HOST:PORT of a server (e.g. PLUS)
  std::string doppler_device = "Doppler";
  std::string bmode_device = "BMode";
  std::string pre_dura_device = "PreDuraDoppler";
};

/// What a serve session did.
struct ServeSummary {
  int frames = 0;        ///< registrations written
  int failed = 0;        ///< volumes that could not be registered (answered with an error)
  int bad_messages = 0;  ///< messages refused (answered with an error)
};

/// Serves until `stop` becomes true (SIGINT / SIGTERM in the command), then finishes the frame
/// in progress and returns. Progress lines go to `progress` (stderr) as well as STATUS messages.
/// \throws brainshift::Error, one line, when the model, MRI or pose cannot be read, DIR cannot
/// be created, the port cannot be opened, or HOST:PORT is malformed.
ServeSummary serve(const ServeOptions& options, const workflow::Progress& progress,
                   const std::atomic<bool>& stop);

}  // namespace brainshift::serve
