#pragma once
/// @file
/// @brief Progress lines on stderr ("brainshift register: [1.2 s] pairing…") so that anything
/// longer than a second shows it is alive; results go to stdout. A sink can take the stages
/// instead (the Slicer modules report them in Slicer's `<filter-progress>` format).

#include "core/timing.hpp"

#include <functional>
#include <iostream>
#include <string>
#include <utility>

namespace brainshift::workflow {

class Progress {
 public:
  /// Receives each stage (what starts now, seconds since construction) instead of stderr.
  using Sink = std::function<void(const std::string& what, double seconds)>;
  explicit Progress(std::string command, Sink sink = {})
      : m_command(std::move(command)), m_sink(std::move(sink)) {}
  /// One line on stderr (or a call of the sink) naming the stage that starts now.
  void stage(const std::string& what) const {
    if (m_sink) {
      m_sink(what, seconds());
      return;
    }
    std::cerr << "brainshift " << m_command << ": [" << format(seconds()) << " s] " << what << "\n";
  }
  /// Seconds since construction.
  [[nodiscard]] double seconds() const { return m_watch.seconds(); }

 private:
  static std::string format(double s) {
    char b[32];
    std::snprintf(b, sizeof b, "%.1f", s);
    return b;
  }
  std::string m_command;
  Sink m_sink;
  core::Stopwatch m_watch;
};

}  // namespace brainshift::workflow
