// SPDX-License-Identifier: MIT
// What the parts of the LAS reader and writer share (header.cpp, read.cpp,
// write.cpp, pieces.cpp, stream.cpp): the point formats' layouts, the public
// header and VLRs as read, the columns a selection decodes, the writer's
// plan. Private to src/io/las/.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <iosfwd>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "ced/io/las.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"
#include "io/laz/types.hpp"

namespace ced::io::las_detail {

using namespace ced::io::detail;  // scalar_io.hpp, records.hpp, laz/types.hpp

// ---------------------------------------------------------------- utilities

inline std::string fixed_string(const unsigned char* p, std::size_t n) {
  std::size_t len = 0;
  while (len < n && p[len] != 0) ++len;
  std::string s(reinterpret_cast<const char*>(p), len);
  const auto b = s.find_first_not_of(' ');
  if (b == std::string::npos) return {};
  return s.substr(b, s.find_last_not_of(' ') - b + 1);
}

inline std::string num(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

// ------------------------------------------------------------------- layout

inline constexpr std::size_t k_vlr_header_size = 54;
inline constexpr std::size_t k_extra_bytes_descriptor_size = 192;
inline constexpr int k_max_format = 10;

struct format_layout {
  std::size_t min_size;  ///< bytes of the standard fields
  bool extended;         ///< formats 6-10 (LAS 1.4 layout)
  int gps;               ///< byte offset of gps_time, or -1
  int rgb;               ///< byte offset of red (green, blue follow), or -1
  int nir;               ///< byte offset of nir, or -1
};

inline constexpr format_layout k_formats[k_max_format + 1] = {
    {20, false, -1, -1, -1}, {28, false, 20, -1, -1}, {26, false, -1, 20, -1}, {34, false, 20, 28, -1},
    {57, false, 20, -1, -1}, {63, false, 20, 28, -1}, {30, true, 22, -1, -1},  {36, true, 22, 30, -1},
    {38, true, 22, 30, 36},  {59, true, 22, -1, -1},  {67, true, 22, 30, 36}};

inline std::size_t header_size_for(int version_minor) noexcept {
  return version_minor >= 4 ? 375 : version_minor == 3 ? 235 : 227;
}

/// Extra-bytes data types 1..10 (the deprecated arrays 11..30 repeat them).
inline constexpr scalar_type k_extra_types[10] = {
    scalar_type::uint8, scalar_type::int8,   scalar_type::uint16, scalar_type::int16,   scalar_type::uint32,
    scalar_type::int32, scalar_type::uint64, scalar_type::int64,  scalar_type::float32, scalar_type::float64};

inline int extra_type_code(scalar_type t) noexcept {
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

std::vector<extra_desc> parse_extra_bytes(const unsigned char* p, std::size_t len, const std::string& file);

/// The bitwise OR of the byte at p + i * stride over all i < n.
inline unsigned or_of_bytes(const unsigned char* p, std::size_t stride, std::size_t n) noexcept {
  unsigned bits = 0;
  for (std::size_t i = 0; i < n; ++i) bits |= p[i * stride];
  return bits;
}

/// `name`, or `name` with a suffix when the cloud already has such a field.
/// `taken` holds every field name of the file so far, selected or not, so
/// that a field's name never depends on the selection.
std::string unique_name(std::vector<std::string>& taken, std::string name, std::size_t index);

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

/// The raw integer bounds of the n point records (`stride` bytes apart from
/// base), merged into lo/hi (`any`: they already hold some points').
inline void raw_bounds(const unsigned char* base, std::size_t stride, std::size_t n, std::int32_t lo[3],
                       std::int32_t hi[3], bool any) noexcept {
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

/// A LAZ file's compression and chunks.
struct laz_points {
  laz_layout layout;
  std::vector<laz_chunk> chunks;
};

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

template <class T>
inline void put(std::string& s, std::size_t offset, T v) {
  store_le<T>(reinterpret_cast<unsigned char*>(&s[offset]), v);
}

inline void put_string(std::string& s, std::size_t offset, std::size_t width, const std::string& text) {
  std::memcpy(&s[offset], text.data(), std::min(width, text.size()));
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

/// What a LAS header says of the points: their number, the bounding box of
/// their positions as LAS integers (relative to the origin), the number of
/// points by return number (1 to 15).
struct las_stats {
  std::uint64_t n = 0;
  double qmin[3] = {0, 0, 0}, qmax[3] = {0, 0, 0};
  std::array<std::uint64_t, 15> by_return{};
};

// Defined in header.cpp, read.cpp and write.cpp.
void read_scale_and_offset(const unsigned char* d, las_header& h, const std::string& file);
las_header read_header(const unsigned char* d, std::size_t size, const std::string& file);
std::vector<extra_desc> read_vlrs(const unsigned char* d, const las_header& h, const std::string& file,
                                  laz_layout* laz = nullptr, std::optional<copc_info>* copc = nullptr,
                                  std::vector<std::string>* others = nullptr, std::string* coordinate_system = nullptr);
void fill_info(las_read_info& info, const las_header& h, const unsigned char* d);
std::array<double, 3> las_origin(const std::int32_t lo[3], const std::int32_t hi[3], const las_header& h);
record_scan scan_records(const record_source& src, std::uint64_t n);
std::vector<flag_spec> flags_of(bool extended);
void plan_flags(column_planner& plan, bool extended);
void plan_standard_fields(column_planner& plan, const format_layout& layout);
void plan_extra_fields(column_planner& plan, const std::vector<extra_desc>& extras);
std::vector<las_column> plan_columns(const las_header& h, const std::vector<extra_desc>& extras,
                                     const field_selection& selection, const unsigned flag_bits[2]);
void decode_las_column(const las_column& c, const unsigned char* p, std::size_t stride, std::size_t m,
                       unsigned char* out);
void decode_positions(const unsigned char* p, std::size_t stride, std::size_t m, const las_header& h,
                      const std::array<double, 3>& origin, float* out) noexcept;
point_cloud decode_records(const record_source& src, std::uint64_t count, const las_header& h,
                           const std::array<double, 3>& origin, const std::vector<las_column>& plan,
                           point_cloud&& reuse = {});
point_cloud read_records(const record_source& src, const las_header& h, const std::vector<extra_desc>& extras,
                         const field_selection& selection);
std::string read_head(input_file& file);
laz_read_fn memory_reader(std::string_view bytes, const std::string& file);
laz_read_fn file_reader(const input_file& file);
laz_points open_laz(const las_header& h, const laz_layout& layout, std::uint64_t size, const laz_read_fn& read,
                    const std::string& file);
laz_wanted wanted_of(const field_selection& s);
big_bytes decode_laz(const laz_points& z, std::size_t c0, std::size_t c1, const laz_read_fn& read,
                     const std::string& file, const laz_wanted& wanted = {});
point_cloud read_las_records(const unsigned char* d, const las_header& h, std::uint64_t size, const laz_read_fn& read,
                             const record_source& plain, const std::string& file, las_read_info* info,
                             const field_selection& selection);
point_cloud parse_las(std::string_view bytes, const std::string& file, las_read_info* info,
                      const field_selection& selection);
point_cloud read_las_file(const std::string& path, las_read_info* info, const field_selection& selection);
std::vector<slot_spec> standard_slots(const format_layout& layout);
void encode_column(const out_column& c, std::size_t i0, std::size_t m, unsigned char* buf, std::size_t record);
void check_writable(const point_cloud& cloud, const las_write_options& opt, std::uint64_t n);
double slot_factor(const field& f, const slot_spec& s, bool extended);
void plan_standard_columns(const point_cloud& cloud, const std::array<const field*, 3>& rgb, const field* nir,
                           las_plan& plan, std::vector<const field*>& used);
void plan_extra_columns(const point_cloud& cloud, las_plan& plan, const std::vector<const field*>& used);
las_plan plan_records(const point_cloud& cloud, const las_write_options& opt);
std::array<double, 3> header_offset(const point_cloud& cloud, const las_write_options& opt);
std::array<double, 3> position_shift(const point_cloud& cloud, const las_write_options& opt);
void add_stats(const point_cloud& cloud, const las_write_options& opt, const las_plan& plan, las_stats& s);
void put_extra_bytes_vlr(std::string& h, std::size_t v, const std::vector<const field*>& extras);
std::string make_header(const point_cloud& cloud, const las_write_options& opt, const las_plan& plan,
                        const las_stats& s);
void write_records(std::ostream& out, const point_cloud& cloud, const las_write_options& opt, const las_plan& plan);
void write_las_unchecked(std::ostream& out, const point_cloud& cloud, const las_write_options& opt);

}  // namespace ced::io::las_detail

namespace ced::io::detail {
/// read_report::details of a LAS file ("LAS 1.4, point format 6").
std::string las_details(const las_read_info& info);
}  // namespace ced::io::detail
