// SPDX-License-Identifier: MIT
// PCD written whole and in pieces.
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
#include "io/pcd/layout.hpp"

namespace ced::io {

using namespace detail;
using namespace pcd_detail;

namespace pcd_detail {

std::vector<out_column> plan_columns(const point_cloud& cloud, pcd_format fmt) {
  const std::size_t n = cloud.size();
  const field* rgb[3] = {cloud.find_field("red"), cloud.find_field("green"), cloud.find_field("blue")};
  const bool pack = rgb[0] && rgb[1] && rgb[2] && rgb[0]->type() == scalar_type::uint8 &&
                    rgb[1]->type() == scalar_type::uint8 && rgb[2]->type() == scalar_type::uint8;
  for (const auto& f : cloud.fields()) {
    if (f.name.empty() || f.name == "_" ||
        std::any_of(f.name.begin(), f.name.end(), [](char c) { return is_space(c) || c < 32 || c == 127; }))
      throw std::invalid_argument("field name '" + f.name +
                                  "' cannot be written to PCD (empty, '_' or has whitespace)");
    if (f.name == "x" || f.name == "y" || f.name == "z")
      throw std::invalid_argument("field '" + f.name + "' clashes with the PCD coordinate field");
    if (pack && (f.name == "rgb" || f.name == "rgba"))
      throw std::invalid_argument("field '" + f.name +
                                  "' clashes with the packed rgb field written for red/green/blue");
    check_field_size(f, n);
  }
  const auto& o = cloud.origin();
  const bool georef = o[0] != 0 || o[1] != 0 || o[2] != 0;
  std::vector<out_column> cols;
  for (int k = 0; k < 3; ++k) {
    out_column c;
    c.name = std::string(1, static_cast<char>('x' + k));
    c.size = georef ? 8 : 4;
    c.enc = georef ? scalar_type::float64 : scalar_type::float32;
    c.axis = k;
    cols.push_back(c);
  }
  for (const auto& f : cloud.fields()) {
    if (pack && (&f == rgb[1] || &f == rgb[2])) continue;
    out_column c;
    if (pack && &f == rgb[0]) {
      c.name = "rgb";
      c.type = fmt == pcd_format::ascii ? 'U' : 'F';
      c.size = 4;
      c.enc = scalar_type::uint32;
      for (int k = 0; k < 3; ++k) c.rgb[k] = &rgb[k]->values;
    } else {
      c.name = f.name;
      c.type = type_char(f.type());
      c.size = size_of(f.type());
      c.enc = f.type();
      c.values = &f.values;
    }
    cols.push_back(c);
  }
  check_values_per_point(cols.size(), "PCD");
  return cols;
}

std::string make_header(const std::vector<out_column>& cols, std::size_t n, pcd_format fmt) {
  std::string h = "# .PCD v0.7 - Point Cloud Data file format (written by ced)\nVERSION 0.7\nFIELDS";
  for (const auto& c : cols) h += " " + c.name;
  h += "\nSIZE";
  for (const auto& c : cols) h += " " + std::to_string(c.size);
  h += "\nTYPE";
  for (const auto& c : cols) h += std::string(" ") + c.type;
  h += "\nCOUNT";
  for (std::size_t i = 0; i < cols.size(); ++i) h += " 1";
  h += "\nWIDTH " + std::to_string(n) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(n) + "\nDATA ";
  h += fmt == pcd_format::ascii ? "ascii" : fmt == pcd_format::binary ? "binary" : "binary_compressed";
  h += "\n";
  return h;
}

/// v[i] = value of column c for point i0 + i, i < m.
void column_values(const out_column& c, const point_cloud& cloud, std::size_t i0, std::size_t m, double* v) {
  if (c.values) {
    copy_values(*c.values, i0, m, v);
  } else if (c.axis >= 0) {
    const auto k = static_cast<std::size_t>(c.axis);
    const double o = cloud.origin()[k];
    const float* xyz = cloud.positions().data();
    if (o == 0)  // keeps -0
      for (std::size_t i = 0; i < m; ++i) v[i] = static_cast<double>(xyz[3 * (i0 + i) + k]);
    else
      for (std::size_t i = 0; i < m; ++i) v[i] = o + static_cast<double>(xyz[3 * (i0 + i) + k]);
  } else {
    // Packed only from uint8 fields (plan_columns()).
    const std::uint8_t* rgb[3] = {c.rgb[0]->data<std::uint8_t>() + i0, c.rgb[1]->data<std::uint8_t>() + i0,
                                  c.rgb[2]->data<std::uint8_t>() + i0};
    for (std::size_t i = 0; i < m; ++i)
      v[i] = static_cast<double>(std::uint32_t{rgb[0][i]} << 16 | std::uint32_t{rgb[1][i]} << 8 | rgb[2][i]);
  }
}

/// The binary_compressed body: the sizes, then the LZF-compressed values,
/// field by field (each column of all points, then the next).
void write_compressed(std::ostream& out, const point_cloud& cloud, const std::vector<out_column>& cols,
                      std::size_t record) {
  const std::size_t n = cloud.size();
  constexpr std::size_t chunk = 4096;
  std::vector<double> vals(chunk);
  ced::detail::raw_column_vector<unsigned char> block(n * record);  // field-major; every byte is written below
  unsigned char* const base = block.data();
  std::size_t offset = 0;
  for (const auto& c : cols) {
    for (std::size_t i0 = 0; i0 < n; i0 += chunk) {
      const std::size_t m = std::min(chunk, n - i0);
      column_values(c, cloud, i0, m, vals.data());
      const double* v = vals.data();
      encode_values(c.enc, !host_little_endian(), base + offset + i0 * c.size, c.size, m,
                    [v](std::size_t i) { return v[i]; });
    }
    offset += n * c.size;
  }
  ced::detail::raw_column_vector<unsigned char> packed;
  detail::lzf_compress_into(std::string_view(reinterpret_cast<const char*>(base), block.size()), packed,
                            detail::lzf_segment_bytes(block.size()), 0);
  if (packed.size() > std::numeric_limits<std::uint32_t>::max())
    throw io_error("the compressed cloud is too large for PCD binary_compressed");
  unsigned char sizes[8];
  store_le<std::uint32_t>(sizes, static_cast<std::uint32_t>(packed.size()));
  store_le<std::uint32_t>(sizes + 4, static_cast<std::uint32_t>(block.size()));
  out.write(reinterpret_cast<const char*>(sizes), 8);
  out.write(reinterpret_cast<const char*>(packed.data()), static_cast<std::streamsize>(packed.size()));
}

/// The points of `cloud` as ascii or binary data, after the header.
void write_body(std::ostream& out, const point_cloud& cloud, const std::vector<out_column>& cols, pcd_format fmt) {
  std::vector<scalar_type> types;
  for (const auto& c : cols) types.push_back(c.enc);
  point_format pf;
  pf.text = fmt == pcd_format::ascii;
  pf.swap = !host_little_endian();
  std::vector<const column*> direct;
  for (const auto& c : cols) direct.push_back(c.values);
  write_points(
      out, cloud.size(), types, pf,
      [&](std::size_t c, std::size_t i0, std::size_t m, double* v) { column_values(cols[c], cloud, i0, m, v); },
      direct);
}

void write_pcd_unchecked(std::ostream& out, const point_cloud& cloud, pcd_format fmt) {
  const std::vector<out_column> cols = plan_columns(cloud, fmt);
  const std::size_t n = cloud.size();
  std::size_t record = 0;
  for (const auto& c : cols) record += c.size;
  if (fmt == pcd_format::binary_compressed && n > std::numeric_limits<std::uint32_t>::max() / record)
    throw io_error("the cloud is too large for PCD binary_compressed (4 GiB or more of data)");
  const std::string header = make_header(cols, n, fmt);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  if (fmt == pcd_format::binary_compressed) return write_compressed(out, cloud, cols, record);
  write_body(out, cloud, cols, fmt);
}

}  // namespace pcd_detail

void write_pcd(std::ostream& out, const point_cloud& cloud, pcd_format fmt) {
  detail::write_to_stream(out, "PCD", [&](std::ostream& o) { write_pcd_unchecked(o, cloud, fmt); });
}

void write_pcd(const std::string& path, const point_cloud& cloud, pcd_format fmt) {
  detail::write_to_file(path, [&](std::ostream& o) { write_pcd_unchecked(o, cloud, fmt); });
}

namespace detail {
namespace {
class pcd_piece_writer final : public piece_writer {
 public:
  pcd_piece_writer(std::ostream& out, const point_cloud& layout, std::uint64_t n) {
    const std::string header = make_header(plan_columns(layout, pcd_format::binary), n, pcd_format::binary);
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
  }
  void write(std::ostream& out, const point_cloud& chunk) override {
    write_body(out, chunk, plan_columns(chunk, pcd_format::binary), pcd_format::binary);
  }
};
}  // namespace

std::unique_ptr<piece_writer> pcd_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t n) {
  return std::make_unique<pcd_piece_writer>(out, layout, n);
}
}  // namespace detail

}  // namespace ced::io
