#pragma once
/// @file
/// @brief A fresh, uniquely named folder under the system temporary folder, removed with its
/// contents when the test ends.

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <unistd.h>

namespace brainshift::tests {

class TempFolder {
 public:
  TempFolder() {
    // Outside a test (a suite's SetUpTestSuite) there is no current test: the suite's name.
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const auto* suite = ::testing::UnitTest::GetInstance()->current_test_suite();
    std::string name = std::string("brainshift_") +
                       (info ? std::string(info->test_suite_name()) + "_" + info->name()
                             : std::string(suite ? suite->name() : "setup")) +
                       "_" + std::to_string(::getpid());
    for (char& c : name)
      if (c == '/') c = '_';
    m_path = std::filesystem::temp_directory_path() / name;
    std::filesystem::remove_all(m_path);
    std::filesystem::create_directories(m_path);
  }
  ~TempFolder() {
    std::error_code ec;
    std::filesystem::remove_all(m_path, ec);
  }
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;

  [[nodiscard]] const std::filesystem::path& path() const { return m_path; }
  [[nodiscard]] std::filesystem::path operator/(const std::string& name) const {
    return m_path / name;
  }
  /// Number of entries in the folder (to check nothing partial was left behind).
  [[nodiscard]] std::size_t count() const {
    std::size_t n = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(m_path)) ++n;
    return n;
  }

 private:
  std::filesystem::path m_path;
};

}  // namespace brainshift::tests
