// SPDX-License-Identifier: MIT
// LAS: the public header, the VLRs and the extra-bytes descriptors as read.
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

std::string unique_name(std::vector<std::string>& taken, std::string name, std::size_t index) {
  if (name.empty()) name = "extra_" + std::to_string(index);
  const auto free = [&](const std::string& c) { return std::find(taken.begin(), taken.end(), c) == taken.end(); };
  std::string candidate = name;
  for (int k = 1; !free(candidate); ++k) candidate = name + "_extra" + (k == 1 ? std::string() : std::to_string(k));
  taken.push_back(candidate);
  return candidate;
}

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
std::vector<extra_desc> read_vlrs(const unsigned char* d, const las_header& h, const std::string& file, laz_layout* laz,
                                  std::optional<copc_info>* copc, std::vector<std::string>* others,
                                  std::string* coordinate_system) {
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
    // The coordinate system: OGC WKT (2112) and GeoTIFF's keys (34735-34737), as stored.
    if (coordinate_system && user_id == "LASF_Projection" &&
        (record_id == 2112 || (record_id >= 34735 && record_id <= 34737))) {
      *coordinate_system += std::to_string(record_id) + ":";
      coordinate_system->append(reinterpret_cast<const char*>(d + pos + k_vlr_header_size), len);
      *coordinate_system += '\n';
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
}  // namespace las_detail

namespace detail {
std::string las_details(const las_read_info& info) {
  return std::string(info.compressed ? "LAZ " : "LAS ") + std::to_string(info.version_major) + "." +
         std::to_string(info.version_minor) + ", point format " + std::to_string(info.point_format) +
         (info.copc ? ", COPC" : "");
}
}  // namespace detail

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
