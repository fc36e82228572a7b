// The signal handlers of output_guard.hpp, in forked children (a handler ends the process): a
// signal while an output goes into place is held, so a run ended by a signal left its output as
// it was and a run that finished wrote it whole.

#include "temp_folder.hpp"

#include "imaging/io/atomic_write.hpp"
#include "imaging/io/output_guard.hpp"

#include <gtest/gtest.h>

#include <csignal>
#include <fstream>
#include <functional>
#include <sys/wait.h>
#include <unistd.h>

namespace brainshift::imaging {
namespace {

/// Runs `body` in a child with the handlers installed; returns the signal that ended it, or
/// 100 + its exit code when it exited.
int in_child(const std::function<void()>& body) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    remove_temporaries_on_signal();
    body();
    ::_exit(0);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFSIGNALED(status) ? WTERMSIG(status) : 100 + WEXITSTATUS(status);
}

TEST(OutputGuard, ASignalEndsTheRunAndRemovesTheRegisteredTemporaries) {
  const tests::TempFolder dir;
  const auto temporary = dir / ".out.tmp";
  const int ended = in_child([&] {
    std::ofstream(temporary) << "partial";
    const TemporaryGuard guard(temporary);
    std::raise(SIGTERM);
    ::_exit(3);  // not reached
  });
  EXPECT_EQ(ended, SIGTERM);
  EXPECT_FALSE(std::filesystem::exists(temporary));
}

TEST(OutputGuard, ASignalDuringAFinalCommitIsHeldUntilTheNextOutputBegins) {
  const tests::TempFolder dir;
  // The run finishes normally after its output is in place: exit 0, the output whole.
  EXPECT_EQ(in_child([&] {
              const CommitSection commit(true);
              std::raise(SIGINT);
              std::ofstream(dir / "result") << "whole";
            }),
            100);
  EXPECT_TRUE(std::filesystem::exists(dir / "result"));
  // A signal after the commit is held too, and ends the run when its next output begins, before
  // anything of that output exists.
  EXPECT_EQ(in_child([&] {
              { const CommitSection commit(true); }
              std::raise(SIGTERM);
              resume_interruption();
              std::ofstream(dir / "next") << "never";
            }),
            SIGTERM);
  EXPECT_FALSE(std::filesystem::exists(dir / "next"));
}

TEST(OutputGuard, ASignalDuringAnIntermediateRenameEndsTheRunRightAfterIt) {
  const tests::TempFolder dir;
  EXPECT_EQ(in_child([&] {
              {
                const CommitSection commit(false);
                std::raise(SIGTERM);
                std::ofstream(dir / "renamed") << "in place";  // the rename still completes
              }
              std::ofstream(dir / "after") << "never";
            }),
            SIGTERM);
  EXPECT_TRUE(std::filesystem::exists(dir / "renamed"));
  EXPECT_FALSE(std::filesystem::exists(dir / "after"));
}

TEST(OutputGuard, AWriteAtomicallyInterruptedLeavesNoTemporary) {
  const tests::TempFolder dir;
  const auto target = dir / "a.txt";
  EXPECT_EQ(in_child([&] {
              write_atomically(target, [](const std::filesystem::path& p) {
                std::ofstream(p) << "partial";
                std::raise(SIGTERM);
              });
            }),
            SIGTERM);
  EXPECT_EQ(dir.count(), 0u);  // neither the target nor its temporary
}

}  // namespace
}  // namespace brainshift::imaging
