// SPDX-License-Identifier: MIT
// LZF (ced/io/lzf.hpp), the compression of PCD binary_compressed.
#include "ced/io/lzf.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include "ced/io/error.hpp"
#include "scalar_io.hpp"

namespace ced::io {

std::string lzf_compress(std::string_view input) {
  const auto* in = reinterpret_cast<const unsigned char*>(input.data());
  const std::size_t n = input.size();
  std::string out;
  out.reserve(n + n / 32 + 16);
  constexpr unsigned hash_bits = 15;
  std::vector<std::size_t> table(std::size_t(1) << hash_bits, 0);  // position + 1 of the last 3-byte sequence; 0: none
  const auto hash = [in](std::size_t i) {
    const std::uint32_t v = (std::uint32_t(in[i]) << 16) | (std::uint32_t(in[i + 1]) << 8) | in[i + 2];
    return (v * 2654435761u) >> (32 - hash_bits);
  };
  std::size_t lit = 0;  // start of the pending literal run
  const auto flush_literals = [&](std::size_t end) {
    while (lit < end) {
      const std::size_t k = std::min<std::size_t>(32, end - lit);
      out.push_back(static_cast<char>(k - 1));
      out.append(reinterpret_cast<const char*>(in + lit), k);
      lit += k;
    }
  };
  std::size_t i = 0;
  while (i + 2 < n) {
    const auto h = hash(i);
    const std::size_t candidate = table[h];
    table[h] = i + 1;
    if (candidate != 0) {
      const std::size_t c = candidate - 1;
      const std::size_t distance = i - c;  // >= 1
      if (distance <= 8192 && in[c] == in[i] && in[c + 1] == in[i + 1] && in[c + 2] == in[i + 2]) {
        const std::size_t max_len = std::min<std::size_t>(264, n - i);
        std::size_t len = 3;
        while (len < max_len && in[c + len] == in[i + len]) ++len;
        flush_literals(i);
        const std::size_t l = len - 2, off = distance - 1;
        if (l < 7) {
          out.push_back(static_cast<char>((l << 5) | (off >> 8)));
        } else {
          out.push_back(static_cast<char>((7 << 5) | (off >> 8)));
          out.push_back(static_cast<char>(l - 7));
        }
        out.push_back(static_cast<char>(off & 0xff));
        const std::size_t next = i + len;
        for (std::size_t k = i + 1; k < next && k + 2 < n; ++k) table[hash(k)] = k + 1;
        i = lit = next;
        continue;
      }
    }
    ++i;
  }
  flush_literals(n);
  return out;
}

std::string lzf_decompress(std::string_view input, std::size_t out_size, const std::string& name_for_errors) {
  std::string result(out_size, '\0');
  detail::lzf_decompress_into(input, result.data(), out_size, name_for_errors);
  return result;
}

void detail::lzf_decompress_into(std::string_view input, char* output, std::size_t out_size,
                                 const std::string& name_for_errors) {
  const auto corrupt = [&](const std::string& why) {
    throw io_error(name_for_errors, "corrupt LZF data (" + why + ")");
  };
  const auto* in = reinterpret_cast<const unsigned char*>(input.data());
  const std::size_t n = input.size();
  auto* out = reinterpret_cast<unsigned char*>(output);
  std::size_t ip = 0, op = 0;
  while (ip < n) {
    const std::size_t at = ip;
    const unsigned ctrl = in[ip++];
    if (ctrl < 32) {
      const std::size_t run = ctrl + 1;
      if (run > n - ip)
        corrupt("a literal run of " + std::to_string(run) + " bytes at input offset " + std::to_string(at) +
                " goes past the end of the input");
      if (run > out_size - op) corrupt("the output would exceed the declared " + std::to_string(out_size) + " bytes");
      std::memcpy(out + op, in + ip, run);
      ip += run;
      op += run;
    } else {
      std::size_t len = ctrl >> 5;
      if (len == 7) {
        if (ip >= n) corrupt("truncated back-reference at input offset " + std::to_string(at));
        len += in[ip++];
      }
      if (ip >= n) corrupt("truncated back-reference at input offset " + std::to_string(at));
      const std::size_t distance = ((ctrl & 0x1fu) << 8) + in[ip++] + 1;
      if (distance > op)
        corrupt("a back-reference at input offset " + std::to_string(at) + " points before the start of the output");
      len += 2;
      if (len > out_size - op) corrupt("the output would exceed the declared " + std::to_string(out_size) + " bytes");
      const unsigned char* src = out + op - distance;
      if (distance >= len) {
        std::memcpy(out + op, src, len);
      } else {
        for (std::size_t k = 0; k < len; ++k) out[op + k] = src[k];  // overlapping: repeats a pattern
      }
      op += len;
    }
  }
  if (op != out_size)
    corrupt("it expands to " + std::to_string(op) + " bytes, not the declared " + std::to_string(out_size));
}

}  // namespace ced::io
