#pragma once
/// @file
/// @brief Progress lines on stderr ("brainshift register: [1.2 s] pairing…") so that anything
/// longer than a second shows it is alive; results go to stdout.

#include <chrono>
#include <iostream>
#include <string>

namespace brainshift::apps {

class Progress {
 public:
  explicit Progress(std::string command) : m_command(std::move(command)), m_start(Clock::now()) {}
  /// One line on stderr naming the stage that starts now.
  void stage(const std::string& what) const {
    std::cerr << "brainshift " << m_command << ": [" << format(seconds()) << " s] " << what << "\n";
  }
  /// Seconds since construction.
  [[nodiscard]] double seconds() const { return std::chrono::duration<double>(Clock::now() - m_start).count(); }

 private:
  using Clock = std::chrono::steady_clock;
  static std::string format(double s) {
    char b[32];
    std::snprintf(b, sizeof b, "%.1f", s);
    return b;
  }
  std::string m_command;
  Clock::time_point m_start;
};

}  // namespace brainshift::apps
