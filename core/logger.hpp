#pragma once
/// @file
/// @brief The brainshift logger (spdlog). Library code logs here, never to std::cout.

#include <spdlog/spdlog.h>

namespace brainshift {

/// The shared logger, created on first use, writing to stderr. Level from BS_LOG_LEVEL
/// (trace, debug, info, warn, error, off); default warn.
spdlog::logger& logger();

}  // namespace brainshift
