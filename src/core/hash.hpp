// SPDX-License-Identifier: MIT
// Private: the FNV-1a hash of bytes (not installed), for the names and
// digests ced derives from text: a tile plan's digest and fingerprint, a
// tiled run's default work directory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace ced::detail {

constexpr std::uint64_t fnv1a_offset = 1469598103934665603ull;

/// 64-bit FNV-1a of n bytes at p, continuing from `h`.
inline std::uint64_t fnv1a(const char* p, std::size_t n, std::uint64_t h = fnv1a_offset) noexcept {
  for (std::size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(p[i]);
    h *= 1099511628211ull;
  }
  return h;
}

inline std::uint64_t fnv1a(std::string_view s, std::uint64_t h = fnv1a_offset) noexcept {
  return fnv1a(s.data(), s.size(), h);
}

}  // namespace ced::detail
