#pragma once
/// @file
/// @brief Several output files written all or none: each is written to a hidden temporary file
/// beside its target (keeping the target's name as suffix, so formats chosen by extension still
/// work), and only when every one is complete are they renamed into place. Slicer reads the
/// outputs at the paths it gave; a module that fails leaves nothing at them.

#include <filesystem>
#include <functional>
#include <utility>
#include <vector>

namespace brainshift::apps::slicer {

class StagedOutputs {
 public:
  StagedOutputs() = default;
  StagedOutputs(const StagedOutputs&) = delete;
  StagedOutputs& operator=(const StagedOutputs&) = delete;
  /// Removes the temporaries of a set that was not committed.
  ~StagedOutputs();

  /// Calls `write(temporary)` now; the file is renamed to `target` by commit().
  /// \throws brainshift::Error naming `target` when its folder cannot take the file, or whatever
  /// `write` throws (the temporary is removed).
  void add(const std::filesystem::path& target,
           const std::function<void(const std::filesystem::path&)>& write);

  /// Renames every temporary to its target (replacing an existing file).
  /// \throws brainshift::Error naming the target whose rename failed.
  void commit();

 private:
  std::vector<std::pair<std::filesystem::path, std::filesystem::path>>
      m_files;  ///< (temporary, target)
  bool m_committed = false;
};

}  // namespace brainshift::apps::slicer
