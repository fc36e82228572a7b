#pragma once
/// @file
/// @brief `brainshift evaluate`: target registration error of a result against landmarks, before
/// and after (mean, median, p95, max, mm), percent of shift corrected, and with surfaces the
/// H95/H75/H50/H25 Hausdorff percentiles (seeds 001 and 004) before and after. The pre-operative
/// landmarks (and surface vertices) are moved by RES/displacement.nii.gz (trilinear; the field
/// maps the pre-operative frame to the intra-operative one, rigid part included). Landmarks come
/// as CSV, MNI .tag, Slicer .mrk.json or .fcsv (imaging/io/landmark_files.hpp). Writes
/// RES/evaluation.json, RES/landmark_errors.mrk.json (each landmark at its intra-operative
/// position with its error, for Slicer's Markups module) and prints a table.

#include <nlohmann/json.hpp>

#include <filesystem>
#include <iosfwd>
#include <optional>

namespace CLI {
class App;
}  // namespace CLI

namespace brainshift::apps {

/// The per-landmark errors evaluate() writes in RES (Slicer markups, LPS).
inline constexpr const char* landmark_errors_file = "landmark_errors.mrk.json";

struct EvaluateArgs {
  std::filesystem::path result;
  std::filesystem::path landmarks_pre;
  std::filesystem::path landmarks_intra;
  std::optional<std::filesystem::path> surface_pre;
  std::optional<std::filesystem::path> surface_intra;
  /// Points with known truth spread over the brain (landmark files, as above; e.g. a
  /// phantom's truth field sampled at brain voxels): the whole-brain error, beside the landmarks'
  /// (evaluation.json → `whole_brain_before_mm`, `whole_brain_after_mm`). Both or neither.
  std::optional<std::filesystem::path> brain_points_pre;
  std::optional<std::filesystem::path> brain_points_intra;
};

CLI::App* add_evaluate_command(CLI::App& app, EvaluateArgs& args);

/// Computes the evaluation and writes RES/evaluation.json (atomically); returns its content.
/// \throws brainshift::Error, one line: unreadable files, no landmark ids in common, only one of
/// the two surfaces given.
nlohmann::json evaluate(const EvaluateArgs& args);

/// evaluate() and a table on `out`.
int run_evaluate(const EvaluateArgs& args, std::ostream& out);

}  // namespace brainshift::apps
