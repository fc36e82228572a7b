#include "temp_folder.hpp"

#include "core/error.hpp"
#include "imaging/io/atomic_write.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

namespace brainshift::imaging {
namespace {

std::string read_all(const std::filesystem::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(AtomicWrite, VerifyWritableLeavesNothingBehind) {
  const tests::TempFolder dir;
  EXPECT_NO_THROW(verify_writable(dir / "out.vtu"));
  EXPECT_EQ(dir.count(), 0u);
  EXPECT_THROW(verify_writable(dir / "missing" / "out.vtu"), Error);
  EXPECT_THROW(verify_writable(dir.path()), Error);  // a folder, not a file
}

TEST(AtomicWrite, AFailedWriteKeepsTheOldFileAndLeavesNoTemporary) {
  const tests::TempFolder dir;
  const auto target = dir / "a.txt";
  write_atomically(target, [](const std::filesystem::path& p) { std::ofstream(p) << "old"; });
  EXPECT_THROW(write_atomically(target,
                                [](const std::filesystem::path& p) {
                                  std::ofstream(p) << "half";
                                  throw Error("disk full");
                                }),
               Error);
  EXPECT_EQ(read_all(target), "old");
  EXPECT_EQ(dir.count(), 1u);
  write_atomically(target, [](const std::filesystem::path& p) { std::ofstream(p) << "new"; });
  EXPECT_EQ(read_all(target), "new");
  EXPECT_EQ(dir.count(), 1u);
}

}  // namespace
}  // namespace brainshift::imaging
