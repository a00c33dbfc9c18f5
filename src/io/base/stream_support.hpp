// SPDX-License-Identifier: MIT
// Private helpers of the streaming readers (ced/io/stream.hpp) and of the
// header parsers they share with the whole-file readers (not installed).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "ced/cloud.hpp"
#include "ced/io/stream.hpp"

namespace ced::io::detail {

/// Thrown by a header parser reading a header_source that holds only the
/// first bytes of a file, when it needs bytes past them.
struct need_more_header {};

/// The text a header parser reads: the whole file (the whole-file readers),
/// or only its first bytes (the streaming readers, which read more and parse
/// again when the parser throws need_more_header). Either way the parser
/// decides exactly as on the whole file.
struct header_source {
  std::string_view text;  ///< the file's first bytes; all of them when `whole`
  bool whole = true;
  /// When !whole: whether the file holds `s` at or after byte `from`.
  std::function<bool(std::string_view s, std::uint64_t from)> file_contains;

  header_source() = default;
  /// The whole file's text.
  explicit header_source(std::string_view whole_file) : text(whole_file) {}

  /// Whether the whole file holds `s`.
  bool contains(std::string_view s) const {
    if (text.find(s) != std::string_view::npos) return true;
    if (whole) return false;
    return file_contains(s, text.size() >= s.size() ? text.size() - s.size() + 1 : 0);
  }
  /// The line at `pos` (up to '\n' or the end of the file, without the
  /// '\n'), moving `pos` past it; false when `pos` is at the end of the file.
  bool next_line(std::size_t& pos, std::string_view& line) const {
    if (pos >= text.size()) {
      if (whole) return false;
      throw need_more_header{};
    }
    const std::size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos && !whole) throw need_more_header{};
    line = text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    return true;
  }
};

/// A regular file read in pieces at given offsets, with bounded memory.
class input_file {
 public:
  /// Opens `path`; io_error naming it when it is a directory, cannot be
  /// opened or its size read.
  explicit input_file(const std::string& path);
  const std::string& path() const noexcept { return m_path; }
  std::uint64_t size() const noexcept { return m_size; }
  /// Up to `n` bytes at `offset` (fewer at the end of the file) into `buf`,
  /// resized to what was read.
  void read_some(std::uint64_t offset, std::size_t n, std::string& buf);
  /// Exactly `n` bytes at `offset` into `out`; io_error naming the file otherwise.
  void read_exact(std::uint64_t offset, std::size_t n, char* out);
  /// The same without moving the file's position: several threads may call it at once.
  void read_at(std::uint64_t offset, std::size_t n, char* out) const;
  /// Whether the file holds `s` at or after byte `from` (read in blocks).
  bool contains(std::string_view s, std::uint64_t from);
  /// Parses the header at the start of the file with `parse(const
  /// header_source&)`, reading more of the file whenever it asks for more.
  template <class Parse>
  auto parse_header(Parse&& parse) {
    std::string head;
    for (std::size_t want = std::size_t(1) << 16;; want *= 4) {
      read_some(0, want, head);
      header_source src;
      src.text = head;
      src.whole = head.size() < want;
      src.file_contains = [this](std::string_view s, std::uint64_t from) { return contains(s, from); };
      try {
        return parse(static_cast<const header_source&>(src));
      } catch (const need_more_header&) {
      }
    }
  }

 private:
  [[noreturn]] void fail_read(std::uint64_t offset, std::size_t n) const;
  struct closer {
    void operator()(std::FILE* f) const noexcept { std::fclose(f); }
  };
  std::string m_path;
  std::unique_ptr<std::FILE, closer> m_file;
  std::uint64_t m_size = 0;
};

/// A window on an input_file read front to back: at least the bytes asked
/// for are in memory at data() (fewer only at the end of the file).
class sequential_reader {
 public:
  sequential_reader(input_file& file, std::uint64_t offset) : m_file(&file), m_offset(offset) {}
  /// The offset in the file of data()[0].
  std::uint64_t offset() const noexcept { return m_offset; }
  /// Bytes from offset() to the end of the file.
  std::uint64_t left() const noexcept { return m_file->size() - m_offset; }
  /// Makes min(n, left()) bytes available at data(); returns that count.
  std::size_t fill(std::size_t n);
  /// Bytes in memory at data().
  std::size_t available() const noexcept { return m_buf.size() - m_begin; }
  const char* data() const noexcept { return m_buf.data() + m_begin; }
  /// Moves `n` bytes on (past the end of what is in memory too).
  void skip(std::uint64_t n) noexcept;
  /// Moves to `offset`, forgetting what is in memory.
  void seek(std::uint64_t offset) noexcept;
  /// The next line (up to '\n' or the end of the file, without the '\n'),
  /// moving past it; false at the end of the file. Valid until the next call.
  bool next_line(std::string_view& line);

 private:
  input_file* m_file;
  std::uint64_t m_offset;
  std::string m_buf;
  std::size_t m_begin = 0;  // m_buf[m_begin] is the byte at m_offset
};

/// The box of the finite points, taken as choose_origin(x, y, z, n) takes it
/// (the same minima and maxima, in the same order).
struct finite_box {
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  bool any = false;
  void add(double x, double y, double z) noexcept {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return;
    const double v[3] = {x, y, z};
    for (int k = 0; k < 3; ++k) {
      lo[k] = any ? std::min(lo[k], v[k]) : v[k];
      hi[k] = any ? std::max(hi[k], v[k]) : v[k];
    }
    any = true;
  }
  /// Adds the points of another box (the boxes of the chunks of a file,
  /// merged in order, are the box of the file).
  void merge(const finite_box& o) noexcept {
    if (!o.any) return;
    for (int k = 0; k < 3; ++k) {
      lo[k] = any ? std::min(lo[k], o.lo[k]) : o.lo[k];
      hi[k] = any ? std::max(hi[k], o.hi[k]) : o.hi[k];
    }
    any = true;
  }
};

/// What the streaming readers of PLY, PCD and CSV share: the first pass
/// learns the finite box of the points, which gives origin() and bounds().
class box_stream : public point_stream {
 public:
  std::array<double, 3> origin() const override { return choose_origin(m_box.lo, m_box.hi); }
  void bounds(double lo[3], double hi[3]) const override {
    for (int k = 0; k < 3; ++k) {
      lo[k] = m_box.lo[k];
      hi[k] = m_box.hi[k];
    }
  }
  bool streaming() const noexcept override { return true; }

 protected:
  /// Makes `out` a cloud of the n points (x[i], y[i], z[i]), absolute,
  /// relative to `origin` (as cloud_at() does); during the first pass, adds
  /// them to the box.
  void set_positions(point_cloud& out, const double* x, const double* y, const double* z, std::size_t n,
                     const std::array<double, 3>& origin);

  finite_box m_box;
  bool m_first_pass_done = false;
};

}  // namespace ced::io::detail
