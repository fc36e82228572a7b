#include "core/error.hpp"

namespace brainshift::detail {

void throw_error(const char* file, int line, const std::string& message) {
  throw Error(message, std::string(file) + ":" + std::to_string(line));
}

}  // namespace brainshift::detail
