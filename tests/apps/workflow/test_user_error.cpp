// The one-line error contract for every failure (issue 36 item 2): no standard-library text
// ("std::bad_alloc", "filesystem error:") reaches the user; the file is named where the
// exception knows it.
#include "apps/workflow/user_error.hpp"
#include "core/error.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <new>
#include <stdexcept>
#include <system_error>

namespace brainshift::workflow {
namespace {

void expect_clean(const std::string& m) {
  EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  EXPECT_LE(m.size(), 300u) << m;
  EXPECT_EQ(m.find("std::"), std::string::npos) << m;
  EXPECT_EQ(m.find("filesystem error"), std::string::npos) << m;
}

TEST(UserError, OurErrorsAreKeptAsTheyAre) {
  const brainshift::Error e("scan.nii: NIfTI pixdim[1] = 0");
  EXPECT_EQ(user_message(e), "scan.nii: NIfTI pixdim[1] = 0");
}

TEST(UserError, FilesystemErrorsNameThePathAndTheProblem) {
  const std::filesystem::filesystem_error e("cannot get file size", "/data/series",
                                            std::make_error_code(std::errc::is_a_directory));
  const std::string m = user_message(e);
  expect_clean(m);
  EXPECT_EQ(m, "/data/series: " + std::make_error_code(std::errc::is_a_directory).message());
}

TEST(UserError, OutOfMemoryAndOtherFailuresAreOneCleanLine) {
  const std::string oom = user_message(std::bad_alloc());
  expect_clean(oom);
  EXPECT_EQ(oom.rfind("out of memory", 0), 0u) << oom;
  const std::string other = user_message(std::runtime_error(std::string(500, 'x') + "\nsecond"));
  expect_clean(other);
  EXPECT_EQ(other.rfind("internal error: ", 0), 0u) << other;
}

}  // namespace
}  // namespace brainshift::workflow
