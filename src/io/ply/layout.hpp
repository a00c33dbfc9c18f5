// SPDX-License-Identifier: MIT
// What the parts of the PLY reader and writer share (header.cpp, read.cpp, write.cpp,
// stream.cpp): the header as parsed, its elements and properties, the record layout. Private to src/io/ply/.
#pragma once

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <istream>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <unordered_set>

#include "ced/io/ply.hpp"
#include "io/base/formats.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"

namespace ced::io::ply_detail {

using namespace ced::io::detail;  // scalar_io.hpp

// ---------------------------------------------------------------- utilities

// Header limits. Duplicate names are checked through sets and vertex
// properties become cloud fields through the cloud's name index, so time is
// linear in the header; the bounds only keep a header from asking for absurd
// numbers of elements or fields.
constexpr std::size_t max_elements = 65536;
constexpr std::size_t max_properties = max_values_per_point;  // per element

// ------------------------------------------------------------------- header

struct property_desc {
  std::string name;
  scalar_type type = scalar_type::float32;
  bool is_list = false;
  scalar_type count_type = scalar_type::uint8;
};

struct element_desc {
  std::string name;
  std::uint64_t count = 0;
  std::vector<property_desc> props;
  std::unordered_set<std::string> prop_names;  // for the duplicate check
};

struct ply_header {
  ply_format format = ply_format::ascii;
  std::vector<element_desc> elements;
  std::unordered_set<std::string> element_names;  // for the duplicate check
  std::size_t body_offset = 0;
};

/// One line of the header: its text, words and number (for messages).
struct header_line {
  std::string_view text;
  std::vector<std::string_view> words;
  int number = 0;
  std::string where() const { return "header line " + std::to_string(number) + ": "; }
};

// ------------------------------------------------------------- binary body

using columns = std::vector<std::vector<double>>;

/// The size of a record of element e: exact when `fixed` (no list), else
/// the least one (empty lists).
struct record_size {
  std::size_t min = 0;
  bool fixed = true;
};

/// The binary data after a position, as read_record() reads it: the whole
/// file in memory.
struct memory_cursor {
  const unsigned char* p;
  const unsigned char* end;
  std::uint64_t left() const noexcept { return static_cast<std::uint64_t>(end - p); }
  const unsigned char* take(std::size_t n) noexcept { return (p += n) - n; }
  void skip(std::uint64_t n) noexcept { p += n; }
};

/// The same, read from a file in pieces.
struct file_cursor {
  sequential_reader& in;
  std::uint64_t left() const noexcept { return in.left(); }
  const unsigned char* take(std::size_t n) {
    in.fill(n);
    const auto* p = reinterpret_cast<const unsigned char*>(in.data());
    in.skip(n);  // the bytes stay in memory until the next fill()
    return p;
  }
  void skip(std::uint64_t n) noexcept { in.skip(n); }
};

/// A vertex property to write: a coordinate or a field.
struct out_column {
  scalar_type type;
  const column* values;  // nullptr for positions
  int axis;
};

double read_value(const unsigned char* p, scalar_type t, bool swap) noexcept;

std::string plural(const std::string& element);

/// Fails: the file ends after `read` of the `count` records of element e.
[[noreturn]] void fail_truncated(const std::string& file, std::uint64_t read, std::uint64_t count,
                                 const element_desc& e);

std::optional<scalar_type> parse_type(std::string_view s) noexcept;

/// "format ascii|binary_little_endian|binary_big_endian 1.0".
void read_format_line(const header_line& l, const std::string& file, ply_header& h);

/// "element NAME COUNT": a new element, named once.
void read_element_line(const header_line& l, const std::string& file, ply_header& h);

/// "property TYPE NAME" or "property list COUNT_TYPE TYPE NAME": a property
/// of the last element, named once in it.
void read_property_line(const header_line& l, const std::string& file, ply_header& h);

/// Parses the header (from the whole file, or from its first bytes: see
/// header_source).
ply_header parse_header(const header_source& src, const std::string& file);

/// The vertex element of `h` and the indices of its x, y and z properties.
const element_desc& find_vertex(const ply_header& h, const std::string& file, std::size_t axis[3]);

bool swapped(ply_format f) noexcept;

record_size record_size_of(const element_desc& e) noexcept;

/// Fails when the `remaining` bytes cannot hold the e.count records of
/// element e (r = record_size_of(e), r.min > 0): an implausible count, or a
/// truncated file when the records have a fixed size.
void check_count(const element_desc& e, const record_size& r, std::uint64_t remaining, const std::string& file);

/// Reads (cols != nullptr) or skips element `e` starting at data[pos]; returns
/// the offset just after it.
std::size_t read_binary_element(std::string_view data, std::size_t pos, const element_desc& e, bool swap, columns* cols,
                                const std::string& file);

/// Where value `tok` of record i, property `prop`, is: "vertex 12, property 'red': 'abc' ".
std::string ascii_where(const element_desc& e, std::size_t i, const property_desc& prop, std::string_view tok);

/// Fails: value `tok` of record i, property `prop`, is not one (status s).
[[noreturn]] void fail_ascii_value(const std::string& file, const element_desc& e, std::size_t i,
                                   const property_desc& prop, std::string_view tok, parse_status s);

/// Records [first, first + count) of element e (no list properties) from the
/// lines at [p, end), one a line, blank lines skipped, into `cols`. False
/// when a line holds another number of values than the element has
/// properties (the records are then not one a line). `stop`: the end of the
/// last value read.
bool read_ascii_lines(const char* p, const char* const end, std::size_t first, std::size_t count, const element_desc& e,
                      columns& cols, const std::string& file, const char*& stop);

/// read_ascii_element() for an element of no list properties whose records
/// lie one a line, in blocks of whole lines on the threads; false (nothing
/// decided) when the body is small, there is one thread, or the records are
/// not one a line or fewer than declared (the word-by-word reader then reads
/// them and names any problem). `end_pos` receives where the element ends.
bool read_ascii_blocks(std::string_view data, std::size_t pos, const element_desc& e, columns& cols,
                       const std::string& file, std::size_t& end_pos);

std::size_t read_ascii_element(std::string_view data, std::size_t pos, const element_desc& e, columns* cols,
                               const std::string& file);

/// The layout of vertex records of fixed size: x, y, z and the selected
/// scalar properties, in order.
point_layout vertex_layout(const element_desc& v, const std::size_t axis[3], bool swap,
                           const field_selection& selection);

/// The n fixed-size vertex records of `src` as a cloud (the origin of their
/// finite box), in parallel chunks.
point_cloud read_vertices(const record_source& src, std::uint64_t n, const point_layout& layout);

point_cloud parse_ply(std::string_view data, const std::string& file, const field_selection& selection);

/// Skips element e at `pos` of `file` (checking it as parse_ply() does);
/// returns the offset after it.
std::uint64_t skip_element(input_file& file, std::uint64_t pos, const element_desc& e, bool swap);

/// read_ply() of a file: binary vertices of a fixed size are read in
/// parallel chunks straight from the file, the other elements only checked;
/// anything else is read whole.
point_cloud read_ply_path(const std::string& path, const field_selection& selection);

const char* ply_type_name(scalar_type t) noexcept;

scalar_type written_type(scalar_type t) noexcept;

/// Throws std::invalid_argument when a field cannot be written as a vertex
/// property, io_error when there are more than the reader accepts.
void check_writable(const point_cloud& cloud);

std::string make_header(const point_cloud& cloud, std::uint64_t n, ply_format fmt, scalar_type pos_type);

/// The vertices, in chunks of points.
void write_vertices(std::ostream& out, const point_cloud& cloud, ply_format fmt, const std::vector<out_column>& cols);

/// Positions are written as double when the cloud has an origin.
scalar_type position_type(const point_cloud& cloud);

/// The header of a cloud with `cloud`'s fields and origin, and n points.
void write_header(std::ostream& out, const point_cloud& cloud, std::uint64_t n, ply_format fmt);

/// The vertices of `cloud`, after write_header().
void write_body(std::ostream& out, const point_cloud& cloud, ply_format fmt);

void write_ply_unchecked(std::ostream& out, const point_cloud& cloud, ply_format fmt);

/// Reads record i of the n records of element e (which has lists) from `in`:
/// store(j, value) for each scalar property j, lists skipped. Fails when
/// the data ends.
template <class Cursor, class Store>
void read_record(Cursor& in, const element_desc& e, bool swap, std::size_t i, std::size_t n, const std::string& file,
                 Store&& store) {
  for (std::size_t j = 0; j < e.props.size(); ++j) {
    const property_desc& prop = e.props[j];
    if (prop.is_list) {
      const std::size_t cs = size_of(prop.count_type);
      if (in.left() < cs) fail_truncated(file, i, n, e);
      const double count = read_value(in.take(cs), prop.count_type, swap);
      if (count < 0)
        throw io_error(file, "element '" + e.name + "' " + std::to_string(i) + ", property '" + prop.name +
                                 "': negative list length " + std::to_string(static_cast<long long>(count)));
      const std::size_t item = size_of(prop.type);
      if (count > static_cast<double>(static_cast<std::size_t>(in.left()) / item)) fail_truncated(file, i, n, e);
      in.skip(static_cast<std::size_t>(count) * item);
    } else {
      const std::size_t sz = size_of(prop.type);
      if (in.left() < sz) fail_truncated(file, i, n, e);
      store(j, read_value(in.take(sz), prop.type, swap));
    }
  }
}

}  // namespace ced::io::ply_detail

namespace ced::io::detail {
/// read_ply() decoding only the selected fields (read_cloud()).
point_cloud read_ply_file(const std::string& path, const field_selection& fields);
/// PLY binary little endian in pieces (cloud_writer).
std::unique_ptr<piece_writer> ply_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t n);
}  // namespace ced::io::detail
