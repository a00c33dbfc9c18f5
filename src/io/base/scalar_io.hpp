// SPDX-License-Identifier: MIT
// Private helpers shared by the readers and writers in src/io (not installed).
#pragma once

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <limits>
#include <memory>
#include <ostream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/io/output_file.hpp"
#include "core/parallel.hpp"
#include "core/raw_vector.hpp"
#include "core/text.hpp"

namespace ced::io {
struct las_write_options;
}

namespace ced::io::detail {

/// The whole file at `path`; io_error naming it when it is a directory,
/// cannot be opened or cannot be read. (Defined in output_file.cpp.)
std::string read_whole_file(const std::string& path);

/// The lines of text [p, end) that hold a word (not blank, is_space), and
/// the line ends ('\n') among them: what the ascii readers count to cut a
/// body into blocks of whole lines.
inline std::pair<std::size_t, std::size_t> count_lines(const char* p, const char* const end) noexcept {
  std::size_t filled = 0, lines = 0;
  while (p < end) {
    const auto* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
    const char* const line_end = nl ? nl : end;
    while (p < line_end && ced::detail::is_space(*p)) ++p;  // a value usually starts the line
    filled += p < line_end;
    lines += nl != nullptr;
    p = nl ? nl + 1 : end;
  }
  return {filled, lines};
}

/// [begin, end) cut at line ends into `blocks` pieces of about equal size:
/// cut[0] = begin, cut[blocks] = end.
inline std::vector<const char*> cut_lines(const char* begin, const char* end, std::size_t blocks) {
  std::vector<const char*> cut(blocks + 1, end);
  cut[0] = begin;
  const auto bytes = static_cast<std::size_t>(end - begin);
  for (std::size_t k = 1; k < blocks; ++k) {
    const char* from = std::max(begin + k * (bytes / blocks), cut[k - 1]);
    const auto* nl = static_cast<const char*>(std::memchr(from, '\n', static_cast<std::size_t>(end - from)));
    cut[k] = nl ? nl + 1 : end;
  }
  return cut;
}

/// How many blocks of whole lines an ascii body of `bytes` is parsed in: 1
/// (one thread) unless there are threads and at least 2 MiB; at most 4 a
/// thread, each at least 1 MiB.
inline std::size_t ascii_blocks(std::size_t bytes) noexcept {
  const std::size_t threads = ced::detail::effective_threads(0);
  return threads <= 1 ? 1 : std::max<std::size_t>(1, std::min(4 * threads, bytes >> 20));
}

/// Runs f(k) for every block k < blocks on the threads. An exception of
/// f(k) ends block k only; when all are done, the first block's exception is
/// rethrown: the one that one thread, block after block, would have met.
template <class F>
void for_each_block(std::size_t blocks, F&& f) {
  std::vector<std::exception_ptr> errors(blocks);
  ced::detail::parallel_for(blocks, 0, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t k = b; k < e; ++k) try {
        f(k);
      } catch (...) {
        errors[k] = std::current_exception();
      }
  });
  for (const auto& error : errors)
    if (error) std::rethrow_exception(error);
}

/// lzf_compress() into `out` (resized to the compressed size), with segments
/// of `segment` bytes parsed on up to `threads` threads (0: all cores, or the
/// enclosing limit): the same bytes for any segment size and thread count
/// (lzf.cpp; tests force small segments).
void lzf_compress_into(std::string_view in, ced::detail::raw_column_vector<unsigned char>& out, std::size_t segment,
                       unsigned threads);
std::string lzf_compress_segmented(std::string_view in, std::size_t segment, unsigned threads);
/// Whether lzf_compress() may use its AVX2 passes where the CPU has them
/// (tests turn them off to check the portable ones; not thread-safe).
extern bool lzf_vector_passes;
/// The greedy parse of lzf_compress(), a position at a time on one thread:
/// the reference its faster passes must equal byte for byte (tests).
std::string lzf_compress_reference(std::string_view in);
/// The segment size lzf_compress() uses for n bytes.
std::size_t lzf_segment_bytes(std::size_t n) noexcept;
/// lzf_decompress() into the out_size bytes at `out` (ced/io/lzf.hpp; lzf.cpp).
void lzf_decompress_into(std::string_view in, char* out, std::size_t out_size, const std::string& name_for_errors);

/// The most values per point, x, y and z included, that the PLY, PCD and CSV
/// readers accept: the properties of a PLY element, the values of a PCD
/// point (its COUNTs summed), the columns of a CSV file. Each becomes a cloud
/// field found through its name index, so the bound only keeps a header from
/// asking for absurd numbers of fields. The writers write no more than this,
/// so that ced reads back what it writes.
constexpr std::size_t max_values_per_point = 65536;

/// Throws io_error when a point of `values` values (x, y and z included, as
/// written in `format`) is more than the readers accept.
inline void check_values_per_point(std::size_t values, const char* format) {
  if (values > max_values_per_point)
    throw io_error(std::string("cannot write ") + format + ": " + std::to_string(values) +
                   " values per point (x, y, z and " + std::to_string(values - 3) +
                   " more), and ced's readers accept at most " + std::to_string(max_values_per_point));
}

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
  try {
    write(file.stream());
  } catch (const io_error& e) {
    throw io_error(path + ": " + e.what());
  }
  file.commit();
}

/// A format's writer of a cloud in pieces (io::cloud_writer): made by
/// <format>_pieces(out, layout, n), which writes the header of n points with
/// `layout`'s fields and origin; then write() the points, chunk by chunk.
/// The bytes are those of the format's writer of the whole cloud.
class piece_writer {
 public:
  virtual ~piece_writer() = default;
  virtual void write(std::ostream& out, const point_cloud& chunk) = 0;
  /// After the last chunk: what follows the points (LAZ: the last chunk
  /// and the chunk table).
  virtual void finish(std::ostream& out) { (void)out; }
  /// The header again, when what it says is known only at the end (LAS: the
  /// bounds and counts by return); empty when the first was final.
  virtual std::string final_header() { return {}; }
};

// The text helpers of core, for the readers.
using ced::detail::iequal;
using ced::detail::is_space;
using ced::detail::printable;
using ced::detail::split_words;
using ced::detail::to_lower;
using ced::detail::trim;
using ced::detail::word_reader;

inline bool host_little_endian() noexcept {
  const std::uint16_t one = 1;
  unsigned char b = 0;
  std::memcpy(&b, &one, 1);
  return b == 1;
}

/// The sizeof(T) bytes at p as a T, in reverse order when Swap.
template <class T, bool Swap>
T load(const unsigned char* p) noexcept {
  unsigned char b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if constexpr (Swap) std::reverse(b, b + sizeof(T));
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

/// Stores the bytes of `v` at p, in reverse order when Swap.
template <class T, bool Swap>
void store(unsigned char* p, T v) noexcept {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if constexpr (Swap) std::reverse(b, b + sizeof(T));
  std::memcpy(p, b, sizeof(T));
}

/// Little-endian load/store, whatever the host byte order (a plain load or
/// store on little-endian hosts).
template <class T>
T load_le(const unsigned char* p) noexcept {
  return host_little_endian() ? load<T, false>(p) : load<T, true>(p);
}

template <class T>
void store_le(unsigned char* p, T v) noexcept {
  if (host_little_endian())
    store<T, false>(p, v);
  else
    store<T, true>(p, v);
}

/// out[i] = the value of type t at p + i * stride, for i < n; its bytes
/// reversed when `swap`.
inline void decode_column(const unsigned char* p, std::size_t stride, std::size_t n, scalar_type t, bool swap,
                          double* out) noexcept {
  visit_type(t, [&](auto tag) {
    using T = decltype(tag);
    if (swap)
      for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<double>(load<T, true>(p + i * stride));
    else
      for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<double>(load<T, false>(p + i * stride));
  });
}

/// Rounds and clamps to T's range (NaN -> 0) for integers; float: overflow -> inf.
template <class T>
T convert(double v) noexcept {
  return convert_value<T>(v);
}

/// Stores convert<T>(value(i)) at p + i * stride for i < n, T the type that
/// stores t; its bytes reversed when `swap`.
template <class Value>
void encode_values(scalar_type t, bool swap, unsigned char* p, std::size_t stride, std::size_t n, Value&& value) {
  visit_type(t, [&](auto tag) {
    using T = decltype(tag);
    if (swap)
      for (std::size_t i = 0; i < n; ++i) store<T, true>(p + i * stride, convert<T>(value(i)));
    else
      for (std::size_t i = 0; i < n; ++i) store<T, false>(p + i * stride, convert<T>(value(i)));
  });
}

/// `f` as a conversion to double and back leaves it: a signalling NaN
/// quieted. (Compilers assume there are no signalling NaNs and fold the
/// round trip itself away.)
inline float through_double(float f) noexcept {
  if (f == f) return f;
  std::uint32_t bits = 0;
  std::memcpy(&bits, &f, 4);
  bits |= 0x00400000u;  // the quiet bit
  std::memcpy(&f, &bits, 4);
  return f;
}

/// What encode_values() stores for the m values of `values` from i0 on,
/// encoded as their own type t, stored straight from the column: true when
/// it could (the column's type is t, not a 64-bit integer, which a double
/// may round), false otherwise, nothing stored. Floats go through double as
/// there (a signalling NaN is quieted).
inline bool can_encode_direct(const column* values, scalar_type t) noexcept {
  return values && values->type() == t && t != scalar_type::int64 && t != scalar_type::uint64;
}
inline bool encode_direct(const column& values, std::size_t i0, std::size_t m, scalar_type t, bool swap,
                          unsigned char* p, std::size_t stride) {
  if (!can_encode_direct(&values, t)) return false;
  values.visit([&](const auto* src, std::size_t) {
    using T = std::remove_const_t<std::remove_pointer_t<decltype(src)>>;
    const auto value = [&](std::size_t i) {
      if constexpr (std::is_same_v<T, float>) return through_double(src[i0 + i]);
      return src[i0 + i];
    };
    if (swap)
      for (std::size_t i = 0; i < m; ++i) store<T, true>(p + i * stride, value(i));
    else
      for (std::size_t i = 0; i < m; ++i) store<T, false>(p + i * stride, value(i));
  });
  return true;
}

/// Writes at p the shortest text that reads back as convert<T>(v), T the type
/// that stores t; returns the end of the text.
inline char* format_value(char* p, char* end, double v, scalar_type t) noexcept {
  std::to_chars_result r{};
  visit_type(t, [&](auto tag) {
    using T = decltype(tag);
    r = std::to_chars(p, end, convert<T>(v));
  });
  return r.ptr;
}

/// v[i] = the value of `values` for point i0 + i, for i < m.
inline void copy_values(const column& values, std::size_t i0, std::size_t m, double* v) {
  values.visit([&](const auto* src, std::size_t) {
    for (std::size_t i = 0; i < m; ++i) v[i] = static_cast<double>(src[i0 + i]);
  });
}

/// How write_points() writes a point: a line of text, its values separated by
/// `separator`, or a binary record, its values one after the other (their
/// bytes reversed when `swap`).
struct point_format {
  bool text = false;
  char separator = ' ';
  bool swap = false;
};

/// Writes `chunks` pieces in order, the bytes of piece k made by
/// encode(k, bytes) (`bytes` to be overwritten): batches of pieces are made in
/// parallel, then written one after the other, so the output is the same for
/// any number of threads. `encode` must only read what it shares.
template <class Encode>
void write_chunks(std::ostream& out, std::size_t chunks, Encode&& encode) {
  constexpr std::size_t batch = 32;
  std::vector<std::string> bytes(std::min(batch, chunks));
  for (std::size_t b0 = 0; b0 < chunks; b0 += batch) {
    const std::size_t nb = std::min(batch, chunks - b0);
    ced::detail::parallel_for(nb, 0, 1, [&](std::size_t b, std::size_t e) {
      for (std::size_t k = b; k < e; ++k) encode(b0 + k, bytes[k]);
    });
    for (std::size_t k = 0; k < nb; ++k) out.write(bytes[k].data(), static_cast<std::streamsize>(bytes[k].size()));
  }
}

/// The text or binary bytes of m points (values column-major: value c of
/// point i at vals[c * stride + i]; in binary, value c from direct[c] when
/// encode_direct() can: points i0 to i0 + m - 1) into `buf`; write_points()
/// writes them.
inline void encode_points(const std::vector<scalar_type>& types, point_format fmt, const double* vals,
                          std::size_t stride, const std::vector<const column*>& direct, std::size_t i0, std::size_t m,
                          std::string& buf) {
  const std::size_t nc = types.size();
  if (fmt.text) {
    buf.resize(m * nc * 32);
    char* p = buf.data();
    char* const end = p + buf.size();
    for (std::size_t i = 0; i < m; ++i)
      for (std::size_t c = 0; c < nc; ++c) {
        p = format_value(p, end, vals[c * stride + i], types[c]);
        *p++ = c + 1 == nc ? '\n' : fmt.separator;
      }
    buf.resize(static_cast<std::size_t>(p - buf.data()));
    return;
  }
  std::size_t record = 0;
  for (scalar_type t : types) record += size_of(t);
  buf.resize(m * record);
  auto* base = reinterpret_cast<unsigned char*>(buf.data());
  std::size_t offset = 0;
  for (std::size_t c = 0; c < nc; ++c) {
    const double* v = vals + c * stride;
    if (direct.empty() || !direct[c] || !encode_direct(*direct[c], i0, m, types[c], fmt.swap, base + offset, record))
      encode_values(types[c], fmt.swap, base + offset, record, m, [v](std::size_t i) { return v[i]; });
    offset += size_of(types[c]);
  }
}

/// Writes n points whose value c has type types[c], in chunks encoded in
/// parallel (write_chunks()): fill(c, i0, m, v) sets v[i] to value c of point
/// i0 + i, for i < m, and may be called from several threads at once. In
/// binary, value c is taken from the column direct[c] instead when it is set
/// and encode_direct() can (the same bytes, faster).
template <class Fill>
void write_points(std::ostream& out, std::size_t n, const std::vector<scalar_type>& types, point_format fmt,
                  Fill&& fill, const std::vector<const column*>& direct = {}) {
  const std::size_t nc = types.size();
  // Up to 4096 points a chunk, fewer when there are many values per point:
  // a chunk's values take at most ~2^20 doubles (8 MiB), not 4096 x 65536
  // (2 GiB). The bytes written do not depend on the chunk size.
  const std::size_t chunk =
      std::clamp<std::size_t>(std::min<std::size_t>(n, (std::size_t{1} << 20) / std::max<std::size_t>(nc, 1)), 1, 4096);
  const std::vector<const column*> none;
  write_chunks(out, (n + chunk - 1) / chunk, [&](std::size_t k, std::string& buf) {
    thread_local std::vector<double> vals;  // column-major: value c of point i0 + i at vals[c * chunk + i]
    vals.resize(chunk * nc);
    const std::size_t i0 = k * chunk, m = std::min(chunk, n - i0);
    const std::vector<const column*>& from = fmt.text ? none : direct;
    for (std::size_t c = 0; c < nc; ++c)
      if (from.empty() || !can_encode_direct(from[c], types[c])) fill(c, i0, m, vals.data() + c * chunk);
    encode_points(types, fmt, vals.data(), chunk, from, i0, m, buf);
  });
}

/// Throws std::invalid_argument unless field f has a value for each of n points.
inline void check_field_size(const field& f, std::size_t n) {
  if (f.values.size() != n)
    throw std::invalid_argument("field '" + f.name + "' has " + std::to_string(f.values.size()) + " values for " +
                                std::to_string(n) + " points");
}

/// A cloud of the n points (x[i], y[i], z[i]), absolute coordinates: its
/// origin from choose_origin(), its positions relative to that; no fields.
inline point_cloud cloud_at(const double* x, const double* y, const double* z, std::size_t n) {
  const double* xyz[3] = {x, y, z};
  const std::array<double, 3> origin = choose_origin(x, y, z, n);
  point_cloud cloud;
  cloud.set_origin(origin);
  cloud.resize(n);
  float* out = cloud.positions().data();
  for (std::size_t k = 0; k < 3; ++k)
    for (std::size_t i = 0; i < n; ++i) out[3 * i + k] = static_cast<float>(xyz[k][i] - origin[k]);
  return cloud;
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

/// Fails for a value that parse_ascii_value() refused with status `s`:
/// `what` (which names the value), then why, for type t.
[[noreturn]] inline void fail_value(const std::string& file, const std::string& what, parse_status s, scalar_type t) {
  const std::string type(name_of(t));
  if (s == parse_status::not_a_number) throw io_error(file, what + "is not a number (expected " + type + ")");
  if (s == parse_status::not_an_integer) throw io_error(file, what + "is not an integer (expected " + type + ")");
  throw io_error(file, what + "is out of range for " + type);
}

}  // namespace ced::io::detail
