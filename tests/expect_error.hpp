#pragma once
/// @file
/// @brief Runs a callable and expects a brainshift::Error whose message is one line containing
/// every needle (the "bad input gets a one-line error naming the file and the problem" contract).

#include "core/error.hpp"

#include <gtest/gtest.h>

#include <initializer_list>
#include <string>

namespace brainshift::tests {

template <typename F>
void expect_error(F&& f, std::initializer_list<std::string> needles) {
  try {
    f();
    ADD_FAILURE() << "no error thrown";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "not one line: " << msg;
    for (const auto& n : needles) EXPECT_NE(msg.find(n), std::string::npos) << msg;
  }
}

}  // namespace brainshift::tests
