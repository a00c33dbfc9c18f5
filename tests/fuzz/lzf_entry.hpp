// SPDX-License-Identifier: MIT
// What fuzz_lzf feeds one input to (shared with test_lzf): the input is read
// as a small program that writes data with the structure LZF meets in PCD
// columns (literals, copies at any distance up to past the 8 KiB reach,
// runs, slowly varying floats), and every way lzf_compress() can parse it
// must give the bytes of the plain parse a position at a time: the AVX2
// passes, the portable passes, and segments parsed on threads and joined.
// The bytes must decompress to the data. Returns what went wrong, or "".
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

#include "ced/io/lzf.hpp"
#include "io/base/scalar_io.hpp"

namespace ced_fuzz {

/// The data that `program` writes (at most max_bytes).
inline std::string lzf_data(std::string_view program, std::size_t max_bytes = std::size_t(1) << 18) {
  std::string out;
  std::size_t at = 0;
  auto next = [&]() -> unsigned { return at < program.size() ? static_cast<unsigned char>(program[at++]) : 0u; };
  while (at < program.size() && out.size() < max_bytes) {
    const unsigned op = next();
    switch (op % 5) {
      case 0: {  // literals from the program
        const std::size_t n = op / 5 + 1;
        for (std::size_t i = 0; i < n && at < program.size(); ++i) out += static_cast<char>(next());
        break;
      }
      case 1:
      case 2: {  // a copy from a distance (up to 8,448: past LZF's reach), overlapping allowed
        if (out.empty()) break;
        const std::size_t d = 1 + ((next() << 8 | next()) % (op % 5 == 1 ? 8448u : 64u)) % out.size();
        const std::size_t n = 1 + next() * (op / 5 + 1);
        for (std::size_t i = 0; i < n; ++i) out += out[out.size() - d];
        break;
      }
      case 3: {  // a run of one byte
        const char c = static_cast<char>(next());
        out.append(1 + next() * (op / 5 + 1), c);
        break;
      }
      default: {  // slowly varying floats, as a PCD column
        const unsigned n = 1 + next() * 4, seed = next();
        std::uint32_t s = seed * 2654435761u + 1;
        for (unsigned i = 0; i < n; ++i) {
          s = s * 1664525u + 1013904223u;
          const float f = static_cast<float>(i % (op / 5 + 7)) * 0.01f + static_cast<float>(s >> 26) * 1e-4f;
          char b[sizeof f];
          std::memcpy(b, &f, sizeof f);
          out.append(b, sizeof f);
        }
      }
    }
  }
  if (out.size() > max_bytes) out.resize(max_bytes);
  return out;
}

/// Every parse of `data` against the plain one; "" when all agree and the
/// bytes decompress to `data`. `segment`: the segment size of the threaded
/// parses (at least 64 on inputs over 5,000 bytes: each segment seeds 8 KiB).
inline std::string lzf_check(const std::string& data, std::size_t segment) {
  namespace d = ced::io::detail;
  const std::string plain = d::lzf_compress_reference(data);
  if (ced::io::lzf_compress(data) != plain) return "lzf_compress differs from the plain parse";
  d::lzf_vector_passes = false;
  const std::string portable = d::lzf_compress_segmented(data, data.size() + 1, 1);
  d::lzf_vector_passes = true;
  if (portable != plain) return "the portable passes differ from the plain parse";
  if (d::lzf_compress_segmented(data, data.size() + 1, 1) != plain) return "the vector passes differ";
  for (unsigned threads : {2u, 3u})
    if (d::lzf_compress_segmented(data, segment, threads) != plain)
      return "segments of " + std::to_string(segment) + " on " + std::to_string(threads) + " threads differ";
  if (ced::io::lzf_decompress(plain, data.size(), "fuzz.lzf") != data) return "the bytes do not decompress to the data";
  return "";
}

/// One fuzz input: its first byte chooses the segment size, the rest is the program.
inline std::string lzf_one(std::string_view input) {
  if (input.empty()) return "";
  const std::string data = lzf_data(input.substr(1));
  const std::size_t segment = 64 + std::size_t(static_cast<unsigned char>(input[0])) * 97;
  return lzf_check(data, segment);
}

}  // namespace ced_fuzz
