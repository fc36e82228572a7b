#include "expect_error.hpp"
#include "temp_folder.hpp"

#include "apps/workflow/compliance_cache.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <random>

namespace brainshift::workflow {
namespace {

using tests::expect_error;

/// A random symmetric block over `n` nodes (values need not be a real compliance for I/O).
constraints::ComplianceBlock random_block(index_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  constraints::ComplianceBlock b;
  b.fingerprint = 0x0123456789abcdefULL;
  for (index_t i = 0; i < n; ++i) b.nodes.push_back(3 * i + 1);
  b.matrix.resize(3 * n, 3 * n);
  for (Eigen::Index j = 0; j < b.matrix.cols(); ++j)
    for (Eigen::Index i = j; i < b.matrix.rows(); ++i) b.matrix(i, j) = b.matrix(j, i) = u(rng);
  return b;
}

std::size_t bytes_of(const std::filesystem::path& p) {
  return static_cast<std::size_t>(std::filesystem::file_size(p));
}

TEST(ComplianceCache, RoundTripsExactlyWithTheLowerTriangleOnly) {
  const tests::TempFolder dir;
  const auto b = random_block(7, 1);
  write_compliance_cache(dir / "c.bin", b);
  const auto r = read_compliance_cache(dir / "c.bin");
  EXPECT_EQ(r.fingerprint, b.fingerprint);
  EXPECT_EQ(r.nodes, b.nodes);
  EXPECT_EQ(r.matrix, b.matrix);  // bit-exact: doubles written and read as bytes
  // Header 32 + 7 node indices + 21·22/2 doubles + checksum: symmetric storage halves the file.
  EXPECT_EQ(bytes_of(dir / "c.bin"), 32 + 7 * 8 + 21 * 22 / 2 * 8 + 8);
}

TEST(ComplianceCache, DamagedFilesAreOneLineErrorsNamingTheFile) {
  const tests::TempFolder dir;
  const auto p = dir / "c.bin";
  write_compliance_cache(p, random_block(4, 2));
  std::string bytes;
  {
    std::ifstream in(p, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  auto write = [&](const std::string& b) {
    std::ofstream(p, std::ios::binary | std::ios::trunc) << b;
  };

  write(bytes.substr(0, bytes.size() - 20));
  expect_error([&] { (void)read_compliance_cache(p); }, {"c.bin", "truncated"});
  std::string flipped = bytes;
  flipped[100] = static_cast<char>(flipped[100] ^ 0x10);  // one bit of a matrix value
  write(flipped);
  expect_error([&] { (void)read_compliance_cache(p); }, {"c.bin", "checksum"});
  std::string version = bytes;
  version[8] = 9;
  write(version);
  expect_error([&] { (void)read_compliance_cache(p); }, {"c.bin", "version 9", "prepare again"});
  write("solid cube\nfacet normal 0 0 1\n");
  expect_error([&] { (void)read_compliance_cache(p); },
               {"c.bin", "not a brainshift compliance cache"});
  std::string huge = bytes;
  for (int k = 0; k < 8; ++k) huge[24 + k] = static_cast<char>(0x7f);  // node count ≈ 9e18
  write(huge);
  expect_error([&] { (void)read_compliance_cache(p); }, {"c.bin", "corrupted", "node count"});
  expect_error([&] { (void)read_compliance_cache(dir / "absent.bin"); },
               {"absent.bin", "cannot read"});
}

TEST(ComplianceCache, AMisSizedBlockIsRefusedAndNothingIsWritten) {
  const tests::TempFolder dir;
  auto b = random_block(3, 3);
  b.nodes.pop_back();
  expect_error([&] { write_compliance_cache(dir / "c.bin", b); }, {"c.bin", "9x9 for 2 nodes"});
  EXPECT_FALSE(std::filesystem::exists(dir / "c.bin"));
}

}  // namespace
}  // namespace brainshift::workflow
