#pragma once
/// @file
/// @brief A file's bytes, and a gzip file's decompressed bytes read with zlib's own reader (what
/// VTK, ITK and Slicer use), for tests that compare written files.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>
#include <zlib.h>

namespace brainshift::tests {

inline std::vector<char> file_bytes(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

/// Fails the test when the file cannot be opened, a read fails, or the trailer's CRC-32 and
/// length do not match (gzclose's Z_OK); returns what was read.
inline std::vector<char> gunzip(const std::filesystem::path& p) {
  gzFile f = gzopen(p.string().c_str(), "rb");
  EXPECT_NE(f, nullptr) << p;
  std::vector<char> out;
  if (!f) return out;
  char buffer[1 << 16];
  int n = 0;
  while ((n = gzread(f, buffer, sizeof buffer)) > 0) out.insert(out.end(), buffer, buffer + n);
  EXPECT_EQ(n, 0) << "gzread error: " << p;
  EXPECT_EQ(gzclose(f), Z_OK) << p;
  return out;
}

/// A written file's content: decompressed for a .gz, as is otherwise.
inline std::vector<char> content(const std::filesystem::path& p) {
  return p.extension() == ".gz" ? gunzip(p) : file_bytes(p);
}

}  // namespace brainshift::tests
