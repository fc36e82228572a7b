#pragma once
/// @file
/// @brief What keeps an output as it was when a run fails, is interrupted or meets another run
///:
/// - temporaries (the files and folders that write_atomically() and write_folder_atomically()
///   fill before renaming them into place) are registered while they exist, and a SIGINT, SIGTERM
///   or SIGHUP removes them before the process ends with that signal;
/// - an output is written by one run at a time: OutputLock holds a lock beside it for the whole
///   run, and a second run writing the same output stops at once, saying so;
/// - the step that puts a finished output in place is indivisible for the handlers (a
///   CommitSection): a signal that arrives while an output is renamed into place, or after a
///   command's output folder is in place, no longer interrupts what is done. The run then ends
///   with its own exit code and the new, complete result — or, when it goes on to write another
///   output, it ends by that signal as it starts the next one. So a run that exits by a signal
///   (128 + n) has left its output as it was.

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

/// Makes the rename of a finished output into place (and the removal of what it replaced)
/// indivisible for the handlers: a signal meanwhile is held. When the section ends, a held signal
/// ends the process for an intermediate file (`final` false: the temporaries are removed as
/// usual); for a command's output (`final` true) it stays held until the next output begins
/// (resume_interruption()) or the process ends normally. If a handler is already removing the
/// temporaries as the section begins, the process is ending: the section waits for it.
class CommitSection {
 public:
  explicit CommitSection(bool final);
  ~CommitSection();
  CommitSection(const CommitSection&) = delete;
  CommitSection& operator=(const CommitSection&) = delete;

 private:
  bool m_final;
  bool m_resume;  ///< the section began outside a final commit's hold
};

/// Begins a new output: a signal held since a command's output was put in place now ends the
/// process (the previous output is complete; nothing of this one is written yet). OutputLock and
/// write_folder_atomically() call it first.
void resume_interruption();

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
