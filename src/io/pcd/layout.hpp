// SPDX-License-Identifier: MIT
// What the parts of the PCD reader and writer share (header.cpp, read.cpp, write.cpp,
// stream.cpp): the header as parsed, its fields, the columns. Private to src/io/pcd/.
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
#include <set>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <unordered_set>

#include "ced/io/pcd.hpp"
#include "io/base/formats.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"

namespace ced::io::pcd_detail {

using namespace ced::io::detail;  // scalar_io.hpp

// ------------------------------------------------------------------- header

struct pcd_field {
  std::string name;
  char type = 'F';
  std::size_t size = 4;
  std::size_t count = 1;
  scalar_type stype = scalar_type::float32;
  bool padding = false;     ///< named "_": skipped
  bool packed_rgb = false;  ///< rgb/rgba, unpacked into red/green/blue
};

struct pcd_header {
  std::vector<pcd_field> fields;
  std::uint64_t width = 0, height = 1, points = 0;
  pcd_format format = pcd_format::ascii;
  std::string data_name;
  std::size_t body_offset = 0;
  std::size_t body_line = 0;  ///< 1-based line number of the line after DATA
};

/// The header's lines as given, before they are checked together.
struct header_lines {
  std::vector<std::string_view> names, sizes, types, counts;
  bool have_fields = false, have_size = false, have_type = false, have_count = false;
  bool have_width = false, have_height = false, have_points = false;
};

// ------------------------------------------------------------------ reader

using columns = std::vector<std::vector<double>>;

/// The body of a binary_compressed file, uncompressed: the values field by
/// field, padding fields included when `with_padding`.
struct uncompressed_body {
  big_bytes bytes;
  bool with_padding = false;
};

// ------------------------------------------------------------------ writer

struct out_column {
  std::string name;
  char type = 'F';
  std::size_t size = 4;
  scalar_type enc = scalar_type::float32;  ///< how values are encoded (rgb: uint32 bits)
  const column* values = nullptr;          ///< field values, or nullptr
  int axis = -1;                           ///< 0/1/2 for positions
  const column* rgb[3] = {nullptr, nullptr, nullptr};
};

bool parse_u64(std::string_view s, std::uint64_t& v) noexcept;

/// The TYPE of values of t: F (floating point), I (signed) or U (unsigned).
char type_char(scalar_type t) noexcept;

/// The type of the values of PCD TYPE `type` and SIZE `size`, if any.
std::optional<scalar_type> pcd_type(char type, std::uint64_t size) noexcept;

bool has_data_line(const header_source& src);

/// Reads the header line `w` (its words; `line` as given, number `line_no`)
/// into `l` and `h`. True when it is the DATA line, which ends the header.
bool read_header_line(const std::vector<std::string_view>& w, std::string_view line, std::size_t line_no,
                      const header_source& src, const std::string& file, header_lines& l, pcd_header& h);

/// Reads the header lines, up to DATA, into `l` and `h` (and the body's offset and first line).
void read_header_lines(const header_source& src, const std::string& file, header_lines& l, pcd_header& h);

/// The fields of FIELDS, with their SIZE, TYPE and COUNT (each list, when
/// given, as long as FIELDS).
void make_fields(const header_lines& l, const std::string& file, pcd_header& h);

/// WIDTH, HEIGHT and POINTS: either may stand for the other, and when both
/// are given they must agree.
void resolve_point_count(const header_lines& l, const std::string& file, pcd_header& h);

/// Parses the header (from the whole file, or from its first bytes: see
/// header_source).
pcd_header parse_header(const header_source& src, const std::string& file);

/// A packed rgb value in ascii: a plain integer is the packed 32 bits (PCL
/// writes it so); for TYPE F anything else is a float whose bits are taken.
parse_status parse_packed_rgb(std::string_view tok, char type, double& out) noexcept;

/// The size of a point's binary record (padding included).
std::size_t point_size_of(const pcd_header& h) noexcept;

/// Fails when the `remaining` bytes of a binary body cannot hold POINTS points.
void check_binary_size(const pcd_header& h, std::uint64_t remaining, const std::string& file);

uncompressed_body decompress_body(std::string_view data, const pcd_header& h, const std::string& file);

/// The ascii points [first, first + count) from the lines at [p, end) (the
/// first of them numbered line_no + 1), blank lines skipped, into `cols`.
/// Throws the truncation error when the lines end first.
void parse_ascii_points(const char* p, const char* const end, std::size_t first, std::size_t count, std::size_t n,
                        std::size_t line_no, const pcd_header& h, const std::vector<std::size_t>& col_of, columns& cols,
                        const std::string& file);

void read_ascii(std::string_view data, const pcd_header& h, const std::vector<std::size_t>& col_of, columns& cols,
                const std::string& file);

/// The indices of the x, y and z fields (each of COUNT 1) in h.fields.
std::array<std::size_t, 3> find_axes(const pcd_header& h, const std::string& file);

/// Marks the packed rgb fields and gives each value of each non-padding field
/// a column: col_of[j] is the first column of field j. `ncols` receives their
/// number. Fails when two fields would get the same name in the cloud.
std::vector<std::size_t> assign_columns(pcd_header& h, const std::string& file, std::size_t& ncols);

/// Drops, from every column, the points with a non-finite coordinate in
/// x, y or z; returns the number of points kept.
std::size_t drop_nonfinite(columns& cols, const std::vector<double>* const xyz[3], std::size_t declared);

/// Adds red, green and blue uint8 fields unpacked from the packed rgb values
/// (0x00RRGGBB), then releases those.
void add_unpacked_rgb(point_cloud& cloud, std::vector<double>& packed);

/// Adds the fields other than x, y, z and padding: a field of COUNT c > 1 as
/// fields name_0 ... name_{c-1}.
void add_fields(point_cloud& cloud, const pcd_header& h, const std::array<std::size_t, 3>& axis,
                const std::vector<std::size_t>& col_of, columns& cols);

/// What read_pcd() tells of the file, but the points it removes.
pcd_read_info info_of(const pcd_header& h);

/// Adds to `layout` the values of field f at `offset` (`stride` as in
/// value_spec): an axis when it is axis k (0 to 2), else the selected values.
void add_values(point_layout& layout, const pcd_field& f, int k, std::size_t offset, std::size_t stride,
                const field_selection& selection);

/// The axis (0 to 2) that field j is, or -1.
int axis_of(const std::array<std::size_t, 3>& axis, std::size_t j) noexcept;

/// The layout of binary records: x, y, z and the selected values, in the
/// reader's order (a packed rgb as red, green, blue; COUNT c as name_0 ...).
point_layout record_layout(const pcd_header& h, const std::array<std::size_t, 3>& axis,
                           const field_selection& selection);

/// The same for an uncompressed binary_compressed body: each field's values
/// one after the other, then the next field's.
point_layout field_major_layout(const pcd_header& h, const std::array<std::size_t, 3>& axis,
                                const field_selection& selection, const uncompressed_body& body);

/// The n points of `src` (`layout`), in parallel chunks; the origin of the
/// finite points; without the non-finite ones unless `keep_nonfinite`.
point_cloud read_points(const record_source& src, std::uint64_t n, const point_layout& layout, bool keep_nonfinite);

/// The ascii body as a cloud: without the non-finite points unless `keep_nonfinite`.
point_cloud read_ascii_cloud(std::string_view data, const pcd_header& h, const std::array<std::size_t, 3>& axis,
                             bool keep_nonfinite, const std::string& file);

/// The body of the file `data` (header h, checked) as a cloud with the selected fields.
point_cloud read_body(std::string_view data, const pcd_header& h, const std::array<std::size_t, 3>& axis,
                      bool keep_nonfinite, const field_selection& selection, const std::string& file);

/// The header of the file `data`, checked: its axes, and the fields marked
/// (assign_columns()).
pcd_header checked_header(const header_source& src, const std::string& file, std::array<std::size_t, 3>& axis);

point_cloud parse_pcd(std::string_view data, const std::string& file, pcd_read_info* info, bool keep_nonfinite,
                      const field_selection& selection);

/// read_pcd() of a file: binary records are read in parallel chunks straight
/// from the file; the other encodings are read whole.
point_cloud read_pcd_path(const std::string& path, pcd_read_info* info, bool keep_nonfinite,
                          const field_selection& selection);

std::vector<out_column> plan_columns(const point_cloud& cloud, pcd_format fmt);

std::string make_header(const std::vector<out_column>& cols, std::size_t n, pcd_format fmt);

/// v[i] = value of column c for point i0 + i, i < m.
void column_values(const out_column& c, const point_cloud& cloud, std::size_t i0, std::size_t m, double* v);

/// The binary_compressed body: the sizes, then the LZF-compressed values,
/// field by field (each column of all points, then the next).
void write_compressed(std::ostream& out, const point_cloud& cloud, const std::vector<out_column>& cols,
                      std::size_t record);

/// The points of `cloud` as ascii or binary data, after the header.
void write_body(std::ostream& out, const point_cloud& cloud, const std::vector<out_column>& cols, pcd_format fmt);

void write_pcd_unchecked(std::ostream& out, const point_cloud& cloud, pcd_format fmt);

}  // namespace ced::io::pcd_detail

namespace ced::io::detail {
/// read_report::details of a PCD file ("PCD binary, organized 640x480").
std::string pcd_details(const pcd_read_info& info);
/// read_pcd() decoding only the selected fields (read_cloud()).
point_cloud read_pcd_file(const std::string& path, pcd_read_info* info, bool keep_nonfinite,
                          const field_selection& fields);
/// PCD binary in pieces (cloud_writer).
std::unique_ptr<piece_writer> pcd_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t n);
}  // namespace ced::io::detail
