// SPDX-License-Identifier: MIT
#include "ced/io/las.hpp"

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

#include "ced/io/stream.hpp"
#include "ced/version.hpp"
#include "laz.hpp"
#include "records.hpp"
#include "scalar_io.hpp"
#include "stream_support.hpp"

namespace ced::io {

using namespace detail;  // scalar_io.hpp

namespace {

// ---------------------------------------------------------------- utilities

/// A fixed-size char field: up to the first NUL, without surrounding spaces.
std::string fixed_string(const unsigned char* p, std::size_t n) {
  std::size_t len = 0;
  while (len < n && p[len] != 0) ++len;
  std::string s(reinterpret_cast<const char*>(p), len);
  const auto b = s.find_first_not_of(' ');
  if (b == std::string::npos) return {};
  return s.substr(b, s.find_last_not_of(' ') - b + 1);
}

std::string num(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

// ------------------------------------------------------------------- layout

constexpr std::size_t k_vlr_header_size = 54;
constexpr std::size_t k_extra_bytes_descriptor_size = 192;
constexpr int k_max_format = 10;

struct format_layout {
  std::size_t min_size;  ///< bytes of the standard fields
  bool extended;         ///< formats 6-10 (LAS 1.4 layout)
  int gps;               ///< byte offset of gps_time, or -1
  int rgb;               ///< byte offset of red (green, blue follow), or -1
  int nir;               ///< byte offset of nir, or -1
};

constexpr format_layout k_formats[k_max_format + 1] = {
    {20, false, -1, -1, -1}, {28, false, 20, -1, -1}, {26, false, -1, 20, -1}, {34, false, 20, 28, -1},
    {57, false, 20, -1, -1}, {63, false, 20, 28, -1}, {30, true, 22, -1, -1},  {36, true, 22, 30, -1},
    {38, true, 22, 30, 36},  {59, true, 22, -1, -1},  {67, true, 22, 30, 36}};

std::size_t header_size_for(int version_minor) noexcept {
  return version_minor >= 4 ? 375 : version_minor == 3 ? 235 : 227;
}

/// Extra-bytes data types 1..10 (the deprecated arrays 11..30 repeat them).
constexpr scalar_type k_extra_types[10] = {
    scalar_type::uint8, scalar_type::int8,   scalar_type::uint16, scalar_type::int16,   scalar_type::uint32,
    scalar_type::int32, scalar_type::uint64, scalar_type::int64,  scalar_type::float32, scalar_type::float64};

int extra_type_code(scalar_type t) noexcept {
  for (int i = 0; i < 10; ++i)
    if (k_extra_types[i] == t) return i + 1;
  return 10;
}

// ------------------------------------------------------------------- reader

struct extra_desc {
  std::string name;
  scalar_type type = scalar_type::uint8;
  int count = 1;           ///< 1, or 2/3 for the deprecated array types; 0 for undocumented bytes
  std::size_t size = 0;    ///< bytes in the record
  std::size_t offset = 0;  ///< from the start of the record
  int options = 0;
  double scale[3] = {1, 1, 1};
  double offset_value[3] = {0, 0, 0};
};

std::vector<extra_desc> parse_extra_bytes(const unsigned char* p, std::size_t len, const std::string& file) {
  if (len % k_extra_bytes_descriptor_size != 0)
    throw io_error(file, "the extra-bytes VLR has " + std::to_string(len) + " bytes, not a multiple of the " +
                             std::to_string(k_extra_bytes_descriptor_size) + "-byte descriptor size");
  std::vector<extra_desc> out;
  for (std::size_t i = 0; i < len / k_extra_bytes_descriptor_size; ++i) {
    const unsigned char* d = p + i * k_extra_bytes_descriptor_size;
    extra_desc e;
    const int data_type = d[2];
    e.options = d[3];
    e.name = fixed_string(d + 4, 32);
    const std::string what = "extra-bytes descriptor " + std::to_string(i) + " ('" + e.name + "')";
    if (data_type == 0) {
      e.count = 0;
      e.size = static_cast<std::size_t>(e.options);  // undocumented bytes: options holds their number
    } else if (data_type <= 30) {
      e.type = k_extra_types[(data_type - 1) % 10];
      e.count = data_type <= 10 ? 1 : data_type <= 20 ? 2 : 3;
      e.size = size_of(e.type) * static_cast<std::size_t>(e.count);
      for (int k = 0; k < e.count; ++k) {
        e.scale[k] = load_le<double>(d + 112 + 8 * k);
        e.offset_value[k] = load_le<double>(d + 136 + 8 * k);
        if ((e.options & 8) && (!std::isfinite(e.scale[k]) || e.scale[k] == 0))
          throw io_error(file, what + " has an invalid scale " + num(e.scale[k]) + " (it must be finite and non-zero)");
        if ((e.options & 16) && !std::isfinite(e.offset_value[k]))
          throw io_error(file, what + " has a non-finite offset");
      }
    } else {
      throw io_error(file, what + " has unknown data type " + std::to_string(data_type) + " (LAS defines 0 to 30)");
    }
    out.push_back(std::move(e));
  }
  return out;
}

/// The bitwise OR of the byte at p + i * stride over all i < n.
unsigned or_of_bytes(const unsigned char* p, std::size_t stride, std::size_t n) noexcept {
  unsigned bits = 0;
  for (std::size_t i = 0; i < n; ++i) bits |= p[i * stride];
  return bits;
}

/// `name`, or `name` with a suffix when the cloud already has such a field.
/// `taken` holds every field name of the file so far, selected or not, so
/// that a field's name never depends on the selection.
std::string unique_name(std::vector<std::string>& taken, std::string name, std::size_t index) {
  if (name.empty()) name = "extra_" + std::to_string(index);
  const auto free = [&](const std::string& c) { return std::find(taken.begin(), taken.end(), c) == taken.end(); };
  std::string candidate = name;
  for (int k = 1; !free(candidate); ++k) candidate = name + "_extra" + (k == 1 ? std::string() : std::to_string(k));
  taken.push_back(candidate);
  return candidate;
}

/// A one-bit flag (or the 2-bit scanner channel) in byte 14 or 15 of a record.
struct flag_spec {
  const char* name;
  std::size_t offset;
  int shift;
  unsigned mask;
};

/// The fields of the public header that the reader uses, checked.
struct las_header {
  int major = 1, minor = 0;
  std::size_t header_size = 0;
  std::size_t point_offset = 0;
  std::uint32_t n_vlrs = 0;
  int format = 0;
  const format_layout* layout = nullptr;
  std::size_t record_length = 0;  ///< the stride of the point records
  std::uint64_t count = 0;        ///< point records, all within the file (when not compressed)
  std::array<double, 3> scale{}, offset{};
  std::array<double, 3> min{}, max{};  ///< the header's bounds, as written (maybe wrong)
  bool compressed = false;             ///< LAZ: the records are in compressed chunks (laz.hpp)
};

/// The header's scale factors and offsets: finite, the scales non-zero.
void read_scale_and_offset(const unsigned char* d, las_header& h, const std::string& file) {
  for (std::size_t k = 0; k < 3; ++k) {
    const std::string axis(1, static_cast<char>('X' + k));
    h.scale[k] = load_le<double>(d + 131 + 8 * k);
    h.offset[k] = load_le<double>(d + 155 + 8 * k);
    if (!std::isfinite(h.scale[k]) || h.scale[k] == 0)
      throw io_error(file,
                     "invalid " + axis + " scale factor " + num(h.scale[k]) + " (it must be finite and non-zero)");
    if (!std::isfinite(h.offset[k]))
      throw io_error(file, "invalid " + axis + " offset " + num(h.offset[k]) + " (not finite)");
    h.max[k] = load_le<double>(d + 179 + 16 * k);
    h.min[k] = load_le<double>(d + 187 + 16 * k);
  }
}

/// The public header of the `size` bytes at d: its signature, version, sizes,
/// point format and count are checked against the file.
las_header read_header(const unsigned char* d, std::size_t size, const std::string& file) {
  if (size < 4 || std::memcmp(d, "LASF", 4) != 0)
    throw io_error(file, "not a LAS file (it does not start with the 'LASF' signature)");
  if (size < 227)
    throw io_error(
        file, "truncated header: the file has " + std::to_string(size) + " bytes, a LAS header needs at least 227");
  las_header h;
  h.major = d[24];
  h.minor = d[25];
  if (h.major != 1 || h.minor > 4)
    throw io_error(file, "unsupported LAS version " + std::to_string(h.major) + "." + std::to_string(h.minor) +
                             " (this reader supports 1.0 to 1.4)");
  const std::string version = std::to_string(h.major) + "." + std::to_string(h.minor);
  const std::size_t min_header = header_size_for(h.minor);
  if (size < min_header)
    throw io_error(file, "truncated header: the file has " + std::to_string(size) + " bytes, a LAS " + version +
                             " header needs " + std::to_string(min_header));
  h.header_size = load_le<std::uint16_t>(d + 94);
  if (h.header_size < min_header)
    throw io_error(file, "header size " + std::to_string(h.header_size) + " is smaller than the " +
                             std::to_string(min_header) + " bytes of a LAS " + version + " header");
  h.point_offset = load_le<std::uint32_t>(d + 96);
  if (h.point_offset < h.header_size)
    throw io_error(file, "offset to point data (" + std::to_string(h.point_offset) +
                             ") is smaller than the header size (" + std::to_string(h.header_size) + ")");
  if (h.point_offset > size)
    throw io_error(file, "truncated: the point data should start at byte " + std::to_string(h.point_offset) +
                             ", but the file has " + std::to_string(size) + " bytes");
  h.n_vlrs = load_le<std::uint32_t>(d + 100);
  const int format_byte = d[104];
  // LAZ sets the top bit of the point format byte.
  if (format_byte & 0x40)
    throw io_error(file, "unknown compression of the point data (point format byte " + std::to_string(format_byte) +
                             ", bit 6 set)");
  h.compressed = (format_byte & 0x80) != 0;
  h.format = format_byte & 0x3F;
  if (h.format > k_max_format)
    throw io_error(file, "unsupported point data record format " + std::to_string(h.format) + " (LAS defines 0 to 10)");
  h.layout = &k_formats[h.format];
  h.record_length = load_le<std::uint16_t>(d + 105);
  if (h.record_length < h.layout->min_size)
    throw io_error(file, "point record length " + std::to_string(h.record_length) + " is too small for point format " +
                             std::to_string(h.format) + " (it needs at least " + std::to_string(h.layout->min_size) +
                             " bytes)");
  h.count = load_le<std::uint32_t>(d + 107);
  if (h.minor >= 4) {
    const auto count64 = load_le<std::uint64_t>(d + 247);
    if (count64 != 0 || h.count == 0) h.count = count64;
  }
  read_scale_and_offset(d, h, file);
  const std::uint64_t room = (size - h.point_offset) / h.record_length;
  if (!h.compressed && h.count > room)
    throw io_error(file, "truncated: " + std::to_string(h.count) + " points declared, room for " +
                             std::to_string(room) + " (" + std::to_string(h.record_length) +
                             "-byte records from byte " + std::to_string(h.point_offset) + " in " +
                             std::to_string(size) + " bytes)");
  return h;
}

/// The extra-bytes descriptors of the variable length records (between the
/// header and the point data), placed after the standard fields and checked
/// to fit in a point record; none without an extra-bytes VLR.
std::vector<extra_desc> read_vlrs(const unsigned char* d, const las_header& h, const std::string& file,
                                  laz_layout* laz = nullptr, std::optional<copc_info>* copc = nullptr,
                                  std::vector<std::string>* others = nullptr) {
  std::vector<extra_desc> extras;
  bool have_laz = false;
  bool have_extras = false;
  std::size_t pos = h.header_size;
  for (std::uint32_t i = 0; i < h.n_vlrs; ++i) {
    if (h.point_offset - pos < k_vlr_header_size)
      throw io_error(file, "VLR " + std::to_string(i) + " of " + std::to_string(h.n_vlrs) + " (at byte " +
                               std::to_string(pos) + ") does not fit before the point data at byte " +
                               std::to_string(h.point_offset));
    const std::string user_id = fixed_string(d + pos + 2, 16);
    const int record_id = load_le<std::uint16_t>(d + pos + 18);
    const std::size_t len = load_le<std::uint16_t>(d + pos + 20);
    if (h.point_offset - pos - k_vlr_header_size < len)
      throw io_error(file, "VLR " + std::to_string(i) + " ('" + user_id + "' record " + std::to_string(record_id) +
                               ", " + std::to_string(len) + " bytes) runs past the start of the point data at byte " +
                               std::to_string(h.point_offset));
    if (user_id == "LASF_Spec" && record_id == 4 && !have_extras) {
      extras = parse_extra_bytes(d + pos + k_vlr_header_size, len, file);
      have_extras = true;
    }
    // COPC: the info VLR comes first.
    if (copc && h.compressed && i == 0 && user_id == "copc" && record_id == 1)
      *copc = parse_copc_info(d + pos + k_vlr_header_size, len, file);
    if (h.compressed && user_id == "laszip encoded" && record_id == 22204 && !have_laz) {
      const laz_layout l = parse_laszip_vlr(d + pos + k_vlr_header_size, len, h.format, h.record_length, file);
      if (laz) *laz = l;
      have_laz = true;
    }
    const bool known = (user_id == "LASF_Spec" && record_id == 4) || (user_id == "copc" && record_id == 1) ||
                       (user_id == "laszip encoded" && record_id == 22204);
    if (others && !known) others->push_back("'" + user_id + "' " + std::to_string(record_id));
    pos += k_vlr_header_size + len;
  }
  if (h.compressed && !have_laz)
    throw io_error(file,
                   "the point format byte says LAZ-compressed, but there is no LASzip VLR ('laszip encoded', "
                   "record 22204) to say how");
  std::size_t extra_total = 0;
  for (auto& e : extras) {
    e.offset = h.layout->min_size + extra_total;
    extra_total += e.size;
  }
  if (h.layout->min_size + extra_total > h.record_length)
    throw io_error(file, "the extra bytes (" + std::to_string(extra_total) + " bytes in " +
                             std::to_string(extras.size()) + " descriptors) do not fit in the " +
                             std::to_string(h.record_length) + "-byte point record (point format " +
                             std::to_string(h.format) + " uses " + std::to_string(h.layout->min_size) + " bytes)");
  return extras;
}

void fill_info(las_read_info& info, const las_header& h, const unsigned char* d) {
  info.version_major = h.major;
  info.version_minor = h.minor;
  info.point_format = h.format;
  info.points = h.count;
  info.scale = h.scale;
  info.offset = h.offset;
  info.system_identifier = fixed_string(d + 26, 32);
  info.generating_software = fixed_string(d + 58, 32);
  info.compressed = h.compressed;
  info.global_encoding = load_le<std::uint16_t>(d + 6);
  info.extended_vlrs = h.minor >= 4 && h.header_size >= 247 ? load_le<std::uint32_t>(d + 243) : 0;
}

/// The raw integer bounds of the n point records (`stride` bytes apart from
/// base), merged into lo/hi (`any`: they already hold some points').
void raw_bounds(const unsigned char* base, std::size_t stride, std::size_t n, std::int32_t lo[3], std::int32_t hi[3],
                bool any) noexcept {
  if (n > 0 && !any)
    for (std::size_t k = 0; k < 3; ++k) lo[k] = hi[k] = load_le<std::int32_t>(base + 4 * k);
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char* p = base + i * stride;
    for (std::size_t k = 0; k < 3; ++k) {
      const auto v = load_le<std::int32_t>(p + 4 * k);
      lo[k] = std::min(lo[k], v);
      hi[k] = std::max(hi[k], v);
    }
  }
}

/// The origin of points whose raw integers span [lo, hi]: that of the
/// header's box when it holds them grown by 1 % (las_header_box), else of theirs. A file
/// whose header is right thus has one origin however much of it is read,
/// which a tile read through a COPC index needs (ced::io::point_stream::header_box).
std::array<double, 3> las_origin(const std::int32_t lo[3], const std::int32_t hi[3], const las_header& h) {
  double a[3], b[3], box[6];
  const bool header = las_header_box(h.min.data(), h.max.data(), h.scale.data(), 0.01, box);
  bool inside = header;
  for (std::size_t k = 0; k < 3; ++k) {
    a[k] = lo[k] * h.scale[k] + h.offset[k];
    b[k] = hi[k] * h.scale[k] + h.offset[k];
    inside = inside && std::min(a[k], b[k]) >= box[k] && std::max(a[k], b[k]) <= box[3 + k];
  }
  return inside ? choose_origin(h.min.data(), h.max.data()) : choose_origin(a, b);
}

/// What a pass over point records learns: the bounds of their raw integer
/// coordinates and the OR of their bytes 14 and 15 (the flags some point sets).
struct record_scan {
  std::int32_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  unsigned flags[2] = {0, 0};
  bool any = false;  ///< lo and hi hold some points'

  /// Adds the n records (`stride` bytes apart from base).
  void add(const unsigned char* base, std::size_t stride, std::size_t n) noexcept {
    raw_bounds(base, stride, n, lo, hi, any);
    any = any || n > 0;
    flags[0] |= or_of_bytes(base + 14, stride, n);
    flags[1] |= or_of_bytes(base + 15, stride, n);
  }
  /// Adds the records another scan saw.
  void merge(const record_scan& o) noexcept {
    for (std::size_t k = 0; o.any && k < 3; ++k) {
      lo[k] = any ? std::min(lo[k], o.lo[k]) : o.lo[k];
      hi[k] = any ? std::max(hi[k], o.hi[k]) : o.hi[k];
    }
    any = any || o.any;
    flags[0] |= o.flags[0];
    flags[1] |= o.flags[1];
  }
};

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

/// One selected field: where its values are in a record and how they are decoded.
struct las_column {
  enum class kind { typed, bits, extra };
  std::string name;
  scalar_type type = scalar_type::uint8;  ///< the field's
  std::size_t offset = 0;                 ///< in the record
  kind how = kind::typed;
  int shift = 0;      ///< bits: (byte >> shift) & mask
  unsigned mask = 0;  ///<
  scalar_type raw{};  ///< extra: the type in the record
  double scale = 1;   ///< extra: applied when `scaled`
  double add = 0;     ///< extra: applied when `offsetted`
  bool scaled = false, offsetted = false;
};

/// The fields of a point format that a selection keeps, in the reader's order.
struct column_planner {
  const field_selection& selection;
  /// The OR of bytes 14 and 15 over all the points read together, which
  /// decides the flag fields (a chunk of a file must have the file's fields).
  const unsigned* flag_bits;
  std::vector<std::string> taken;  ///< every field's name so far, selected or not
  std::vector<las_column> cols;

  /// The field `name` (`c` says how it is decoded), when selected.
  void add(const char* name, las_column c) {
    taken.push_back(name);
    if (!selection.wants(name)) return;
    c.name = name;
    cols.push_back(std::move(c));
  }
  /// A field of type T at byte `off` of each record.
  template <class T>
  void typed(const char* name, std::size_t off) {
    las_column c;
    c.type = scalar_type_of<T>();
    c.offset = off;
    add(name, c);
  }
  /// A field of the bits (byte >> shift) & mask of byte `off` of each record.
  void bits(const char* name, std::size_t off, int shift, unsigned mask) {
    las_column c;
    c.how = las_column::kind::bits;
    c.offset = off;
    c.shift = shift;
    c.mask = mask;
    add(name, c);
  }
};

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
                           point_cloud&& reuse = {}) {
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

/// A LAZ file's compression and chunks.
struct laz_points {
  laz_layout layout;
  std::vector<laz_chunk> chunks;
};

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
                     const std::string& file, const laz_wanted& wanted = {}) {
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
  const std::vector<extra_desc> extras = read_vlrs(d, h, file, &layout, &copc, &others);
  if (info) {
    fill_info(*info, h, d);
    info->copc = copc.has_value();
    info->other_vlrs = std::move(others);
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

// ------------------------------------------------------------------ writer

enum class slot_kind { u8, i8, u16, i16, f64, bits };

/// The type of the slots of each kind but bits.
constexpr scalar_type k_slot_types[] = {scalar_type::uint8, scalar_type::int8, scalar_type::uint16, scalar_type::int16,
                                        scalar_type::float64};

/// One standard LAS field in a point record.
struct slot_spec {
  const char* name;
  slot_kind kind;
  std::size_t offset;
  int shift = 0;      ///< bits: position in the byte
  unsigned max = 0;   ///< bits: largest value
  bool flag = false;  ///< bits: non-zero -> 1
};

std::vector<slot_spec> standard_slots(const format_layout& layout) {
  using k = slot_kind;
  std::vector<slot_spec> s;
  s.push_back({"intensity", k::u16, 12});
  if (layout.extended) {
    s.push_back({"return_number", k::bits, 14, 0, 15});
    s.push_back({"number_of_returns", k::bits, 14, 4, 15});
    s.push_back({"synthetic", k::bits, 15, 0, 1, true});
    s.push_back({"key_point", k::bits, 15, 1, 1, true});
    s.push_back({"withheld", k::bits, 15, 2, 1, true});
    s.push_back({"overlap", k::bits, 15, 3, 1, true});
    s.push_back({"scanner_channel", k::bits, 15, 4, 3});
    s.push_back({"scan_direction_flag", k::bits, 15, 6, 1, true});
    s.push_back({"edge_of_flight_line", k::bits, 15, 7, 1, true});
    s.push_back({"classification", k::u8, 16});
    s.push_back({"user_data", k::u8, 17});
    s.push_back({"scan_angle", k::i16, 18});
    s.push_back({"point_source_id", k::u16, 20});
  } else {
    s.push_back({"return_number", k::bits, 14, 0, 7});
    s.push_back({"number_of_returns", k::bits, 14, 3, 7});
    s.push_back({"scan_direction_flag", k::bits, 14, 6, 1, true});
    s.push_back({"edge_of_flight_line", k::bits, 14, 7, 1, true});
    s.push_back({"classification", k::bits, 15, 0, 31});
    s.push_back({"synthetic", k::bits, 15, 5, 1, true});
    s.push_back({"key_point", k::bits, 15, 6, 1, true});
    s.push_back({"withheld", k::bits, 15, 7, 1, true});
    s.push_back({"scan_angle", k::i8, 16});
    s.push_back({"user_data", k::u8, 17});
    s.push_back({"point_source_id", k::u16, 18});
  }
  if (layout.gps >= 0) s.push_back({"gps_time", k::f64, static_cast<std::size_t>(layout.gps)});
  if (layout.rgb >= 0) {
    const auto o = static_cast<std::size_t>(layout.rgb);
    s.push_back({"red", k::u16, o});
    s.push_back({"green", k::u16, o + 2});
    s.push_back({"blue", k::u16, o + 4});
  }
  if (layout.nir >= 0) s.push_back({"nir", k::u16, static_cast<std::size_t>(layout.nir)});
  return s;
}

/// A column to encode: a slot or an extra-bytes field.
struct out_column {
  const column* values = nullptr;  ///< nullptr: `constant` for every point
  double constant = 0;
  double factor = 1;                      ///< applied before conversion (scan angle units)
  scalar_type type = scalar_type::uint8;  ///< unless `bits`
  std::size_t offset = 0;
  bool bits = false;  ///< bits of a byte: `shift`, `max`, `flag` as in slot_spec
  int shift = 0;
  unsigned max = 0;
  bool flag = false;
};

void encode_column(const out_column& c, std::size_t i0, std::size_t m, unsigned char* buf, std::size_t record) {
  unsigned char* p = buf + c.offset;
  // Straight from the column when that stores the same bytes (not doubles:
  // the product by the factor quiets a signalling NaN).
  if (!c.bits && c.values && c.factor == 1 && c.type != scalar_type::float64 &&
      encode_direct(*c.values, i0, m, c.type, !host_little_endian(), p, record))
    return;
  thread_local std::vector<double> values;
  values.resize(m);
  if (c.values)
    copy_values(*c.values, i0, m, values.data());
  else
    std::fill(values.begin(), values.end(), c.constant);
  const auto value = [&](std::size_t i) { return values[i] * c.factor; };
  if (!c.bits) return encode_values(c.type, !host_little_endian(), p, record, m, value);
  for (std::size_t i = 0; i < m; ++i) {
    const double v = value(i);
    unsigned b = 0;
    if (c.flag)
      b = v != 0 && !std::isnan(v) ? 1u : 0u;
    else
      b = std::min<unsigned>(convert<std::uint8_t>(v), c.max);
    p[i * record] = static_cast<unsigned char>(p[i * record] | (b << c.shift));
  }
}

template <class T>
void put(std::string& s, std::size_t offset, T v) {
  store_le<T>(reinterpret_cast<unsigned char*>(&s[offset]), v);
}

void put_string(std::string& s, std::size_t offset, std::size_t width, const std::string& text) {
  std::memcpy(&s[offset], text.data(), std::min(width, text.size()));
}

/// Throws std::invalid_argument when `cloud` cannot be written as LAS with `opt`.
void check_writable(const point_cloud& cloud, const las_write_options& opt, std::uint64_t n) {
  const int minor = opt.version_minor;
  if (minor < 2 || minor > 4)
    throw std::invalid_argument("LAS version 1." + std::to_string(minor) + " cannot be written (use 1.2, 1.3 or 1.4)");
  for (std::size_t k = 0; k < 3; ++k) {
    if (!std::isfinite(opt.scale[k]) || opt.scale[k] <= 0)
      throw std::invalid_argument("invalid LAS scale " + num(opt.scale[k]) + " (it must be finite and positive)");
    if (!std::isfinite(cloud.origin()[k])) throw std::invalid_argument("the cloud's origin is not finite");
    if (opt.offset && !std::isfinite((*opt.offset)[k]))
      throw std::invalid_argument("invalid LAS offset " + num((*opt.offset)[k]) + " (not finite)");
  }
  const int pf = opt.point_format;
  if (pf != -1 && (pf < 0 || pf > k_max_format || (pf >= 6 && minor < 4)))
    throw std::invalid_argument("LAS point format " + std::to_string(pf) + " cannot be written in LAS 1." +
                                std::to_string(minor) + " (formats 0-3, and 6-8 in LAS 1.4)");
  if (pf == 4 || pf == 5 || pf == 9 || pf == 10)
    throw std::invalid_argument("LAS point format " + std::to_string(pf) +
                                " holds waveform packets, which ced does not write (use " +
                                std::to_string(pf == 4   ? 1
                                               : pf == 5 ? 3
                                               : pf == 9 ? 6
                                                         : 8) +
                                ")");
  for (const auto& f : cloud.fields()) check_field_size(f, cloud.size());
  if (minor < 4 && n > std::numeric_limits<std::uint32_t>::max())
    throw std::invalid_argument("LAS 1." + std::to_string(minor) + " cannot hold " + std::to_string(n) +
                                " points (at most 2^32-1; write LAS 1.4)");
}

/// What is written: the point format, the columns of a record and its length.
struct las_plan {
  int format = 0;
  const format_layout* layout = nullptr;
  std::vector<out_column> cols;          ///< standard slots, then extra bytes
  std::vector<const field*> extras;      ///< the fields written as extra bytes
  std::size_t record = 0;                ///< bytes per point record
  const field* return_number = nullptr;  ///< the field written as return_number, if any
};

/// The factor `f` is written into standard slot `s` with, so that reading the
/// file back gives what ced read from the field: a float colour or nir is a
/// fraction of the full scale (the rgb and bands modalities take floats as
/// [0, 1]: x 65535), an 8-bit nir becomes 16 bits (x 257, which bands reads
/// back as v / 255), a scan angle changes units; other values are written as
/// they are. In the 16-bit slots (intensity, colour, nir) a value that does
/// not fit (NaN, outside 0 .. 65535, a float colour outside [0, 1]) is an
/// error naming the field, never clamped.
double slot_factor(const field& f, const slot_spec& s, bool extended) {
  const std::string_view name = s.name;
  const bool is_float = f.type() == scalar_type::float32 || f.type() == scalar_type::float64;
  const bool colour = name == "red" || name == "green" || name == "blue" || name == "nir";
  double factor = 1;
  if (colour && is_float) factor = 65535;
  if (name == "nir" && f.type() == scalar_type::uint8) factor = 257;
  if (name == "scan_angle") {
    const bool degrees = f.type() == scalar_type::int8;
    if (extended && degrees) factor = 1 / 0.006;
    if (!extended && !degrees) factor = 0.006;
  }
  // The 16-bit slots hold measurements; the others are codes and counts, which
  // an older point format clamps (return numbers to 7, classes to 31).
  if (s.kind != slot_kind::u16 || f.type() == scalar_type::uint16 || f.type() == scalar_type::uint8) return factor;
  const double lo = 0, hi = 65535;
  f.values.visit([&](const auto* v, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      const double x = std::round(static_cast<double>(v[i]) * factor);
      if (x >= lo && x <= hi) continue;
      std::ostringstream msg;
      msg << "field '" << f.name << "' cannot be written as LAS " << name << ": point " << i << " has "
          << static_cast<double>(v[i]);
      if (colour && is_float)
        msg << " (a float " << name << " must be a fraction in [0, 1], written x 65535)";
      else
        msg << " (LAS stores it as an integer in " << lo << " .. " << hi << ")";
      throw std::invalid_argument(msg.str());
    }
  });
  return factor;
}

/// The columns of the standard slots that the cloud has a field for (and
/// return_number, number_of_returns = 1 when it has none); `used` receives
/// those fields.
void plan_standard_columns(const point_cloud& cloud, const std::array<const field*, 3>& rgb, const field* nir,
                           las_plan& plan, std::vector<const field*>& used) {
  const format_layout& layout = *plan.layout;
  for (const slot_spec& s : standard_slots(layout)) {
    const std::string_view name = s.name;
    const field* f = nullptr;
    if (name == "red" || name == "green" || name == "blue")
      f = rgb[name == "red" ? 0 : name == "green" ? 1 : 2];
    else if (name == "nir")
      f = nir;
    else
      f = cloud.find_field_icase(name);  // exact name first
    out_column c;
    c.bits = s.kind == slot_kind::bits;
    if (!c.bits) c.type = k_slot_types[static_cast<int>(s.kind)];
    c.offset = s.offset;
    c.shift = s.shift;
    c.max = s.max;
    c.flag = s.flag;
    if (f) {
      c.values = &f->values;
      used.push_back(f);
      c.factor = slot_factor(*f, s, layout.extended);
      if (name == "return_number") plan.return_number = f;
    } else if (name == "return_number" || name == "number_of_returns") {
      c.constant = 1;
    } else {
      continue;
    }
    plan.cols.push_back(c);
  }
}

/// The columns of the other fields, as extra bytes after the standard fields.
void plan_extra_columns(const point_cloud& cloud, las_plan& plan, const std::vector<const field*>& used) {
  for (const auto& f : cloud.fields()) {
    if (std::find(used.begin(), used.end(), &f) != used.end()) continue;
    if (f.name.empty() || f.name.size() > 32)
      throw std::invalid_argument("field '" + f.name +
                                  "' cannot be written as LAS extra bytes (the name must have 1 to 32 characters)");
    if (iequal(f.name, "x") || iequal(f.name, "y") || iequal(f.name, "z"))
      throw std::invalid_argument("field '" + f.name + "' clashes with the LAS coordinates");
    plan.extras.push_back(&f);
  }
  plan.record = plan.layout->min_size;
  for (const field* f : plan.extras) {
    out_column c;
    c.values = &f->values;
    c.type = f->type();
    c.offset = plan.record;
    plan.record += size_of(f->type());
    plan.cols.push_back(c);
  }
  if (plan.record > std::numeric_limits<std::uint16_t>::max() ||
      plan.extras.size() * k_extra_bytes_descriptor_size > std::numeric_limits<std::uint16_t>::max())
    throw std::invalid_argument("too many fields for LAS extra bytes (" + std::to_string(plan.extras.size()) + ")");
}

/// The point format (opt.point_format, or the one for the cloud's fields:
/// colour, nir, gps_time) and its columns.
las_plan plan_records(const point_cloud& cloud, const las_write_options& opt) {
  const int minor = opt.version_minor;
  const auto rgb = find_rgb_fields(cloud);
  const bool has_rgb = rgb[0] != nullptr;
  const field* nir = cloud.find_field("nir");
  if (!nir) nir = cloud.find_field_icase("nir");
  const bool has_gps = cloud.find_field("gps_time") != nullptr;
  las_plan plan;
  if (minor >= 4)
    plan.format = has_rgb ? (nir ? 8 : 7) : 6;
  else
    plan.format = has_rgb ? (has_gps ? 3 : 2) : (has_gps ? 1 : 0);
  if (opt.point_format >= 0) plan.format = opt.point_format;
  plan.layout = &k_formats[plan.format];
  std::vector<const field*> used;
  plan_standard_columns(cloud, rgb, nir, plan, used);
  plan_extra_columns(cloud, plan, used);
  return plan;
}

/// The header's offsets: options.offset, or the cloud's origin.
std::array<double, 3> header_offset(const point_cloud& cloud, const las_write_options& opt) {
  return opt.offset ? *opt.offset : cloud.origin();
}

/// offset - origin: a position p relative to the origin is written as the
/// integer round((p - shift) / scale), which read_las() reads back as
/// float(integer * scale + shift). 0 with the default offset (the origin).
std::array<double, 3> position_shift(const point_cloud& cloud, const las_write_options& opt) {
  std::array<double, 3> d{0, 0, 0};
  if (opt.offset)
    for (std::size_t k = 0; k < 3; ++k) d[k] = (*opt.offset)[k] - cloud.origin()[k];
  return d;
}

/// What a LAS header says of the points: their number, the bounding box of
/// their positions as LAS integers (relative to the origin), the number of
/// points by return number (1 to 15).
struct las_stats {
  std::uint64_t n = 0;
  double qmin[3] = {0, 0, 0}, qmax[3] = {0, 0, 0};
  std::array<std::uint64_t, 15> by_return{};
};

/// Adds `cloud`'s points to `s`; std::invalid_argument when a position is
/// not finite or does not fit (points numbered from s.n; the first such
/// point). Chunks of points are checked in parallel and merged in order: the
/// same bounds and error as one pass.
void add_stats(const point_cloud& cloud, const las_write_options& opt, const las_plan& plan, las_stats& s) {
  const float* xyz = cloud.positions().data();
  const std::array<double, 3> shift = position_shift(cloud, opt);
  constexpr std::size_t chunk = 65536;
  const std::size_t chunks = (cloud.size() + chunk - 1) / chunk;
  struct chunk_stats {
    double qmin[3], qmax[3];
    std::string error;  ///< its first point's that cannot be stored
  };
  std::vector<chunk_stats> part(chunks);
  ced::detail::parallel_for(chunks, 0, 1, [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c) {
      const std::size_t b = c * chunk, e = std::min(cloud.size(), b + chunk);
      double qmin[3], qmax[3];  // here, not in part[c]: chunks side by side share cache lines
      for (std::size_t i = b; i < e; ++i)
        for (std::size_t k = 0; k < 3; ++k) {
          const float p = xyz[3 * i + k];
          if (!std::isfinite(p)) {
            part[c].error = "point " + std::to_string(s.n + i) + " has a non-finite coordinate; LAS cannot store it";
            return;
          }
          const double q = std::round((static_cast<double>(p) - shift[k]) / opt.scale[k]);
          if (q < std::numeric_limits<std::int32_t>::min() || q > std::numeric_limits<std::int32_t>::max()) {
            part[c].error = "point " + std::to_string(s.n + i) + ": coordinate " + num(p) +
                            " (relative to the origin) does not fit a 32-bit LAS integer at scale " +
                            num(opt.scale[k]) + (opt.offset ? " and offset " + num((*opt.offset)[k]) : "") +
                            " (choose a coarser scale)";
            return;
          }
          qmin[k] = i == b ? q : std::min(qmin[k], q);
          qmax[k] = i == b ? q : std::max(qmax[k], q);
        }
      std::copy_n(qmin, 3, part[c].qmin);
      std::copy_n(qmax, 3, part[c].qmax);
    }
  });
  for (std::size_t c = 0; c < chunks; ++c) {
    if (!part[c].error.empty()) throw std::invalid_argument(part[c].error);
    for (std::size_t k = 0; k < 3; ++k) {
      s.qmin[k] = s.n == 0 && c == 0 ? part[c].qmin[k] : std::min(s.qmin[k], part[c].qmin[k]);
      s.qmax[k] = s.n == 0 && c == 0 ? part[c].qmax[k] : std::max(s.qmax[k], part[c].qmax[k]);
    }
  }
  const unsigned max_return = plan.layout->extended ? 15 : 7;
  if (!plan.return_number)
    s.by_return[0] += cloud.size();
  else
    plan.return_number->values.visit([&](const auto* v, std::size_t n) {
      for (std::size_t i = 0; i < n; ++i) {
        const unsigned r = std::min<unsigned>(convert<std::uint8_t>(static_cast<double>(v[i])), max_return);
        if (r >= 1 && r <= 15) ++s.by_return[r - 1];
      }
    });
  s.n += cloud.size();
}

/// Writes the extra-bytes VLR describing `extras` at h[v...].
void put_extra_bytes_vlr(std::string& h, std::size_t v, const std::vector<const field*>& extras) {
  h.replace(v, k_vlr_header_size,
            detail::vlr_header("LASF_Spec", 4, extras.size() * k_extra_bytes_descriptor_size, "extra bytes"));
  v += k_vlr_header_size;
  for (const field* f : extras) {
    put<std::uint8_t>(h, v + 2, static_cast<std::uint8_t>(extra_type_code(f->type())));
    put_string(h, v + 4, 32, f->name);
    put_string(h, v + 160, 32, "ced field (" + std::string(name_of(f->type())) + ")");
    v += k_extra_bytes_descriptor_size;
  }
}

/// The public header, then the extra-bytes VLR when there are extra bytes.
std::string make_header(const point_cloud& cloud, const las_write_options& opt, const las_plan& plan,
                        const las_stats& s) {
  const std::uint64_t n = s.n;
  const int minor = opt.version_minor;
  const double* qmin = s.qmin;
  const double* qmax = s.qmax;
  const std::array<std::uint64_t, 15>& by_return = s.by_return;
  const std::array<double, 3> offset = header_offset(cloud, opt);
  const std::size_t header_size = header_size_for(minor);
  const std::size_t vlr_size =
      plan.extras.empty() ? 0 : k_vlr_header_size + plan.extras.size() * k_extra_bytes_descriptor_size;
  std::string h(header_size + vlr_size, '\0');
  put_string(h, 0, 4, "LASF");
  // Formats 6-10: the WKT bit must be set. Bit 0: the GPS time type.
  put<std::uint16_t>(h, 6, (plan.layout->extended ? 0x10 : 0) | (opt.adjusted_standard_gps_time ? 1 : 0));
  put<std::uint8_t>(h, 24, 1);
  put<std::uint8_t>(h, 25, static_cast<std::uint8_t>(minor));
  put_string(h, 26, 32, "OTHER");
  put_string(h, 58, 32, "ced " CED_VERSION_STRING);
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
#if defined(_WIN32)
  gmtime_s(&utc, &now);
#else
  gmtime_r(&now, &utc);
#endif
  put<std::uint16_t>(h, 90, static_cast<std::uint16_t>(utc.tm_yday + 1));
  put<std::uint16_t>(h, 92, static_cast<std::uint16_t>(utc.tm_year + 1900));
  put<std::uint16_t>(h, 94, static_cast<std::uint16_t>(header_size));
  put<std::uint32_t>(h, 96, static_cast<std::uint32_t>(header_size + vlr_size));
  put<std::uint32_t>(h, 100, plan.extras.empty() ? 0u : 1u);
  put<std::uint8_t>(h, 104, static_cast<std::uint8_t>(plan.format));
  put<std::uint16_t>(h, 105, static_cast<std::uint16_t>(plan.record));
  const bool legacy_counts = !plan.layout->extended && n <= std::numeric_limits<std::uint32_t>::max();
  if (legacy_counts) {
    put<std::uint32_t>(h, 107, static_cast<std::uint32_t>(n));
    for (std::size_t r = 0; r < 5; ++r) put<std::uint32_t>(h, 111 + 4 * r, static_cast<std::uint32_t>(by_return[r]));
  }
  for (std::size_t k = 0; k < 3; ++k) {
    put<double>(h, 131 + 8 * k, opt.scale[k]);
    put<double>(h, 155 + 8 * k, offset[k]);
    put<double>(h, 179 + 16 * k, n ? offset[k] + qmax[k] * opt.scale[k] : 0.0);
    put<double>(h, 187 + 16 * k, n ? offset[k] + qmin[k] * opt.scale[k] : 0.0);
  }
  if (minor >= 4) {
    put<std::uint64_t>(h, 247, n);
    for (std::size_t r = 0; r < 15; ++r) put<std::uint64_t>(h, 255 + 8 * r, by_return[r]);
  }
  if (!plan.extras.empty()) put_extra_bytes_vlr(h, header_size, plan.extras);
  return h;
}

/// The point records, in chunks encoded in parallel (write_chunks()).
void write_records(std::ostream& out, const point_cloud& cloud, const las_write_options& opt, const las_plan& plan) {
  const std::size_t n = cloud.size();
  const std::size_t record = plan.record;
  const float* xyz = cloud.positions().data();
  const std::array<double, 3> shift = position_shift(cloud, opt);
  constexpr std::size_t chunk = 8192;
  write_chunks(out, (n + chunk - 1) / chunk, [&](std::size_t k, std::string& bytes) {
    const std::size_t i0 = k * chunk, m = std::min(chunk, n - i0);
    bytes.assign(m * record, '\0');
    auto* buf = reinterpret_cast<unsigned char*>(bytes.data());
    for (std::size_t i = 0; i < m; ++i)
      for (std::size_t a = 0; a < 3; ++a) {
        const double q = std::round((static_cast<double>(xyz[3 * (i0 + i) + a]) - shift[a]) / opt.scale[a]);
        store_le<std::int32_t>(buf + i * record + 4 * a, static_cast<std::int32_t>(q));
      }
    for (const auto& c : plan.cols) encode_column(c, i0, m, buf, record);
  });
}

void write_las_unchecked(std::ostream& out, const point_cloud& cloud, const las_write_options& opt) {
  check_writable(cloud, opt, cloud.size());
  const las_plan plan = plan_records(cloud, opt);
  las_stats stats;
  add_stats(cloud, opt, plan, stats);
  const std::string header = make_header(cloud, opt, plan, stats);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  write_records(out, cloud, opt, plan);
}

}  // namespace

point_cloud read_las_buffer(std::string_view bytes, const std::string& name, las_read_info* info,
                            const field_selection& fields) {
  return parse_las(bytes, name, info, fields);
}

point_cloud read_las(const std::string& path, las_read_info* info, const field_selection& fields) {
  return read_las_file(path, info, fields);
}

void write_las(std::ostream& out, const point_cloud& cloud, const las_write_options& options) {
  detail::write_to_stream(out, "LAS", [&](std::ostream& o) { write_las_unchecked(o, cloud, options); });
}

void write_las(const std::string& path, const point_cloud& cloud, const las_write_options& options) {
  detail::write_to_file(path, [&](std::ostream& o) { write_las_unchecked(o, cloud, options); });
}

namespace {
/// True when every position of `cloud` is exact in `scale` and `offset`: its
/// integer, read back as read_las() reads it, gives the same float.
bool positions_exact(const point_cloud& cloud, const std::array<double, 3>& scale,
                     const std::array<double, 3>& offset) {
  double shift[3];
  for (std::size_t k = 0; k < 3; ++k) {
    if (!std::isfinite(scale[k]) || scale[k] <= 0 || !std::isfinite(offset[k])) return false;
    shift[k] = offset[k] - cloud.origin()[k];
  }
  const float* xyz = cloud.positions().data();
  const std::size_t n = cloud.size();
  constexpr std::size_t chunk = 65536;
  std::vector<std::uint8_t> exact((n + chunk - 1) / chunk, 1);
  ced::detail::parallel_for(exact.size(), 0, 1, [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c)
      for (std::size_t i = c * chunk; i < std::min(n, (c + 1) * chunk) && exact[c]; ++i)
        for (std::size_t k = 0; k < 3; ++k) {
          const float p = xyz[3 * i + k];
          const double q = std::round((static_cast<double>(p) - shift[k]) / scale[k]);
          if (!(q >= std::numeric_limits<std::int32_t>::min() && q <= std::numeric_limits<std::int32_t>::max()) ||
              static_cast<float>(static_cast<std::int32_t>(q) * scale[k] + shift[k]) != p) {
            exact[c] = 0;
            break;
          }
        }
  });
  return std::all_of(exact.begin(), exact.end(), [](std::uint8_t e) { return e != 0; });
}

std::string triple(const std::array<double, 3>& v) { return num(v[0]) + ", " + num(v[1]) + ", " + num(v[2]); }
}  // namespace

las_write_options las_write_options_like(const las_read_info& source, const point_cloud& cloud, bool copc,
                                         std::vector<std::string>* changes) {
  const auto note = [&](const std::string& what) {
    if (changes) changes->push_back(what);
  };
  las_write_options o;
  const int minor = source.version_major == 1 ? std::clamp(source.version_minor, 2, 4) : 4;
  if (source.version_major != 1 || source.version_minor != minor)
    note("LAS " + std::to_string(source.version_major) + "." + std::to_string(source.version_minor) +
         " is written as LAS 1." + std::to_string(minor));
  o.version_minor = minor;
  int pf = std::clamp(source.point_format, 0, k_max_format);
  static constexpr int k_no_waveform[k_max_format + 1] = {0, 1, 2, 3, 1, 3, 6, 7, 8, 6, 8};
  if (k_no_waveform[pf] != pf) {
    note("point format " + std::to_string(pf) + " is written as " + std::to_string(k_no_waveform[pf]) +
         ": ced does not keep waveform packets");
    pf = k_no_waveform[pf];
  }
  if (copc && pf < 6) {
    const int to = k_formats[pf].rgb >= 0 ? 7 : 6;
    note("COPC holds LAS 1.4 point formats 6-8: point format " + std::to_string(pf) + " (LAS 1." +
         std::to_string(minor) + ") is written as " + std::to_string(to) +
         " (scan angles in 0.006-degree steps, not whole degrees)");
    pf = to;
  }
  if (pf >= 6 && o.version_minor < 4 && !copc) {  // (COPC said so)
    note("point format " + std::to_string(pf) + " needs LAS 1.4: written as LAS 1.4, not 1." + std::to_string(minor));
    o.version_minor = 4;
  }
  if (copc) o.version_minor = 4;
  o.point_format = pf;
  o.adjusted_standard_gps_time = (source.global_encoding & 1) != 0;
  if (positions_exact(cloud, source.scale, source.offset)) {
    o.scale = source.scale;
    o.offset = source.offset;
    // Floats as far from the origin as the farthest point step by more than
    // the scale: the file's integers were rounded on reading.
    float far[3] = {0, 0, 0};
    const std::vector<float>& xyz = cloud.positions();
    for (std::size_t i = 0; i < xyz.size(); ++i) far[i % 3] = std::max(far[i % 3], std::fabs(xyz[i]));
    for (std::size_t k = 0; k < 3; ++k) {
      const double step = static_cast<double>(std::nextafter(far[k], 2 * far[k]) - far[k]);
      if (far[k] > 0 && step >= source.scale[k])
        note(std::string(1, static_cast<char>('X' + k)) + " positions are floats relative to the origin " +
             num(cloud.origin()[k]) + ": up to " + num(far[k]) + " from it their step, " + num(step) +
             ", is coarser than the scale " + num(source.scale[k]) + ", so the source's integers can move by up to " +
             num(step / 2) + " (a second conversion gives back the first's)");
    }
  } else {
    note("the positions are not on the source's grid (scale " + triple(source.scale) + ", offset " +
         triple(source.offset) + "), as after voxel down-sampling or a transform: they are written at scale " +
         triple(o.scale) + " with the offset at the cloud's origin " + triple(cloud.origin()));
  }
  return o;
}

namespace detail {
namespace {
/// The head of a LAZ file (up to its point data) from a LAS file's head (up
/// to its point data): the LASzip VLR after the VLRs (before any bytes
/// between them and the points), the format byte's compression bit, the
/// point data's offset and the VLR count.
std::string laz_head(std::string_view las_head, const laz_layout& layout) {
  const auto* d = reinterpret_cast<const unsigned char*>(las_head.data());
  const std::uint32_t n_vlrs = load_le<std::uint32_t>(d + 100);
  std::size_t vlr_end = load_le<std::uint16_t>(d + 94);
  for (std::uint32_t i = 0; i < n_vlrs; ++i) vlr_end += k_vlr_header_size + load_le<std::uint16_t>(d + vlr_end + 20);
  const std::string vlr = laszip_vlr(layout);
  std::string out(las_head.substr(0, vlr_end));
  out += vlr;
  out += las_head.substr(vlr_end);
  auto* o = reinterpret_cast<unsigned char*>(out.data());
  store_le<std::uint32_t>(o + 96, static_cast<std::uint32_t>(out.size()));
  store_le<std::uint32_t>(o + 100, n_vlrs + 1);
  o[104] = static_cast<unsigned char>(d[104] | 0x80);
  return out;
}

void append_i64(std::string& s, std::int64_t v) {
  s.append(8, '\0');
  store_le<std::int64_t>(reinterpret_cast<unsigned char*>(s.data()) + s.size() - 8, v);
}

/// LAS in pieces: a header of the right size first, rewritten with the
/// bounds and counts of all the points once they are written.
class las_piece_writer final : public piece_writer {
 public:
  las_piece_writer(std::ostream& out, const point_cloud& layout, std::uint64_t n, const las_write_options& options = {})
      : m_layout(layout), m_opt(options) {
    check_writable(m_layout, m_opt, n);
    const std::string header = make_header(m_layout, m_opt, plan_records(m_layout, m_opt), m_stats);
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
  }
  void write(std::ostream& out, const point_cloud& chunk) override {
    check_writable(chunk, m_opt, m_stats.n + chunk.size());
    const las_plan plan = plan_records(chunk, m_opt);
    add_stats(chunk, m_opt, plan, m_stats);
    write_records(out, chunk, m_opt, plan);
  }
  std::string final_header() override { return make_header(m_layout, m_opt, plan_records(m_layout, m_opt), m_stats); }

 private:
  point_cloud m_layout;
  las_write_options m_opt;
  las_stats m_stats;
};
/// LAZ in pieces: the LAS 1.2 records of a las_piece_writer, coded in chunks
/// of 50,000 points as they fill, the last chunk and the chunk table at the
/// end, then the header again with its bounds and the table's offset: the
/// bytes write_laz() writes for the whole cloud.
class laz_piece_writer final : public piece_writer {
 public:
  laz_piece_writer(std::ostream& out, const point_cloud& layout, std::uint64_t n) {
    las_write_options o;
    o.version_minor = 2;
    std::ostringstream head;
    m_las = std::make_unique<las_piece_writer>(head, layout, n, o);
    const std::string las_head = head.str();
    const auto* d = reinterpret_cast<const unsigned char*>(las_head.data());
    m_layout = pointwise_layout(d[104], load_le<std::uint16_t>(d + 105), k_laz_chunk_points);
    const std::string h = laz_head(las_head, m_layout);
    m_head_size = h.size();
    out.write(h.data(), static_cast<std::streamsize>(h.size()));
    out.write("\0\0\0\0\0\0\0\0", 8);  // the chunk table's offset, known at the end
  }
  void write(std::ostream& out, const point_cloud& chunk) override {
    std::ostringstream records;
    m_las->write(records, chunk);
    m_pending += records.str();
    const std::size_t full = std::size_t(k_laz_chunk_points) * m_layout.record_length;
    std::size_t at = 0;
    for (; m_pending.size() - at >= full; at += full) code(out, m_pending.data() + at, k_laz_chunk_points);
    m_pending.erase(0, at);
  }
  void finish(std::ostream& out) override {
    if (!m_pending.empty())
      code(out, m_pending.data(), static_cast<std::uint32_t>(m_pending.size() / m_layout.record_length));
    m_pending.clear();
    const std::string table = encode_chunk_table(m_points, m_bytes, false);
    out.write(table.data(), static_cast<std::streamsize>(table.size()));
  }
  std::string final_header() override {
    std::string h = laz_head(m_las->final_header(), m_layout);
    std::uint64_t table = m_head_size + 8;
    for (std::uint32_t b : m_bytes) table += b;
    append_i64(h, std::int64_t(table));
    return h;
  }

 private:
  void code(std::ostream& out, const char* records, std::uint32_t points) {
    std::string c;
    encode_laz_chunk(m_layout, reinterpret_cast<const unsigned char*>(records), points, c);
    out.write(c.data(), static_cast<std::streamsize>(c.size()));
    m_points.push_back(points);
    m_bytes.push_back(static_cast<std::uint32_t>(c.size()));
  }

  std::unique_ptr<las_piece_writer> m_las;
  laz_layout m_layout;
  std::size_t m_head_size = 0;
  std::string m_pending;  ///< records of the chunk being filled
  std::vector<std::uint32_t> m_points, m_bytes;
};
/// COPC in pieces: the LAS 1.4 file of a las_piece_writer held in memory,
/// written as COPC at the end (its octree needs every point).
class copc_piece_writer final : public piece_writer {
 public:
  copc_piece_writer(const point_cloud& layout, std::uint64_t n) : m_las(m_buffer, layout, n) {}
  void write(std::ostream&, const point_cloud& chunk) override { m_las.write(m_buffer, chunk); }
  void finish(std::ostream& out) override {
    std::string las = m_buffer.str();
    const std::string header = m_las.final_header();
    las.replace(0, header.size(), header);
    const std::string copc = copc_from_las(las, "the LAS records of the output");
    out.write(copc.data(), static_cast<std::streamsize>(copc.size()));
  }

 private:
  std::ostringstream m_buffer;
  las_piece_writer m_las;
};
}  // namespace

std::unique_ptr<piece_writer> copc_pieces(const point_cloud& layout, std::uint64_t n) {
  return std::make_unique<copc_piece_writer>(layout, n);
}

std::unique_ptr<piece_writer> las_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t n) {
  return std::make_unique<las_piece_writer>(out, layout, n);
}

std::unique_ptr<piece_writer> laz_pieces(std::ostream& out, const point_cloud& layout, std::uint64_t n) {
  return std::make_unique<laz_piece_writer>(out, layout, n);
}

std::string las_point_records(std::string_view bytes, const std::string& name) {
  const auto* d = reinterpret_cast<const unsigned char*>(bytes.data());
  const las_header h = read_header(d, bytes.size(), name);
  laz_layout layout;
  read_vlrs(d, h, name, &layout);
  if (!h.compressed) return std::string(bytes.substr(h.point_offset, h.count * h.record_length));
  const laz_read_fn read = memory_reader(bytes, name);
  const laz_points z = open_laz(h, layout, bytes.size(), read, name);
  const big_bytes records = decode_laz(z, 0, z.chunks.size(), read, name);
  return std::string(records.data(), records.size());
}

las_head read_las_head(std::string_view las, const std::string& name) {
  const auto* d = reinterpret_cast<const unsigned char*>(las.data());
  const las_header h = read_header(d, las.size(), name);
  read_vlrs(d, h, name);
  if (h.compressed) throw std::invalid_argument(name + ": already compressed");
  las_head out;
  out.records = d + h.point_offset;
  out.header_size = h.header_size;
  out.point_offset = h.point_offset;
  out.record_length = h.record_length;
  out.vlrs = h.n_vlrs;
  out.count = h.count;
  if (h.minor >= 4) {
    out.evlr_offset = load_le<std::uint64_t>(d + 235);
    out.evlr_count = load_le<std::uint32_t>(d + 243);
  }
  out.minor = h.minor;
  out.format = h.format;
  out.scale = h.scale;
  out.offset = h.offset;
  return out;
}

std::string laz_from_las(std::string_view las, const std::string& name, std::uint32_t chunk_size,
                         const std::vector<std::uint32_t>& chunk_points) {
  const las_head h = read_las_head(las, name);
  const bool layered = h.format >= 6 && h.format <= 8;
  if (h.format > 3 && !layered)
    throw std::invalid_argument(name + ": LAZ is written for point formats 0-3 and 6-8 only");
  if (h.evlr_offset != 0 || h.evlr_count != 0)
    throw std::invalid_argument(name + ": extended VLRs are not carried into LAZ");
  // Layered chunks (formats 6-8) are variable: chunks of chunk_size points
  // unless chunk_points says otherwise.
  std::vector<std::uint32_t> points = chunk_points;
  if (layered && points.empty() && chunk_size > 0)
    for (std::uint64_t left = h.count; left > 0; left -= points.back())
      points.push_back(static_cast<std::uint32_t>(std::min<std::uint64_t>(left, chunk_size)));
  const bool variable = !points.empty() || layered;
  if (!variable && chunk_size == 0) throw std::invalid_argument("laz_from_las: a chunk size of 0");
  const laz_layout layout = layered ? layered_layout(h.format, h.record_length)
                                    : pointwise_layout(h.format, h.record_length, variable ? 0xFFFFFFFFu : chunk_size);
  // The chunks' points, and their bytes coded in parallel.
  if (!variable)
    for (std::uint64_t left = h.count; left > 0; left -= points.back())
      points.push_back(static_cast<std::uint32_t>(std::min<std::uint64_t>(left, chunk_size)));
  std::vector<std::uint64_t> first(points.size() + 1, 0);
  for (std::size_t i = 0; i < points.size(); ++i) first[i + 1] = first[i] + points[i];
  if (first.back() != h.count) throw std::invalid_argument("laz_from_las: the chunks do not hold the points");
  std::vector<std::string> coded(points.size());
  ced::detail::parallel_for(points.size(), 0, 1, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i)
      encode_laz_chunk(layout, h.records + first[i] * h.record_length, points[i], coded[i]);
  });
  std::vector<std::uint32_t> bytes;
  for (const std::string& c : coded) bytes.push_back(static_cast<std::uint32_t>(c.size()));
  std::string out = laz_head(las.substr(0, h.point_offset), layout);
  std::uint64_t table = out.size() + 8;
  for (const std::string& c : coded) table += c.size();
  append_i64(out, std::int64_t(table));
  for (const std::string& c : coded) out += c;
  out += encode_chunk_table(points, bytes, variable);
  return out;
}

void write_laz(std::ostream& out, const point_cloud& cloud, const las_write_options* options) {
  std::ostringstream las;
  las_write_options o;
  if (options)
    o = *options;
  else
    o.version_minor = 2;
  write_las(las, cloud, o);
  const std::string laz = laz_from_las(las.str(), "the LAS records of the output");
  out.write(laz.data(), static_cast<std::streamsize>(laz.size()));
}

std::string las_details(const las_read_info& info) {
  return std::string(info.compressed ? "LAZ " : "LAS ") + std::to_string(info.version_major) + "." +
         std::to_string(info.version_minor) + ", point format " + std::to_string(info.point_format) +
         (info.copc ? ", COPC" : "");
}
}  // namespace detail

namespace {
/// read_las(), chunk by chunk: the header and VLRs once, then the records.
class las_stream final : public point_stream {
 public:
  las_stream(const std::string& path, const field_selection& fields) : m_file(path), m_fields(fields) {
    const std::string head = read_head(m_file);
    const auto* d = reinterpret_cast<const unsigned char*>(head.data());
    m_header = read_header(d, static_cast<std::size_t>(m_file.size()), path);
    laz_layout layout;
    m_extras = read_vlrs(d, m_header, path, &layout, &m_copc);
    if (m_header.compressed) m_laz = open_laz(m_header, layout, m_file.size(), file_reader(m_file), path);
    las_read_info info;
    fill_info(info, m_header, d);
    info.copc = m_copc.has_value();
    m_details = las_details(info);
  }

  std::size_t read(std::size_t max, const std::array<double, 3>& origin, point_cloud& out) override {
    const std::uint64_t left = m_header.count - m_next;
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(left, max));
    point_cloud last = std::move(out);  // its memory, for this chunk
    out = point_cloud();
    if (n == 0) {
      m_first_pass_done = true;
      return 0;
    }
    const std::size_t stride = m_header.record_length;
    const record_source src =
        m_header.compressed ? window(n) : record_source(m_file, m_header.point_offset + m_next * stride, stride);
    // During the first pass, the chunk's own flags decide its flag fields.
    const unsigned* flag_bits = m_scan.flags;
    record_scan chunk;
    if (!m_first_pass_done) {
      chunk = scan_records(src, n);
      if (m_next == 0) m_scan.any = false;
      m_scan.merge(chunk);
      flag_bits = chunk.flags;
    }
    out = decode_records(src, n, m_header, origin, plan_columns(m_header, m_extras, m_fields, flag_bits),
                         std::move(last));
    m_next += n;
    return n;
  }
  void rewind() override { m_next = 0; }
  std::array<double, 3> origin() const override {
    if (m_header.count == 0) return {0, 0, 0};
    return las_origin(m_scan.lo, m_scan.hi, m_header);
  }
  void bounds(double lo[3], double hi[3]) const override {
    for (std::size_t k = 0; k < 3; ++k) {
      const double a = m_scan.lo[k] * m_header.scale[k] + m_header.offset[k];
      const double b = m_scan.hi[k] * m_header.scale[k] + m_header.offset[k];
      lo[k] = std::min(a, b);
      hi[k] = std::max(a, b);
    }
  }
  std::string details() const override { return m_details; }
  bool streaming() const noexcept override { return true; }
  std::uint64_t declared_points() const noexcept override { return m_header.count; }

  std::optional<std::vector<index_node>> index_nodes() override {
    if (!m_copc) return std::nullopt;
    if (!m_nodes) m_nodes = read_copc_hierarchy(*m_copc, m_file.size(), file_reader(m_file), m_file.path());
    const std::vector<laz_chunk>& chunks = m_laz.chunks;
    std::vector<index_node> out;
    out.reserve(m_nodes->size());
    for (const copc_node& n : *m_nodes) {
      const auto it = std::lower_bound(chunks.begin(), chunks.end(), n.offset,
                                       [](const laz_chunk& c, std::uint64_t o) { return c.offset < o; });
      if (it == chunks.end() || it->offset != n.offset || it->points != std::uint64_t(n.points))
        throw io_error(m_file.path(), "COPC node " + std::to_string(n.depth) + "-" + std::to_string(n.x) + "-" +
                                          std::to_string(n.y) + "-" + std::to_string(n.z) + " (" +
                                          std::to_string(n.points) + " points at byte " + std::to_string(n.offset) +
                                          ") is not a chunk of the chunk table");
      index_node& e = out.emplace_back();
      n.box(*m_copc, e.box.data());
      e.run = {it->first_point, it->points};
    }
    return out;
  }
  std::vector<point_run> chunk_runs() const override {
    std::vector<point_run> out;
    if (m_header.compressed) {
      for (const laz_chunk& c : m_laz.chunks)
        if (c.points > 0) out.push_back({c.first_point, c.points});
      return out;
    }
    return fixed_runs(m_header.count);
  }
  std::vector<std::string> flags_set() const override {
    std::vector<std::string> out;
    for (const flag_spec& fl : flags_of(m_header.layout->extended))
      if ((m_scan.flags[fl.offset - 14] >> fl.shift) & fl.mask) out.push_back(fl.name);
    return out;
  }
  bool header_bounds(double lo[3], double hi[3]) const override {
    double box[6];
    if (!las_header_box(m_header.min.data(), m_header.max.data(), m_header.scale.data(), 0, box)) return false;
    std::copy_n(m_header.min.begin(), 3, lo);
    std::copy_n(m_header.max.begin(), 3, hi);
    return true;
  }
  bool header_box(double growth, double box[6]) const override {
    return las_header_box(m_header.min.data(), m_header.max.data(), m_header.scale.data(), growth, box);
  }

  bool read_points(const std::vector<std::uint64_t>& at, const std::vector<std::string>& fields,
                   const std::array<double, 3>& origin, point_cloud& out) override {
    take_flags(fields);
    if (at.empty()) {
      out = point_cloud();
      return true;
    }
    check_point_indices(at, m_header.count);
    const std::size_t stride = m_header.record_length;
    const std::string gathered =
        m_header.compressed ? gather_compressed(at) : gather_records(m_file, m_header.point_offset, stride, at);
    const record_source src(reinterpret_cast<const unsigned char*>(gathered.data()), stride);
    out = decode_records(src, at.size(), m_header, origin, plan_columns(m_header, m_extras, m_fields, m_scan.flags));
    return true;
  }

  void read_run(const point_run& r, const std::vector<std::string>& fields, const std::array<double, 3>& origin,
                point_cloud& out) override {
    take_flags(fields);
    check_run(r, m_header.count, true);
    m_next = r.first;
    read(static_cast<std::size_t>(r.count), origin, out);
  }

 private:
  /// LAZ: the records at `at` (ascending, in the file), back to back,
  /// decoding only the chunks that hold them (the chunk table says where
  /// each starts), up to 8 consecutive ones at a time, in parallel.
  std::string gather_compressed(const std::vector<std::uint64_t>& at) const {
    const std::vector<laz_chunk>& chunks = m_laz.chunks;
    const std::size_t stride = m_header.record_length, most = 8;
    std::string out(at.size() * stride, '\0');
    const auto end_of = [&](std::size_t c) { return chunks[c].first_point + chunks[c].points; };
    for (std::size_t j = 0; j < at.size();) {
      const std::size_t c0 = chunk_of(at[j]);
      std::size_t c1 = c0 + 1, e = j;
      for (;;) {  // the points of chunks [c0, c1); the next chunk joins when it holds the next point
        while (e < at.size() && at[e] < end_of(c1 - 1)) ++e;
        if (e == at.size() || c1 - c0 == most || chunk_of(at[e]) != c1) break;
        ++c1;
      }
      const big_bytes records = decode_laz(m_laz, c0, c1, file_reader(m_file), m_file.path(), wanted_of(m_fields));
      const std::uint64_t first = chunks[c0].first_point;
      for (; j < e; ++j)
        std::memcpy(&out[j * stride], records.data() + static_cast<std::size_t>((at[j] - first) * stride), stride);
    }
    return out;
  }

  /// LAZ: the chunk that holds file point `point`.
  std::size_t chunk_of(std::uint64_t point) const {
    const std::vector<laz_chunk>& chunks = m_laz.chunks;
    const auto it = std::upper_bound(chunks.begin(), chunks.end(), point,
                                     [](std::uint64_t p, const laz_chunk& c) { return p < c.first_point; });
    return static_cast<std::size_t>(it - chunks.begin()) - 1;
  }

  bool take_fields(const std::vector<std::string>& fields) override {
    take_flags(fields);
    return true;
  }

  /// The flags the whole file has, from their names (`fields`), as a
  /// complete pass decides them: the pass is then spent.
  void take_flags(const std::vector<std::string>& fields) {
    record_scan named;
    const format_layout& layout = *m_header.layout;
    for (const std::string& f : fields)
      for (const flag_spec& fl : flags_of(layout.extended))
        if (f == fl.name) named.flags[fl.offset - 14] |= fl.mask << fl.shift;
    m_scan.flags[0] = named.flags[0];
    m_scan.flags[1] = named.flags[1];
    m_first_pass_done = true;
  }

  /// LAZ: the records [m_next, m_next + n) in memory, from the chunks that hold
  /// them, decoded (the last ones are kept for the next call).
  record_source window(std::size_t n) {
    const std::vector<laz_chunk>& chunks = m_laz.chunks;
    const std::size_t stride = m_header.record_length;
    if (m_next < m_window_first || m_next + n > m_window_first + m_window.size() / stride) {
      const std::size_t c0 = chunk_of(m_next), c1 = chunk_of(m_next + n - 1) + 1;
      m_window = decode_laz(m_laz, c0, c1, file_reader(m_file), m_file.path(), wanted_of(m_fields));
      m_window_first = chunks[c0].first_point;
    }
    return {reinterpret_cast<const unsigned char*>(m_window.data()) + (m_next - m_window_first) * stride, stride};
  }

  input_file m_file;
  laz_points m_laz;                               ///< LAZ only
  std::optional<copc_info> m_copc;                ///< COPC only
  std::optional<std::vector<copc_node>> m_nodes;  ///< of the hierarchy, when asked
  big_bytes m_window;
  std::uint64_t m_window_first = 0;
  field_selection m_fields;
  las_header m_header;
  std::vector<extra_desc> m_extras;
  std::string m_details;
  std::uint64_t m_next = 0;
  bool m_first_pass_done = false;
  record_scan m_scan;  ///< of the points read in the first pass: the whole file's, once it is done
};
}  // namespace

std::unique_ptr<point_stream> open_las_stream(const std::string& path, const field_selection& fields) {
  return std::make_unique<las_stream>(path, fields);
}

const std::vector<std::string>& las_flag_fields() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const flag_spec& f : flags_of(true)) out.push_back(f.name);
    return out;  // the legacy formats' flags are among these
  }();
  return names;
}

bool las_header_box(const double min[3], const double max[3], const double scale[3], double growth,
                    double box[6]) noexcept {
  double extent = 0;
  for (std::size_t k = 0; k < 3; ++k) {
    if (!std::isfinite(min[k]) || !std::isfinite(max[k]) || !(min[k] <= max[k])) return false;
    extent = std::max(extent, max[k] - min[k]);
  }
  for (std::size_t k = 0; k < 3; ++k) {
    const double grow = growth * extent + std::fabs(scale[k]);
    box[k] = min[k] - grow;
    box[3 + k] = max[k] + grow;
  }
  return true;
}

}  // namespace ced::io
