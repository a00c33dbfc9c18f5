// SPDX-License-Identifier: MIT
// PCD read whole: ascii, binary and binary_compressed bodies into typed columns.
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

uncompressed_body decompress_body(std::string_view data, const pcd_header& h, const std::string& file) {
  const std::size_t remaining = data.size() - h.body_offset;
  const auto n = static_cast<std::size_t>(h.points);
  if (remaining < 8) {
    if (n == 0) return {};
    throw io_error(
        file, "truncated: the binary_compressed data has no size header (" + std::to_string(remaining) + " bytes)");
  }
  const auto* body = reinterpret_cast<const unsigned char*>(data.data()) + h.body_offset;
  const std::uint32_t compressed = load_le<std::uint32_t>(body);
  const std::uint32_t uncompressed = load_le<std::uint32_t>(body + 4);
  if (compressed > remaining - 8)
    throw io_error(file, "truncated: the binary_compressed data declares " + std::to_string(compressed) +
                             " compressed bytes, but only " + std::to_string(remaining - 8) + " follow");
  std::size_t size_real = 0, size_all = 0;
  for (const auto& f : h.fields) {
    size_all += f.size * f.count;
    if (!f.padding) size_real += f.size * f.count;
  }
  // PCL leaves padding fields out of the compressed layout; accept them too.
  bool with_padding = false;
  if (h.points <= std::numeric_limits<std::uint32_t>::max() / size_real && uncompressed == n * size_real) {
    with_padding = false;
  } else if (size_all != size_real && h.points <= std::numeric_limits<std::uint32_t>::max() / size_all &&
             uncompressed == n * size_all) {
    with_padding = true;
  } else {
    throw io_error(file, "the uncompressed size in the binary_compressed header (" + std::to_string(uncompressed) +
                             " bytes) does not match POINTS × point size (" + std::to_string(h.points) + " × " +
                             std::to_string(size_real) + " bytes)");
  }
  // LZF expands at most 88-fold (a 3-byte back-reference copies 264 bytes):
  // refuse more before allocating.
  if (static_cast<std::uint64_t>(uncompressed) > static_cast<std::uint64_t>(compressed) * 100 + 1024)
    throw io_error(file, "implausible binary_compressed sizes: " + std::to_string(compressed) +
                             " compressed bytes cannot expand to " + std::to_string(uncompressed) + " bytes");
  uncompressed_body out{big_bytes(uncompressed), with_padding};
  lzf_decompress_into(std::string_view(reinterpret_cast<const char*>(body + 8), compressed), out.bytes.data(),
                      uncompressed, file);
  return out;
}

/// The ascii points [first, first + count) from the lines at [p, end) (the
/// first of them numbered line_no + 1), blank lines skipped, into `cols`.
/// Throws the truncation error when the lines end first.
void parse_ascii_points(const char* p, const char* const end, std::size_t first, std::size_t count, std::size_t n,
                        std::size_t line_no, const pcd_header& h, const std::vector<std::size_t>& col_of, columns& cols,
                        const std::string& file) {
  std::size_t values_all = 0, values_real = 0;
  for (const auto& f : h.fields) {
    values_all += f.count;
    if (!f.padding) values_real += f.count;
  }
  std::vector<std::string_view> tok;
  tok.reserve(values_all);
  for (std::size_t i = first; i < first + count; ++i) {
    // The next non-blank line, split into tokens.
    for (;;) {
      if (p >= end)
        throw io_error(file,
                       "truncated: the file ends after " + std::to_string(i) + " of " + std::to_string(n) + " points");
      ++line_no;
      tok.clear();
      const auto* nl = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p)));
      const char* line_end = nl ? nl : end;
      word_reader<> words(std::string_view(p, static_cast<std::size_t>(line_end - p)));
      for (std::string_view w; words.next(w);) tok.push_back(w);
      p = nl ? nl + 1 : end;
      if (!tok.empty()) break;
    }
    const bool with_padding = tok.size() == values_all;
    if (!with_padding && tok.size() != values_real)
      throw io_error(file, "line " + std::to_string(line_no) + ": expected " + std::to_string(values_real) +
                               " values, found " + std::to_string(tok.size()));
    std::size_t t = 0;
    for (std::size_t j = 0; j < h.fields.size(); ++j) {
      const pcd_field& f = h.fields[j];
      if (f.padding) {
        if (with_padding) t += f.count;
        continue;
      }
      for (std::size_t c = 0; c < f.count; ++c, ++t) {
        double v = 0;
        const parse_status s =
            f.packed_rgb ? parse_packed_rgb(tok[t], f.type, v) : parse_ascii_value(tok[t], f.stype, v);
        if (s != parse_status::ok) {
          const std::string what = "line " + std::to_string(line_no) + ", field '" +
                                   (f.count > 1 ? f.name + "_" + std::to_string(c) : f.name) + "': '" +
                                   printable(tok[t]) + "' ";
          fail_value(file, what, s, f.stype);
        }
        cols[col_of[j] + c][i] = v;
      }
    }
  }
}

void read_ascii(std::string_view data, const pcd_header& h, const std::vector<std::size_t>& col_of, columns& cols,
                const std::string& file) {
  std::size_t values_real = 0;
  for (const auto& f : h.fields)
    if (!f.padding) values_real += f.count;
  // A point takes at least 2 bytes per value (a digit and a separator).
  const std::size_t remaining = data.size() - h.body_offset;
  if (h.points > (remaining + 1) / (2 * values_real))
    throw io_error(file, "truncated: POINTS declares " + std::to_string(h.points) + " points of " +
                             std::to_string(values_real) + " values, but only " + std::to_string(remaining) +
                             " bytes of ascii data follow");
  const auto n = static_cast<std::size_t>(h.points);
  for (auto& c : cols) c.resize(n);
  const char* const body = data.data() + h.body_offset;
  const char* const end = data.data() + data.size();
  const std::size_t blocks = ascii_blocks(remaining);
  if (blocks <= 1) return parse_ascii_points(body, end, 0, n, n, h.body_line - 1, h, col_of, cols, file);
  // Blocks of whole lines: counted first (the points and lines before each),
  // then parsed on the threads straight into the columns. Each keeps its
  // first error; the earliest is the one one thread would have met first
  // (a truncated file only shows at its end, after every block).
  const std::vector<const char*> cut = cut_lines(body, end, blocks);
  std::vector<std::pair<std::size_t, std::size_t>> before(blocks + 1, {0, h.body_line - 1});  // points, lines
  ced::detail::parallel_for(blocks, 0, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t k = b; k < e; ++k) before[k + 1] = count_lines(cut[k], cut[k + 1]);
  });
  for (std::size_t k = 1; k <= blocks; ++k) {
    before[k].first += before[k - 1].first;
    before[k].second += before[k - 1].second;
  }
  for_each_block(blocks, [&](std::size_t k) {
    const std::size_t first = std::min(before[k].first, n), last = std::min(before[k + 1].first, n);
    parse_ascii_points(cut[k], cut[k + 1], first, last - first, n, before[k].second, h, col_of, cols, file);
  });
  if (before[blocks].first < n)
    throw io_error(file, "truncated: the file ends after " + std::to_string(before[blocks].first) + " of " +
                             std::to_string(n) + " points");
}

/// The indices of the x, y and z fields (each of COUNT 1) in h.fields.
std::array<std::size_t, 3> find_axes(const pcd_header& h, const std::string& file) {
  std::array<std::size_t, 3> axis{};
  for (int k = 0; k < 3; ++k) {
    const std::string name(1, static_cast<char>('x' + k));
    const auto it = std::find_if(h.fields.begin(), h.fields.end(), [&](const pcd_field& f) { return f.name == name; });
    if (it == h.fields.end()) throw io_error(file, "the PCD file has no '" + name + "' field");
    if (it->count != 1)
      throw io_error(file, "field '" + name + "' has COUNT " + std::to_string(it->count) + " (expected 1)");
    axis[static_cast<std::size_t>(k)] = static_cast<std::size_t>(it - h.fields.begin());
  }
  return axis;
}

/// Marks the packed rgb fields and gives each value of each non-padding field
/// a column: col_of[j] is the first column of field j. `ncols` receives their
/// number. Fails when two fields would get the same name in the cloud.
std::vector<std::size_t> assign_columns(pcd_header& h, const std::string& file, std::size_t& ncols) {
  std::vector<std::size_t> col_of(h.fields.size(), 0);
  ncols = 0;
  std::set<std::string> out_names;
  for (std::size_t j = 0; j < h.fields.size(); ++j) {
    pcd_field& f = h.fields[j];
    if (f.padding) continue;
    f.packed_rgb = (f.name == "rgb" || f.name == "rgba") && f.count == 1 && f.size == 4;
    col_of[j] = ncols;
    ncols += f.count;
    std::vector<std::string> names;
    if (f.packed_rgb)
      names = {"red", "green", "blue"};
    else if (f.count == 1)
      names = {f.name};
    else
      for (std::size_t c = 0; c < f.count; ++c) names.push_back(f.name + "_" + std::to_string(c));
    for (const auto& name : names)
      if (!out_names.insert(name).second)
        throw io_error(file,
                       "two fields would be named '" + name + "' (field '" + f.name + "' clashes with another one)");
  }
  return col_of;
}

/// Drops, from every column, the points with a non-finite coordinate in
/// x, y or z; returns the number of points kept.
std::size_t drop_nonfinite(columns& cols, const std::vector<double>* const xyz[3], std::size_t declared) {
  std::size_t n = 0;
  std::vector<std::uint8_t> keep(declared);
  for (std::size_t i = 0; i < declared; ++i) {
    keep[i] = std::isfinite((*xyz[0])[i]) && std::isfinite((*xyz[1])[i]) && std::isfinite((*xyz[2])[i]);
    n += keep[i];
  }
  if (n != declared)
    for (auto& col : cols) {
      std::size_t o = 0;
      for (std::size_t i = 0; i < declared; ++i)
        if (keep[i]) col[o++] = col[i];
      col.resize(o);
      col.shrink_to_fit();
    }
  return n;
}

/// Adds red, green and blue uint8 fields unpacked from the packed rgb values
/// (0x00RRGGBB), then releases those.
void add_unpacked_rgb(point_cloud& cloud, std::vector<double>& packed) {
  const std::size_t n = cloud.size();
  std::vector<double> rgb[3];
  for (auto& c : rgb) c.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto bits = static_cast<std::uint32_t>(packed[i]);
    rgb[0][i] = (bits >> 16) & 0xff;
    rgb[1][i] = (bits >> 8) & 0xff;
    rgb[2][i] = bits & 0xff;
  }
  cloud.add_field("red", scalar_type::uint8, std::move(rgb[0]));
  cloud.add_field("green", scalar_type::uint8, std::move(rgb[1]));
  cloud.add_field("blue", scalar_type::uint8, std::move(rgb[2]));
  std::vector<double>().swap(packed);
}

/// Adds the fields other than x, y, z and padding: a field of COUNT c > 1 as
/// fields name_0 ... name_{c-1}.
void add_fields(point_cloud& cloud, const pcd_header& h, const std::array<std::size_t, 3>& axis,
                const std::vector<std::size_t>& col_of, columns& cols) {
  for (std::size_t j = 0; j < h.fields.size(); ++j) {
    const pcd_field& f = h.fields[j];
    if (f.padding || j == axis[0] || j == axis[1] || j == axis[2]) continue;
    if (f.packed_rgb) {
      add_unpacked_rgb(cloud, cols[col_of[j]]);
    } else if (f.count == 1) {
      cloud.add_field(f.name, f.stype, std::move(cols[col_of[j]]));
    } else {
      for (std::size_t c = 0; c < f.count; ++c)
        cloud.add_field(f.name + "_" + std::to_string(c), f.stype, std::move(cols[col_of[j] + c]));
    }
  }
}

/// What read_pcd() tells of the file, but the points it removes.
pcd_read_info info_of(const pcd_header& h) {
  pcd_read_info info;
  info.width = static_cast<std::size_t>(h.width);
  info.height = static_cast<std::size_t>(h.height);
  info.points_declared = static_cast<std::size_t>(h.points);
  info.organized = h.height > 1;
  info.data_format = h.data_name;
  return info;
}

/// Adds to `layout` the values of field f at `offset` (`stride` as in
/// value_spec): an axis when it is axis k (0 to 2), else the selected values.
void add_values(point_layout& layout, const pcd_field& f, int k, std::size_t offset, std::size_t stride,
                const field_selection& selection) {
  const bool swap = !host_little_endian();  // PCD binary data is little-endian
  const auto add = [&](std::string name, std::size_t at, scalar_type t, int shift) {
    if (selection.wants(name)) layout.columns.push_back({std::move(name), at, t, swap, shift, stride});
  };
  if (k >= 0) {
    layout.xyz[static_cast<std::size_t>(k)] = {f.name, offset, f.stype, swap, -1, stride};
  } else if (f.packed_rgb) {
    add("red", offset, scalar_type::uint32, 16);
    add("green", offset, scalar_type::uint32, 8);
    add("blue", offset, scalar_type::uint32, 0);
  } else if (f.count == 1) {
    add(f.name, offset, f.stype, -1);
  } else {
    for (std::size_t c = 0; c < f.count; ++c) add(f.name + "_" + std::to_string(c), offset + c * f.size, f.stype, -1);
  }
}

/// The axis (0 to 2) that field j is, or -1.
int axis_of(const std::array<std::size_t, 3>& axis, std::size_t j) noexcept {
  for (int k = 0; k < 3; ++k)
    if (axis[static_cast<std::size_t>(k)] == j) return k;
  return -1;
}

/// The layout of binary records: x, y, z and the selected values, in the
/// reader's order (a packed rgb as red, green, blue; COUNT c as name_0 ...).
point_layout record_layout(const pcd_header& h, const std::array<std::size_t, 3>& axis,
                           const field_selection& selection) {
  point_layout layout;
  std::size_t offset = 0;
  for (std::size_t j = 0; j < h.fields.size(); ++j) {
    const pcd_field& f = h.fields[j];
    if (!f.padding) add_values(layout, f, axis_of(axis, j), offset, 0, selection);
    offset += f.size * f.count;
  }
  return layout;
}

/// The same for an uncompressed binary_compressed body: each field's values
/// one after the other, then the next field's.
point_layout field_major_layout(const pcd_header& h, const std::array<std::size_t, 3>& axis,
                                const field_selection& selection, const uncompressed_body& body) {
  point_layout layout;
  layout.base = reinterpret_cast<const unsigned char*>(body.bytes.data());
  std::size_t offset = 0;
  for (std::size_t j = 0; j < h.fields.size(); ++j) {
    const pcd_field& f = h.fields[j];
    if (f.padding && !body.with_padding) continue;
    if (!f.padding) add_values(layout, f, axis_of(axis, j), offset, f.size * f.count, selection);
    offset += static_cast<std::size_t>(h.points) * f.size * f.count;
  }
  return layout;
}

/// The n points of `src` (`layout`), in parallel chunks; the origin of the
/// finite points; without the non-finite ones unless `keep_nonfinite`.
point_cloud read_points(const record_source& src, std::uint64_t n, const point_layout& layout, bool keep_nonfinite) {
  const points_scan scan = scan_points(src, n, layout);
  return decode_points(src, n, layout, choose_origin(scan.box.lo, scan.box.hi), keep_nonfinite ? nullptr : &scan);
}

/// The ascii body as a cloud: without the non-finite points unless `keep_nonfinite`.
point_cloud read_ascii_cloud(std::string_view data, const pcd_header& h, const std::array<std::size_t, 3>& axis,
                             bool keep_nonfinite, const std::string& file) {
  std::size_t ncols = 0;
  pcd_header marked = h;
  const std::vector<std::size_t> col_of = assign_columns(marked, file, ncols);
  columns cols(ncols);
  read_ascii(data, h, col_of, cols, file);
  const std::vector<double>* xyz[3] = {&cols[col_of[axis[0]]], &cols[col_of[axis[1]]], &cols[col_of[axis[2]]]};
  const auto declared = static_cast<std::size_t>(h.points);
  const std::size_t n = keep_nonfinite ? declared : drop_nonfinite(cols, xyz, declared);
  point_cloud cloud = cloud_at(xyz[0]->data(), xyz[1]->data(), xyz[2]->data(), n);
  add_fields(cloud, h, axis, col_of, cols);
  return cloud;
}

/// The body of the file `data` (header h, checked) as a cloud with the selected fields.
point_cloud read_body(std::string_view data, const pcd_header& h, const std::array<std::size_t, 3>& axis,
                      bool keep_nonfinite, const field_selection& selection, const std::string& file) {
  const auto* d = reinterpret_cast<const unsigned char*>(data.data());
  if (h.format == pcd_format::binary) {
    check_binary_size(h, data.size() - h.body_offset, file);
    return read_points(record_source(d + h.body_offset, point_size_of(h)), h.points, record_layout(h, axis, selection),
                       keep_nonfinite);
  }
  if (h.format == pcd_format::binary_compressed) {
    const uncompressed_body body = decompress_body(data, h, file);
    const std::size_t stride = h.points == 0 ? 1 : body.bytes.size() / static_cast<std::size_t>(h.points);
    return read_points(record_source(reinterpret_cast<const unsigned char*>(body.bytes.data()), stride), h.points,
                       field_major_layout(h, axis, selection, body), keep_nonfinite);
  }
  point_cloud cloud = read_ascii_cloud(data, h, axis, keep_nonfinite, file);
  cloud.keep_fields(selection);
  return cloud;
}

/// The header of the file `data`, checked: its axes, and the fields marked
/// (assign_columns()).
pcd_header checked_header(const header_source& src, const std::string& file, std::array<std::size_t, 3>& axis) {
  pcd_header h = parse_header(src, file);
  axis = find_axes(h, file);
  std::size_t ncols = 0;
  assign_columns(h, file, ncols);
  return h;
}

point_cloud parse_pcd(std::string_view data, const std::string& file, pcd_read_info* info, bool keep_nonfinite,
                      const field_selection& selection) {
  std::array<std::size_t, 3> axis{};
  const pcd_header h = checked_header(header_source{data}, file, axis);
  point_cloud cloud = read_body(data, h, axis, keep_nonfinite, selection, file);
  if (info) {
    *info = info_of(h);
    info->nonfinite_removed = static_cast<std::size_t>(h.points) - cloud.size();
  }
  return cloud;
}

/// read_pcd() of a file: binary records are read in parallel chunks straight
/// from the file; the other encodings are read whole.
point_cloud read_pcd_path(const std::string& path, pcd_read_info* info, bool keep_nonfinite,
                          const field_selection& selection) {
  if (!chunked_file(path)) return parse_pcd(read_whole_file(path), path, info, keep_nonfinite, selection);
  input_file file(path);
  std::array<std::size_t, 3> axis{};
  const pcd_header h = file.parse_header([&](const header_source& src) { return checked_header(src, path, axis); });
  if (h.format != pcd_format::binary) {
    const big_bytes data = read_all(file);
    return parse_pcd(std::string_view(data.data(), data.size()), path, info, keep_nonfinite, selection);
  }
  check_binary_size(h, file.size() - h.body_offset, path);
  point_cloud cloud = read_points(record_source(file, h.body_offset, point_size_of(h)), h.points,
                                  record_layout(h, axis, selection), keep_nonfinite);
  if (info) {
    *info = info_of(h);
    info->nonfinite_removed = static_cast<std::size_t>(h.points) - cloud.size();
  }
  return cloud;
}

}  // namespace pcd_detail

// ------------------------------------------------------------------- public

point_cloud read_pcd_buffer(std::string_view bytes, const std::string& name_for_errors, pcd_read_info* info,
                            bool keep_nonfinite) {
  return parse_pcd(bytes, name_for_errors, info, keep_nonfinite, {});
}

point_cloud read_pcd(const std::string& path, pcd_read_info* info, bool keep_nonfinite) {
  return read_pcd_path(path, info, keep_nonfinite, {});
}

}  // namespace ced::io
