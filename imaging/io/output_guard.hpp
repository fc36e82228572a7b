#pragma once
/// @file
/// @brief What keeps an output as it was when a run fails, is interrupted or meets another run
/// (issue 36 item 3):
/// - temporaries (the files and folders that write_atomically() and write_folder_atomically()
///   fill before renaming them into place) are registered while they exist, and a SIGINT, SIGTERM
///   or SIGHUP removes them before the process ends with that signal;
/// - an output is written by one run at a time: OutputLock holds a lock beside it for the whole
///   run, and a second run writing the same output stops at once, saying so.

#include <filesystem>
#include <memory>

namespace brainshift::imaging {

/// Installs the handlers of SIGINT, SIGTERM and SIGHUP that remove the registered temporaries
/// (with async-signal-safe calls only), then end the process by the same signal (exit 128 + n as
/// seen by a shell). Call once, early in main(). A command that handles these signals itself
/// (`serve`) installs its own handlers after this and removes its temporaries as it stops.
void remove_temporaries_on_signal();

/// Registers a temporary file or folder for removal on a signal while the object lives (the
/// owner still removes or renames it itself on every normal path). At most 64 at once; beyond
/// that, or for a path longer than 4095 bytes, the temporary is simply not registered.
class TemporaryGuard {
 public:
  explicit TemporaryGuard(const std::filesystem::path& temporary);
  ~TemporaryGuard();
  TemporaryGuard(const TemporaryGuard&) = delete;
  TemporaryGuard& operator=(const TemporaryGuard&) = delete;

 private:
  int m_slot = -1;
};

/// An exclusive lock on the output `target` (a file or folder, existing or not) for this run: a
/// lock file `.NAME.lock` beside it, held with flock() and removed when released.
/// \throws brainshift::Error, one line naming `target`, when another run holds it ("another
/// brainshift run is writing ...") or the lock file cannot be created (its folder is missing or
/// read-only).
class OutputLock {
 public:
  explicit OutputLock(const std::filesystem::path& target);
  ~OutputLock();
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;

 private:
  std::filesystem::path m_file;
  int m_fd = -1;
  std::unique_ptr<TemporaryGuard> m_guard;  ///< the lock file goes too when a signal ends the run
};

}  // namespace brainshift::imaging
