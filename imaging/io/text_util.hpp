#pragma once
/// @file
/// @brief Small text helpers of the header and landmark readers (imaging/io).

#include <algorithm>
#include <cctype>
#include <string>
#include <string_view>

namespace brainshift::imaging {

/// `s` without leading and trailing spaces, tabs and line ends.
inline std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}

/// `s` in lower case (ASCII).
inline std::string lower_case(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

}  // namespace brainshift::imaging
