// SPDX-License-Identifier: MIT
// Private helpers shared by the readers and writers in src/io (not installed).
#pragma once

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <ostream>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>

#include "ced/cloud.hpp"
#include "ced/io/output_file.hpp"

namespace ced::io::detail {

/// The whole file at `path`; io_error naming it when it is a directory,
/// cannot be opened or cannot be read. (Defined in output_file.cpp.)
std::string read_whole_file(const std::string& path);

/// The public stream overload of every writer: `write(out)`, then a flush;
/// io_error naming `format` when the stream has failed.
template <class Write>
void write_to_stream(std::ostream& out, const char* format, Write&& write) {
  write(out);
  out.flush();
  if (!out) throw io_error(std::string("error writing ") + format + " data to the output stream");
}

/// The public path overload of every writer: `write(stream)` into an
/// atomic_output_file, committed only when the whole file was written.
template <class Write>
void write_to_file(const std::string& path, Write&& write) {
  atomic_output_file file(path);
  write(file.stream());
  file.commit();
}

inline bool host_little_endian() noexcept {
  const std::uint16_t one = 1;
  unsigned char b = 0;
  std::memcpy(&b, &one, 1);
  return b == 1;
}

/// Little-endian load/store (PCD binary data is little-endian in practice).
template <class T>
T load_le(const unsigned char* p) noexcept {
  unsigned char b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if (!host_little_endian()) std::reverse(b, b + sizeof(T));
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

template <class T>
void store_le(unsigned char* p, T v) noexcept {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (!host_little_endian()) std::reverse(b, b + sizeof(T));
  std::memcpy(p, b, sizeof(T));
}

/// Rounds and clamps to T's range (NaN -> 0) for integers; float: overflow -> inf.
template <class T>
T convert(double v) noexcept {
  return convert_value<T>(v);
}

enum class parse_status { ok, not_a_number, not_an_integer, out_of_range };

inline parse_status parse_double(std::string_view tok, double& out) noexcept {
  const char* b = tok.data();
  const char* e = b + tok.size();
  if (b != e && *b == '+') ++b;
  const auto r = std::from_chars(b, e, out);
  if (r.ptr != e || (r.ec != std::errc() && r.ec != std::errc::result_out_of_range)) return parse_status::not_a_number;
  if (r.ec == std::errc::result_out_of_range) {  // overflow, or underflow to a denormal/zero
    char buf[128];
    if (tok.size() >= sizeof(buf)) return parse_status::out_of_range;
    std::memcpy(buf, tok.data(), tok.size());
    buf[tok.size()] = '\0';
    out = std::strtod(buf, nullptr);
    if (std::isinf(out)) return parse_status::out_of_range;
  }
  return parse_status::ok;
}

inline parse_status parse_ascii_value(std::string_view tok, scalar_type t, double& out) noexcept {
  if (!is_integer(t)) {
    const parse_status s = parse_double(tok, out);
    if (s != parse_status::ok) return s;
    if (t == scalar_type::float32) {
      if (std::isfinite(out) && std::fabs(out) > std::numeric_limits<float>::max()) return parse_status::out_of_range;
      out = static_cast<double>(static_cast<float>(out));
    }
    return parse_status::ok;
  }
  const auto range = natural_range(t);
  const char* b = tok.data();
  const char* e = b + tok.size();
  if (b != e && *b == '+') ++b;
  if (t == scalar_type::uint64) {
    std::uint64_t v = 0;
    const auto r = std::from_chars(b, e, v);
    if (r.ptr == e && r.ec == std::errc()) return out = static_cast<double>(v), parse_status::ok;
    if (r.ptr == e && r.ec == std::errc::result_out_of_range) return parse_status::out_of_range;
  } else {
    std::int64_t v = 0;
    const auto r = std::from_chars(b, e, v);
    if (r.ptr == e && r.ec == std::errc()) {
      out = static_cast<double>(v);
      return out < range[0] || out > range[1] ? parse_status::out_of_range : parse_status::ok;
    }
    if (r.ptr == e && r.ec == std::errc::result_out_of_range) return parse_status::out_of_range;
  }
  // Tolerate integral values written as floats ("255.0", "1e3").
  const parse_status s = parse_double(tok, out);
  if (s != parse_status::ok) return s;
  if (!std::isfinite(out) || out != std::floor(out)) return parse_status::not_an_integer;
  return out < range[0] || out > range[1] ? parse_status::out_of_range : parse_status::ok;
}

}  // namespace ced::io::detail
