// SPDX-License-Identifier: MIT
// CSV written whole and in pieces.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <set>
#include <system_error>
#include <type_traits>

#include "ced/io/csv.hpp"
#include "io/base/formats.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"
#include "io/csv/layout.hpp"

namespace ced::io {

using namespace detail;
using namespace csv_detail;

namespace csv_detail {

// ------------------------------------------------------------------ writer

/// Throws std::invalid_argument when a field cannot be a CSV column,
/// io_error when there are more columns than the reader accepts.
void check_writable(const point_cloud& cloud) {
  check_values_per_point(3 + cloud.fields().size(), "CSV");
  const std::size_t n = cloud.size();
  for (const auto& f : cloud.fields()) {
    if (f.name.empty() || std::any_of(f.name.begin(), f.name.end(), [](char c) {
          return is_space(c) || c == ',' || c == ';' || c == '"' || c == '#' || c < 32 || c == 127;
        }))
      throw std::invalid_argument("field name '" + f.name +
                                  "' cannot be written to CSV (empty, or has whitespace, a delimiter, '\"' or '#')");
    const std::string l = to_lower(f.name);
    if (l == "x" || l == "y" || l == "z" || f.name.substr(0, 2) == "//")
      throw std::invalid_argument("field '" + f.name + "' clashes with the CSV coordinate columns");
    check_field_size(f, n);
  }
}

void write_header(std::ostream& out, const point_cloud& cloud) {
  std::string header = "x,y,z";
  for (const auto& f : cloud.fields()) header += "," + f.name;
  header += "\n";
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
}

/// The rows of `cloud`, after the header.
void write_body(std::ostream& out, const point_cloud& cloud) {
  const std::size_t n = cloud.size();
  // Positions as float (their own shortest text), or as double offset by a
  // non-zero origin; fields as their type.
  const auto& origin = cloud.origin();
  const bool georef = origin[0] != 0 || origin[1] != 0 || origin[2] != 0;
  std::vector<scalar_type> types(3, georef ? scalar_type::float64 : scalar_type::float32);
  for (const auto& f : cloud.fields()) types.push_back(f.type());
  const float* xyz = cloud.positions().data();
  point_format pf;
  pf.text = true;
  pf.separator = ',';
  write_points(out, n, types, pf, [&](std::size_t c, std::size_t i0, std::size_t m, double* v) {
    if (c >= 3) return copy_values(cloud.fields()[c - 3].values, i0, m, v);
    for (std::size_t i = 0; i < m; ++i) {
      const double p = xyz[3 * (i0 + i) + c];
      v[i] = georef ? origin[c] + p : p;  // without an origin, -0 stays -0
    }
  });
}

void write_csv_unchecked(std::ostream& out, const point_cloud& cloud) {
  check_writable(cloud);
  write_header(out, cloud);
  write_body(out, cloud);
}

}  // namespace csv_detail

void write_csv(std::ostream& out, const point_cloud& cloud) {
  detail::write_to_stream(out, "CSV", [&](std::ostream& o) { write_csv_unchecked(o, cloud); });
}

void write_csv(const std::string& path, const point_cloud& cloud) {
  detail::write_to_file(path, [&](std::ostream& o) { write_csv_unchecked(o, cloud); });
}

namespace detail {
namespace {
class csv_piece_writer final : public piece_writer {
 public:
  csv_piece_writer(std::ostream& out, const point_cloud& layout) {
    check_writable(layout);
    write_header(out, layout);
  }
  void write(std::ostream& out, const point_cloud& chunk) override {
    check_writable(chunk);
    write_body(out, chunk);
  }
};
}  // namespace

std::unique_ptr<piece_writer> csv_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t /*n*/) {
  return std::make_unique<csv_piece_writer>(out, layout);
}
}  // namespace detail

}  // namespace ced::io
