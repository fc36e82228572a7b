#pragma once
/// @file
/// @brief What every fuzz target shares: the input written to a file of its own (the readers take
/// paths), and the rule that a reader may refuse an input only with brainshift::Error (one line,
/// the user-facing contract); anything else — another exception, a crash, a sanitizer report — is
/// a finding.

#include "core/error.hpp"

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace brainshift::fuzz {

/// `data` as the file `name` in a folder of this process (rewritten for every input).
inline std::filesystem::path as_file(const std::uint8_t* data, std::size_t size,
                                     const std::string& name) {
  // The folder of this process, removed at exit.
  struct Folder {
    std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("brainshift_fuzz_" + std::to_string(::getpid()));
    Folder() { std::filesystem::create_directories(path); }
    ~Folder() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
  };
  static const Folder folder;
  const std::filesystem::path p = folder.path / name;
  std::ofstream(p, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), std::streamsize(size));
  return p;
}

/// Calls `read`; brainshift::Error (a refusal with a message) is an accepted outcome.
template <typename Read>
void expect_refusal_or_success(Read&& read) {
  try {
    read();
  } catch (const Error& e) {
    if (std::string(e.what()).empty()) std::abort();  // a refusal must say why
    // BS_FUZZ_VERBOSE=1: each refusal on stderr (to check that the seeds of a corpus are read).
    if (std::getenv("BS_FUZZ_VERBOSE") != nullptr) std::fprintf(stderr, "refused: %s\n", e.what());
    return;
  }
  if (std::getenv("BS_FUZZ_VERBOSE") != nullptr) std::fprintf(stderr, "read\n");
}

}  // namespace brainshift::fuzz
