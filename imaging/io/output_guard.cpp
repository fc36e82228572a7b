#include "imaging/io/output_guard.hpp"

#include "core/error.hpp"

#include <array>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <dirent.h>
#include <fcntl.h>
#include <string>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

namespace brainshift::imaging {
namespace {

constexpr int slots = 64;
constexpr std::size_t path_bytes = 4096;

/// A registered temporary: state 0 free, 1 being written, 2 registered.
struct Slot {
  std::atomic<int> state{0};
  char path[path_bytes];
};
std::array<Slot, slots> g_slots;

/// Who holds the signals: RUNNING (a signal ends the run), HOLDING (an output is being or has
/// been put in place: a signal is held in g_held), ENDING (a handler removes the temporaries).
enum Phase : int { RUNNING = 0, HOLDING = 1, ENDING = 2 };
std::atomic<int> g_phase{RUNNING};
std::atomic<int> g_held{0};
static_assert(std::atomic<int>::is_always_lock_free);

/// The process is ending by another thread's handler: wait for it.
[[noreturn]] void wait_for_the_end() {
  for (;;) ::pause();
}

/// linux_dirent64, as getdents64(2) returns it.
struct DirEntry {
  std::uint64_t inode;
  std::int64_t offset;
  unsigned short length;
  unsigned char type;
  char name[1];
};

/// Removes `name` (relative to the folder `at`) and, for a folder, what it holds, `depth` levels
/// at most; true when it is gone. Async-signal-safe: openat, getdents64, unlinkat, close only.
bool remove_tree(int at, const char* name, int depth) {
  if (::unlinkat(at, name, 0) == 0 || errno == ENOENT) return true;
  if (depth <= 0) return false;
  const int fd = ::openat(at, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return errno == ENOENT;
  alignas(8) char buffer[4096];
  for (;;) {
    const long n = ::syscall(SYS_getdents64, fd, buffer, sizeof buffer);
    if (n <= 0) break;
    for (long off = 0; off < n;) {
      const auto* e = reinterpret_cast<const DirEntry*>(buffer + off);
      off += e->length;
      if (std::strcmp(e->name, ".") == 0 || std::strcmp(e->name, "..") == 0) continue;
      remove_tree(fd, e->name, depth - 1);
    }
  }
  ::close(fd);
  return ::unlinkat(at, name, AT_REMOVEDIR) == 0 || errno == ENOENT;
}

extern "C" void on_signal(int signal) {
  int phase = RUNNING;
  if (!g_phase.compare_exchange_strong(phase, ENDING)) {
    if (phase == HOLDING) {
      g_held = signal;  // an output is going into place: the section's end decides
      return;
    }
    wait_for_the_end();  // another thread's handler is at work
  }
  // The other threads go on while this runs: one may still move a finished file into a folder
  // being removed. Passes until every temporary is gone, 2 s at most.
  for (int pass = 0; pass < 100; ++pass) {
    bool gone = true;
    for (Slot& s : g_slots)
      if (s.state.load() == 2 && !remove_tree(AT_FDCWD, s.path, 8)) gone = false;
    if (gone) break;
    const timespec pause{0, 20'000'000};
    ::nanosleep(&pause, nullptr);
  }
  std::signal(signal, SIG_DFL);
  std::raise(signal);
}

}  // namespace

void remove_temporaries_on_signal() {
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  for (const int s : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&action.sa_mask, s);
  for (const int s : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(s, &action, nullptr);
}

CommitSection::CommitSection(bool final) : m_final(final) {
  int phase = RUNNING;
  m_resume = g_phase.compare_exchange_strong(phase, HOLDING);
  if (!m_resume && phase == ENDING) wait_for_the_end();
}

CommitSection::~CommitSection() {
  if (m_final || !m_resume) return;  // held until the next output, or by the enclosing hold
  const int held = g_held.exchange(0);
  g_phase = RUNNING;
  if (held != 0) on_signal(held);
}

void resume_interruption() {
  int phase = HOLDING;
  if (!g_phase.compare_exchange_strong(phase, RUNNING)) return;
  const int held = g_held.exchange(0);
  if (held != 0) on_signal(held);
}

TemporaryGuard::TemporaryGuard(const std::filesystem::path& temporary) {
  const std::string p = std::filesystem::absolute(temporary).string();
  if (p.size() >= path_bytes) return;
  for (int i = 0; i < slots; ++i) {
    int free = 0;
    if (!g_slots[std::size_t(i)].state.compare_exchange_strong(free, 1)) continue;
    std::memcpy(g_slots[std::size_t(i)].path, p.c_str(), p.size() + 1);
    g_slots[std::size_t(i)].state = 2;
    m_slot = i;
    return;
  }
}

TemporaryGuard::~TemporaryGuard() {
  if (m_slot >= 0) g_slots[std::size_t(m_slot)].state = 0;
}

OutputLock::OutputLock(const std::filesystem::path& target) {
  resume_interruption();
  const std::filesystem::path absolute = std::filesystem::absolute(target).lexically_normal();
  std::filesystem::path name = absolute.filename();
  if (name.empty()) name = absolute.parent_path().filename();  // "RES/"
  const std::filesystem::path folder =
      absolute.filename().empty() ? absolute.parent_path().parent_path() : absolute.parent_path();
  std::string file = ".";  // appended piecewise: GCC 12 warns falsely (-Wrestrict) on "." + ...
  file += name.string();
  file += ".lock";
  m_file = folder / file;
  // Another run may remove the lock file between our open and flock: lock the file that is at
  // the path, and check that it still is.
  for (int attempt = 0; attempt < 10; ++attempt) {
    m_fd = ::open(m_file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    const int error = errno;
    BS_VERIFY(m_fd >= 0, target.string() << ": cannot create a lock file in " << folder.string()
                                         << " (" << std::strerror(error) << ")");
    if (::flock(m_fd, LOCK_EX | LOCK_NB) != 0) {
      ::close(m_fd);
      m_fd = -1;
      BS_THROW(target.string() << ": another brainshift run is writing it (lock " << m_file.string()
                               << "); wait for it or choose another output");
    }
    struct stat held {
    }, now{};
    if (::fstat(m_fd, &held) == 0 && ::stat(m_file.c_str(), &now) == 0 &&
        held.st_ino == now.st_ino && held.st_dev == now.st_dev) {
      m_guard = std::make_unique<TemporaryGuard>(m_file);
      return;
    }
    ::close(m_fd);  // removed and replaced meanwhile: try the new one
    m_fd = -1;
  }
  BS_THROW(target.string() << ": cannot take the lock " << m_file.string());
}

OutputLock::~OutputLock() {
  if (m_fd < 0) return;
  m_guard.reset();
  ::unlink(m_file.c_str());  // while held: a run that opened it before finds it replaced
  ::close(m_fd);
}

}  // namespace brainshift::imaging
