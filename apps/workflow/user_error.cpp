#include "apps/workflow/user_error.hpp"

#include "core/error.hpp"

#include <filesystem>
#include <new>

namespace brainshift::workflow {
namespace {

/// One line of at most `limit` characters (newlines and tabs folded to spaces).
std::string one_line(std::string s, std::size_t limit = 300) {
  for (char& c : s)
    if (c == '\n' || c == '\r' || c == '\t') c = ' ';
  if (limit != std::string::npos && s.size() > limit) s = s.substr(0, limit - 3) + "...";
  return s;
}

}  // namespace

std::string user_message(const std::exception& e) {
  // Ours name the file and the problem, some with the choices (an unknown key lists the known
  // ones): whole, on one line.
  if (dynamic_cast<const brainshift::Error*>(&e) != nullptr)
    return one_line(e.what(), std::string::npos);
  if (const auto* f = dynamic_cast<const std::filesystem::filesystem_error*>(&e)) {
    std::string where = f->path1().string();
    if (!f->path2().empty()) where += " -> " + f->path2().string();
    return one_line((where.empty() ? std::string("a file") : where) + ": " + f->code().message());
  }
  if (dynamic_cast<const std::bad_alloc*>(&e) != nullptr)
    return "out of memory: an input is larger than this machine can hold (check the images' "
           "sizes; BRAINSHIFT_MAX_VOLUME_GB bounds what a header may claim)";
  return one_line(std::string("internal error: ") + e.what() + " (please report it)");
}

}  // namespace brainshift::workflow
