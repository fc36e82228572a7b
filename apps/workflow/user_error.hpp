#pragma once
/// @file
/// @brief The one-line error a command prints for any failure: brainshift's
/// own errors as they are (they name the file and the problem); the standard library's turned
/// into the same contract, without its implementation's text (`std::bad_alloc`,
/// "filesystem error: …").

#include <exception>
#include <string>

namespace brainshift::workflow {

/// The message after "brainshift: error: " for `e`, on one line:
/// - brainshift::Error: its text, whole (it names the file and the problem, and may list the
///   valid choices);
/// and the others at most 300 characters:
/// - std::filesystem::filesystem_error: "PATH: PROBLEM" (the operating system's words for the
///   error code, e.g. "No such file or directory"), with the second path when there is one;
/// - std::bad_alloc: "out of memory: ..." with what to try;
/// - anything else: "internal error: TEXT" (a bug to report), newlines folded.
std::string user_message(const std::exception& e);

}  // namespace brainshift::workflow
