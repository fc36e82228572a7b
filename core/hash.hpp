#pragma once
/// @file
/// @brief 64-bit FNV-1a: identifies files and model contents (caches, manifests). Not
/// cryptographic.

#include <cstddef>
#include <cstdint>

namespace brainshift::core {

inline constexpr std::uint64_t fnv1a_offset = 1469598103934665603ULL;

/// FNV-1a of `bytes` bytes at `data`, continuing from `h` (fnv1a_offset to start).
inline std::uint64_t fnv1a(const void* data, std::size_t bytes, std::uint64_t h = fnv1a_offset) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < bytes; ++i) {
    h ^= p[i];
    h *= 1099511628211ULL;
  }
  return h;
}

}  // namespace brainshift::core
