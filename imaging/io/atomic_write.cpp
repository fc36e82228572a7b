#include "imaging/io/atomic_write.hpp"

#include "core/error.hpp"
#include "imaging/io/output_guard.hpp"

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>
#include <system_error>
#include <unistd.h>

namespace brainshift::imaging {
namespace {

/// A name in the folder of `target` that no other writer (thread or process) uses.
std::filesystem::path temporary_name(const std::filesystem::path& target) {
  static std::atomic<unsigned> counter{0};
  // Built by appending (GCC 12 warns falsely, -Wrestrict, on "literal" + std::string).
  std::string name = ".";
  name += target.filename().string();
  name += ".partial-";
  name += std::to_string(::getpid());
  name += '-';
  name += std::to_string(counter++);
  return target.parent_path() / name;
}

/// Creates the (empty) file `temporary` next to `target`, or throws one line saying why not.
void create_temporary(const std::filesystem::path& target, const std::filesystem::path& temporary) {
  namespace fs = std::filesystem;
  BS_VERIFY(!target.filename().empty(),
            "cannot write '" << target.string() << "': not a file name");
  const fs::path folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  std::error_code ec;
  BS_VERIFY(fs::exists(folder, ec), "cannot write " << target.string() << ": folder "
                                                    << folder.string() << " does not exist");
  BS_VERIFY(fs::is_directory(folder, ec),
            "cannot write " << target.string() << ": " << folder.string() << " is not a folder");
  BS_VERIFY(!fs::is_directory(target, ec),
            "cannot write " << target.string() << ": it is a folder");
  std::ofstream file(temporary, std::ios::binary);
  const int error = errno;
  BS_VERIFY(file.is_open(), "cannot write " << target.string() << ": cannot create a file in "
                                            << folder.string() << " (" << std::strerror(error)
                                            << ")");
}

}  // namespace

void verify_writable(const std::filesystem::path& target) {
  const std::filesystem::path probe = temporary_name(target);
  create_temporary(target, probe);
  std::error_code ec;
  std::filesystem::remove(probe, ec);
}

void write_atomically(const std::filesystem::path& target,
                      const std::function<void(const std::filesystem::path&)>& write) {
  const std::filesystem::path temporary = temporary_name(target);
  create_temporary(target, temporary);
  const TemporaryGuard guard(temporary);  // removed if a signal ends the run meanwhile
  try {
    write(temporary);
    std::error_code ec;
    const CommitSection commit(false);  // a signal meanwhile ends the run after the rename
    std::filesystem::rename(temporary, target, ec);
    BS_VERIFY(!ec, "cannot write " << target.string() << ": " << ec.message());
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(temporary, ec);
    throw;
  }
}

}  // namespace brainshift::imaging
