#pragma once
/// @file
/// @brief Write a file so that nothing half-written is ever left under its name: write to a
/// temporary file in the same folder, then rename it over the target.

#include <filesystem>
#include <functional>

namespace brainshift::imaging {

/// Checks, without leaving anything behind, that a file can be created next to `target`: its
/// folder exists, is a folder, and accepts a new file. Lets a command fail before long work.
/// \throws brainshift::Error, one line naming `target` and the reason.
void verify_writable(const std::filesystem::path& target);

/// Calls `write(temporary)` and renames the temporary file to `target`.
/// @param[in] target  final path; its folder must exist and be writable.
/// @param[in] write   writes the whole file to the path it is given; throws on failure.
/// \throws brainshift::Error (one line, naming `target`) when the folder does not exist, when
/// `write` throws (its message is kept) or when the rename fails. The temporary file is removed
/// on every failure, and `target` is left as it was.
void write_atomically(const std::filesystem::path& target,
                      const std::function<void(const std::filesystem::path&)>& write);

}  // namespace brainshift::imaging
