#include "imaging/io/atomic_write.hpp"

#include <atomic>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <string>
#include <system_error>

#include <unistd.h>

#include "core/error.hpp"

namespace brainshift::imaging {
namespace {

/// A name in the folder of `target` that no other writer (thread or process) uses.
std::filesystem::path temporary_name(const std::filesystem::path& target) {
  static std::atomic<unsigned> counter{0};
  const std::string name = "." + target.filename().string() + ".partial-" +
                           std::to_string(::getpid()) + "-" + std::to_string(counter++);
  return target.parent_path() / name;
}

}  // namespace

void write_atomically(const std::filesystem::path& target,
                      const std::function<void(const std::filesystem::path&)>& write) {
  namespace fs = std::filesystem;
  BS_VERIFY(!target.filename().empty(), "cannot write '" << target.string() << "': not a file name");
  const fs::path folder = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  std::error_code ec;
  BS_VERIFY(fs::exists(folder, ec),
            "cannot write " << target.string() << ": folder " << folder.string()
                            << " does not exist");
  BS_VERIFY(fs::is_directory(folder, ec),
            "cannot write " << target.string() << ": " << folder.string() << " is not a folder");
  BS_VERIFY(!fs::is_directory(target, ec),
            "cannot write " << target.string() << ": it is a folder");
  const fs::path temporary = temporary_name(target);
  {
    // Probe: can a file be created in the folder at all? Gives a plain reason when not.
    std::ofstream probe(temporary, std::ios::binary);
    const int error = errno;
    BS_VERIFY(probe.is_open(), "cannot write " << target.string() << ": cannot create a file in "
                                               << folder.string() << " ("
                                               << std::strerror(error) << ")");
  }
  try {
    write(temporary);
    fs::rename(temporary, target, ec);
    BS_VERIFY(!ec, "cannot write " << target.string() << ": " << ec.message());
  } catch (...) {
    fs::remove(temporary, ec);
    throw;
  }
}

}  // namespace brainshift::imaging
