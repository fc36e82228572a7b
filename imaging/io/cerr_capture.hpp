#pragma once
/// @file
/// @brief std::cerr captured into a string while an object lives: MetaIO (VTK's MetaImage reader)
/// reports its problems there, over several lines, and some without failing the read.

#include <iostream>
#include <sstream>
#include <string>

namespace brainshift::imaging {

/// While alive, std::cerr goes to a string: metaio reports problems there (several lines, and
/// some, like truncated data, without failing the read). Not for concurrent use of std::cerr.
class CerrCapture {
 public:
  CerrCapture() : m_previous(std::cerr.rdbuf(m_text.rdbuf())) {}
  ~CerrCapture() { std::cerr.rdbuf(m_previous); }
  CerrCapture(const CerrCapture&) = delete;
  CerrCapture& operator=(const CerrCapture&) = delete;
  /// The last line written, trimmed; empty when nothing was.
  [[nodiscard]] std::string last_line() const {
    std::istringstream in(m_text.str());
    std::string last;
    for (std::string line; std::getline(in, line);)
      if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
    return last;
  }

 private:
  std::ostringstream m_text;
  std::streambuf* m_previous;
};

}  // namespace brainshift::imaging
