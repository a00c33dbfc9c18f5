// SPDX-License-Identifier: MIT
// LAS and LAZ read whole: the columns a selection decodes, the records decoded in parallel chunks.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <initializer_list>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <sstream>
#include <type_traits>
#include <vector>

#include "ced/io/las.hpp"
#include "ced/io/stream.hpp"
#include "ced/version.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"
#include "io/las/layout.hpp"
#include "io/laz/types.hpp"

namespace ced::io {

using namespace las_detail;

namespace las_detail {

/// The scan of the n records of `src`, chunks in parallel.
record_scan scan_records(const record_source& src, std::uint64_t n) {
  std::vector<record_scan> scans(chunk_count(n, src.stride()));
  for_each_chunk(src, n, [&](std::size_t c, std::uint64_t, std::size_t m, const unsigned char* r) {
    scans[c].add(r, src.stride(), m);
  });
  record_scan all;
  for (const record_scan& s : scans) all.merge(s);
  return all;
}

/// The one-bit (and scanner channel) flags of bytes 14 and 15.
std::vector<flag_spec> flags_of(bool extended) {
  if (extended)
    return {{"synthetic", 15, 0, 1},          {"key_point", 15, 1, 1},
            {"withheld", 15, 2, 1},           {"overlap", 15, 3, 1},
            {"scanner_channel", 15, 4, 3},    {"scan_direction_flag", 15, 6, 1},
            {"edge_of_flight_line", 15, 7, 1}};
  return {{"synthetic", 15, 5, 1},
          {"key_point", 15, 6, 1},
          {"withheld", 15, 7, 1},
          {"scan_direction_flag", 14, 6, 1},
          {"edge_of_flight_line", 14, 7, 1}};
}

/// The flags of bytes 14 and 15: added only when some point sets them.
void plan_flags(column_planner& plan, bool extended) {
  for (const flag_spec& fl : flags_of(extended))
    if ((plan.flag_bits[fl.offset - 14] >> fl.shift) & fl.mask) plan.bits(fl.name, fl.offset, fl.shift, fl.mask);
}

/// The standard fields of the point format, then its flags.
void plan_standard_fields(column_planner& plan, const format_layout& layout) {
  plan.typed<std::uint16_t>("intensity", 12);
  if (layout.extended) {
    plan.bits("return_number", 14, 0, 0x0F);
    plan.bits("number_of_returns", 14, 4, 0x0F);
    plan.typed<std::uint8_t>("classification", 16);
    plan.typed<std::int16_t>("scan_angle", 18);
    plan.typed<std::uint8_t>("user_data", 17);
    plan.typed<std::uint16_t>("point_source_id", 20);
  } else {
    plan.bits("return_number", 14, 0, 0x07);
    plan.bits("number_of_returns", 14, 3, 0x07);
    plan.bits("classification", 15, 0, 0x1F);
    plan.typed<std::int8_t>("scan_angle", 16);
    plan.typed<std::uint8_t>("user_data", 17);
    plan.typed<std::uint16_t>("point_source_id", 18);
  }
  if (layout.gps >= 0) plan.typed<double>("gps_time", static_cast<std::size_t>(layout.gps));
  if (layout.rgb >= 0) {
    const char* names[3] = {"red", "green", "blue"};
    for (std::size_t c = 0; c < 3; ++c)
      plan.typed<std::uint16_t>(names[c], static_cast<std::size_t>(layout.rgb) + 2 * c);
  }
  if (layout.nir >= 0) plan.typed<std::uint16_t>("nir", static_cast<std::size_t>(layout.nir));
  plan_flags(plan, layout.extended);
}

/// The extra-bytes fields, scaled and offset as their descriptors say. Their
/// names (made unique) do not depend on the selection.
void plan_extra_fields(column_planner& plan, const std::vector<extra_desc>& extras) {
  for (std::size_t j = 0; j < extras.size(); ++j) {
    const extra_desc& e = extras[j];
    for (int k = 0; k < e.count; ++k) {
      std::string name =
          e.count == 1 ? e.name : (e.name.empty() ? "extra_" + std::to_string(j) : e.name) + "_" + std::to_string(k);
      name = unique_name(plan.taken, std::move(name), j);
      if (!plan.selection.wants(name)) continue;
      las_column c;
      c.name = std::move(name);
      c.how = las_column::kind::extra;
      c.offset = e.offset + size_of(e.type) * static_cast<std::size_t>(k);
      c.raw = e.type;
      c.scaled = (e.options & 8) != 0;
      c.offsetted = (e.options & 16) != 0;
      c.scale = e.scale[k];
      c.add = e.offset_value[k];
      c.type = c.scaled || c.offsetted ? scalar_type::float64 : e.type;
      plan.cols.push_back(std::move(c));
    }
  }
}

/// The selected fields of records of point format h.layout with `extras`,
/// `flag_bits` the OR of bytes 14 and 15 over the points read together.
std::vector<las_column> plan_columns(const las_header& h, const std::vector<extra_desc>& extras,
                                     const field_selection& selection, const unsigned flag_bits[2]) {
  column_planner plan{selection, flag_bits, {}, {}};
  plan_standard_fields(plan, *h.layout);
  plan_extra_fields(plan, extras);
  return std::move(plan.cols);
}

/// The values of column c of the m records at p (`stride` bytes apart) into
/// `out`, m values of c.type.
void decode_las_column(const las_column& c, const unsigned char* p, std::size_t stride, std::size_t m,
                       unsigned char* out) {
  p += c.offset;
  if (c.how == las_column::kind::bits) {
    for (std::size_t i = 0; i < m; ++i) out[i] = static_cast<unsigned char>((p[i * stride] >> c.shift) & c.mask);
  } else if (c.how == las_column::kind::typed) {
    visit_type(c.type, [&](auto tag) {
      using T = decltype(tag);
      for (std::size_t i = 0; i < m; ++i) store<T, false>(out + i * sizeof(T), load_le<T>(p + i * stride));
    });
  } else {
    // As doubles, scaled and offset, then in the field's type: the values
    // (and NaN bits) of a conversion through double, as fields are made.
    visit_type(c.raw, [&](auto tag) {
      using T = decltype(tag);
      for (std::size_t i = 0; i < m; ++i) {
        double v = static_cast<double>(load_le<T>(p + i * stride));
        if (c.scaled) v *= c.scale;
        if (c.offsetted) v += c.add;
        if (c.type == scalar_type::float64)
          store<double, false>(out + i * 8, v);
        else if constexpr (std::is_same_v<T, float>)
          store<T, false>(out + i * sizeof(T), through_double(load_le<T>(p + i * stride)));
        else
          store<T, false>(out + i * sizeof(T), convert<T>(v));
      }
    });
  }
}

/// The positions of the m records at p (`stride` bytes apart), relative to
/// `origin`, into out[0, 3m).
void decode_positions(const unsigned char* p, std::size_t stride, std::size_t m, const las_header& h,
                      const std::array<double, 3>& origin, float* out) noexcept {
  const auto& scale = h.scale;
  const double shift[3] = {h.offset[0] - origin[0], h.offset[1] - origin[1], h.offset[2] - origin[2]};
  for (std::size_t i = 0; i < m; ++i, p += stride)
    for (std::size_t k = 0; k < 3; ++k)
      out[3 * i + k] = static_cast<float>(load_le<std::int32_t>(p + 4 * k) * scale[k] + shift[k]);
}

/// A cloud of the n records of `src`: positions relative to `origin`, the
/// fields of `plan`. Chunks of records are decoded in parallel, each into
/// its own points: the cloud is the same for any number of threads. The
/// memory of `reuse` (a stream's last chunk) holds it where it fits: a
/// stream's chunks then fault no new pages in.
point_cloud decode_records(const record_source& src, std::uint64_t count, const las_header& h,
                           const std::array<double, 3>& origin, const std::vector<las_column>& plan,
                           point_cloud&& reuse) {
  const auto n = static_cast<std::size_t>(count);  // <= room: the allocation is bounded by the file size
  point_cloud cloud;
  cloud.set_origin(origin);
  cloud.positions() = std::move(reuse.positions());
  cloud.resize(n);
  std::vector<field>& old = reuse.fields();
  std::vector<column> cols;
  cols.reserve(plan.size());  // dst keeps pointers to their bytes
  std::vector<unsigned char*> dst;
  for (std::size_t k = 0; k < plan.size(); ++k) {
    column& c = cols.emplace_back(plan[k].type);
    if (k < old.size() && old[k].type() == plan[k].type) c = std::move(old[k].values);
    c.resize(n);  // (every value is written below)
    dst.push_back(c.bytes());
  }
  float* xyz = cloud.positions().data();
  for_each_chunk(src, n, [&](std::size_t, std::uint64_t i0, std::size_t m, const unsigned char* r) {
    decode_positions(r, src.stride(), m, h, origin, xyz + 3 * i0);
    for (std::size_t k = 0; k < plan.size(); ++k)
      decode_las_column(plan[k], r, src.stride(), m, dst[k] + i0 * size_of(plan[k].type));
  });
  for (std::size_t k = 0; k < plan.size(); ++k) cloud.add_field(plan[k].name, std::move(cols[k]));
  return cloud;
}

/// The n records of `src` as a cloud, with the origin of their bounding box
/// and the selected fields: a first pass learns the bounds and flags.
point_cloud read_records(const record_source& src, const las_header& h, const std::vector<extra_desc>& extras,
                         const field_selection& selection) {
  const record_scan scan = scan_records(src, h.count);
  const std::array<double, 3> origin = scan.any ? las_origin(scan.lo, scan.hi, h) : std::array<double, 3>{0, 0, 0};
  return decode_records(src, h.count, h, origin, plan_columns(h, extras, selection, scan.flags));
}

/// The bytes of a LAS file up to its point data (all of it when shorter than
/// a header), enough for read_header() and read_vlrs() with the file's size.
std::string read_head(input_file& file) {
  std::string head;
  file.read_some(0, 375, head);
  if (head.size() >= 100) {
    const auto offset = load_le<std::uint32_t>(reinterpret_cast<const unsigned char*>(head.data()) + 96);
    if (offset > head.size() && offset <= file.size()) file.read_some(0, offset, head);
  }
  return head;
}

/// Reads bytes of a file held in memory (io_error past its end).
laz_read_fn memory_reader(std::string_view bytes, const std::string& file) {
  return [bytes, file](std::uint64_t offset, std::size_t n, char* out) {
    if (offset > bytes.size() || n > bytes.size() - offset)
      throw io_error(file, "truncated: " + std::to_string(n) + " bytes at byte " + std::to_string(offset) +
                               " are past the end of the file (" + std::to_string(bytes.size()) + " bytes)");
    std::memcpy(out, bytes.data() + offset, n);
  };
}

laz_read_fn file_reader(const input_file& file) {
  return [&file](std::uint64_t offset, std::size_t n, char* out) { file.read_at(offset, n, out); };
}

/// The chunks of a LAZ file (`h` compressed, `layout` from its VLR) of `size` bytes.
laz_points open_laz(const las_header& h, const laz_layout& layout, std::uint64_t size, const laz_read_fn& read,
                    const std::string& file) {
  laz_points z{layout, laz_chunks(layout, h.point_offset, size, h.count, read, file)};
  // Far beyond what LAZ compresses real points to (10-20 times): a corrupt
  // header, refused before its records are allocated.
  const std::uint64_t coded = size - h.point_offset;
  if (h.count > (std::uint64_t(1) << 40) / h.record_length || h.count * h.record_length > 4096 * coded + (1u << 20))
    throw io_error(file, "LAZ: " + std::to_string(h.count) + " points of " + std::to_string(h.record_length) +
                             " bytes declared in " + std::to_string(coded) +
                             " bytes of compressed data; that is not a plausible compression");
  return z;
}

/// The fields of layered LAZ chunks that a selection needs decoded.
laz_wanted wanted_of(const field_selection& s) {
  laz_wanted w;
  if (s.all) return w;
  const auto any = [&](std::initializer_list<const char*> names) {
    for (const char* n : names)
      if (s.wants(n)) return true;
    return false;
  };
  w.classification = any({"classification"});
  w.flags = any({"synthetic", "key_point", "withheld", "overlap", "scan_direction_flag", "edge_of_flight_line"});
  w.intensity = any({"intensity"});
  w.scan_angle = any({"scan_angle"});
  w.user_data = any({"user_data"});
  w.point_source = any({"point_source_id"});
  w.gps_time = any({"gps_time"});
  w.rgb = any({"red", "green", "blue"});
  w.nir = any({"nir"});
  return w;  // extra bytes: always (their fields' names are the descriptors')
}

/// The records of chunks [c0, c1), decoded (of layered chunks, the `wanted` fields).
big_bytes decode_laz(const laz_points& z, std::size_t c0, std::size_t c1, const laz_read_fn& read,
                     const std::string& file, const laz_wanted& wanted) {
  const std::uint64_t points =
      c0 < c1 ? z.chunks[c1 - 1].first_point + z.chunks[c1 - 1].points - z.chunks[c0].first_point : 0;
  big_bytes out(static_cast<std::size_t>(points * z.layout.record_length));
  decode_laz_chunks(z.layout, z.chunks, c0, c1, read, reinterpret_cast<unsigned char*>(out.data()), file, wanted);
  return out;
}

/// The records of a LAS or LAZ file whose header and VLRs are at d.
point_cloud read_las_records(const unsigned char* d, const las_header& h, std::uint64_t size, const laz_read_fn& read,
                             const record_source& plain, const std::string& file, las_read_info* info,
                             const field_selection& selection) {
  laz_layout layout;
  std::optional<copc_info> copc;
  std::vector<std::string> others;
  std::string crs;
  const std::vector<extra_desc> extras = read_vlrs(d, h, file, &layout, &copc, &others, &crs);
  if (info) {
    fill_info(*info, h, d);
    info->copc = copc.has_value();
    info->other_vlrs = std::move(others);
    info->coordinate_system = std::move(crs);
  }
  if (!h.compressed) return read_records(plain, h, extras, selection);
  const laz_points z = open_laz(h, layout, size, read, file);
  const big_bytes records = decode_laz(z, 0, z.chunks.size(), read, file, wanted_of(selection));
  return read_records(record_source(reinterpret_cast<const unsigned char*>(records.data()), h.record_length), h, extras,
                      selection);
}

point_cloud parse_las(std::string_view bytes, const std::string& file, las_read_info* info,
                      const field_selection& selection) {
  const auto* d = reinterpret_cast<const unsigned char*>(bytes.data());
  const las_header h = read_header(d, bytes.size(), file);
  return read_las_records(d, h, bytes.size(), memory_reader(bytes, file),
                          record_source(d + h.point_offset, h.record_length), file, info, selection);
}

/// read_las() of a file: the header, then the records read in chunks.
point_cloud read_las_file(const std::string& path, las_read_info* info, const field_selection& selection) {
  if (!chunked_file(path)) return parse_las(read_whole_file(path), path, info, selection);
  input_file file(path);
  const std::string head = read_head(file);
  const auto* d = reinterpret_cast<const unsigned char*>(head.data());
  const las_header h = read_header(d, static_cast<std::size_t>(file.size()), path);
  return read_las_records(d, h, file.size(), file_reader(file), record_source(file, h.point_offset, h.record_length),
                          path, info, selection);
}
}  // namespace las_detail

point_cloud read_las_buffer(std::string_view bytes, const std::string& name, las_read_info* info,
                            const field_selection& fields) {
  return parse_las(bytes, name, info, fields);
}

point_cloud read_las(const std::string& path, las_read_info* info, const field_selection& fields) {
  return read_las_file(path, info, fields);
}

std::string coordinate_system_name(const std::string& coordinate_system) {
  if (coordinate_system.empty()) return "none";
  const std::size_t wkt = coordinate_system.find("2112:");
  if (wkt != std::string::npos) {
    const std::size_t a = coordinate_system.find('"', wkt);
    const std::size_t b = a == std::string::npos ? a : coordinate_system.find('"', a + 1);
    if (b != std::string::npos && b > a + 1 && b - a < 200) return coordinate_system.substr(a + 1, b - a - 1);
  }
  std::uint64_t h = 1469598103934665603ull;  // FNV-1a
  for (const char c : coordinate_system) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ull;
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return std::string(wkt != std::string::npos ? "WKT #" : "GeoTIFF keys #") + hex;
}

}  // namespace ced::io
