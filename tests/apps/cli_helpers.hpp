#pragma once
/// @file
/// @brief Running the real brainshift executable from tests: exit code, stdout, stderr.

#include "temp_folder.hpp"
#include "tests/config.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>

namespace brainshift {

struct CliRun {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline std::string read_all(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// `p` in single quotes for the shell (built by appending: GCC 12 warns falsely, -Wrestrict,
/// on "literal" + std::string).
inline std::string q(const std::filesystem::path& p) {
  std::string s = "'";
  s += p.string();
  s += '\'';
  return s;
}

/// Runs `exe <args>` through the shell with stdout and stderr captured in files next to `dir`.
inline CliRun run_exe(const tests::TempFolder& dir, const std::filesystem::path& exe,
                      const std::string& args) {
  const auto out = dir.path().parent_path() / (dir.path().filename().string() + ".stdout");
  const auto err = dir.path().parent_path() / (dir.path().filename().string() + ".stderr");
  const std::string command = q(exe) + " " + args + " >" + q(out) + " 2>" + q(err);
  const int status = std::system(command.c_str());
  CliRun r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_all(out);
  r.err = read_all(err);
  std::filesystem::remove(out);
  std::filesystem::remove(err);
  return r;
}

/// Runs `brainshift <args>` (run_exe() on the project's executable).
inline CliRun run_brainshift(const tests::TempFolder& dir, const std::string& args) {
  return run_exe(dir, tests::brainshift_exe, args);
}

/// The error contract: non-zero exit and exactly one error line on stderr, prefixed, containing
/// `needle`; the only other stderr lines allowed are progress lines ("brainshift <cmd>: [t s] …")
/// and logged warnings ("[warning] …").
inline void expect_one_line_error(const CliRun& r, const std::string& needle) {
  EXPECT_NE(r.exit_code, 0);
  ASSERT_FALSE(r.err.empty());
  std::istringstream lines(r.err);
  int errors = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("brainshift: error: ", 0) == 0) {
      ++errors;
      EXPECT_NE(line.find(needle), std::string::npos) << line;
    } else {
      const bool progress =
          line.rfind("brainshift ", 0) == 0 && line.find(": [") != std::string::npos;
      EXPECT_TRUE(progress || line.rfind("[warning]", 0) == 0)
          << "unexpected stderr line: " << line;
    }
  }
  EXPECT_EQ(errors, 1) << r.err;
}

}  // namespace brainshift
