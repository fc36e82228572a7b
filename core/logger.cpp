#include "core/logger.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>

#include <cstdlib>
#include <memory>

namespace brainshift {

spdlog::logger& logger() {
  static std::shared_ptr<spdlog::logger> instance = [] {
    auto l = spdlog::stderr_color_mt("brainshift");
    const char* level = std::getenv("BS_LOG_LEVEL");
    l->set_level(level != nullptr ? spdlog::level::from_str(level) : spdlog::level::warn);
    l->set_pattern("[%l] %v");
    return l;
  }();
  return *instance;
}

}  // namespace brainshift
