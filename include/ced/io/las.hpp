// ced: N-modal CEntroid Distance keypoint detection in point clouds.
// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ced/cloud.hpp"
#include "ced/io/error.hpp"

namespace ced::io {

/// What read_las() found in a file's public header.
struct las_read_info {
  int version_major = 1, version_minor = 2;
  int point_format = 0;  ///< point data record format, 0..10
  std::uint64_t points = 0;
  std::array<double, 3> scale{}, offset{};             ///< X = raw X * scale + offset
  std::string system_identifier, generating_software;  ///< trailing NULs and spaces trimmed
  bool compressed = false;                             ///< LAZ
  bool copc = false;  ///< COPC: a LAZ with a COPC info VLR (an octree index of its chunks)
  /// The header's global encoding; bit 0: gps_time is adjusted standard GPS
  /// time (GPS seconds - 1e9), not GPS week seconds.
  std::uint16_t global_encoding = 0;
  /// The VLRs ced does not read, as "'user id' record id" (a coordinate
  /// system's 'LASF_Projection' 34735 or 2112, ...): no writer carries
  /// them over; and the count of extended VLRs (LAS 1.4), likewise.
  std::vector<std::string> other_vlrs;
  std::uint32_t extended_vlrs = 0;
  /// The coordinate system's VLRs ('LASF_Projection' 2112, OGC WKT, and
  /// 34735–34737, GeoTIFF keys), as "record id:" and their bytes, in file
  /// order; empty when there are none (extended VLRs are not read). Two
  /// files whose strings differ are taken to be in different systems.
  std::string coordinate_system;
};

/// A LAS, LAZ or COPC file's header and VLRs, without its points (io_error
/// naming the file for one that is not such a file).
las_read_info read_las_info(const std::string& path);

/// A name for las_read_info::coordinate_system in messages: the WKT's own
/// name (its first quoted string, e.g. "NAD83 / Oregon GIC Lambert (ft)"),
/// else "GeoTIFF keys #<hash of the keys>", else "none".
std::string coordinate_system_name(const std::string& coordinate_system);

/// Reads an uncompressed LAS file, versions 1.0 to 1.4, point data record
/// formats 0 to 10.
///
/// - Coordinates are raw * scale + offset, in double. When the data extends
///   beyond ±1e4 on some axis (georeferenced data), the cloud's origin is the
///   centre of the data's bounding box rounded to integers, and positions are
///   stored relative to it (millimetres survive for extents up to ~16 km);
///   otherwise the origin is zero. The box is the header's bounds when every
///   point lies within them grown by 1 % (las_header_box), else the points'.
/// - Fields, in this order, when the format has them:
///   intensity (uint16), return_number, number_of_returns (uint8),
///   classification (uint8; the low 5 bits for formats 0-5),
///   scan_angle (int8 "scan angle rank" in whole degrees for formats 0-5;
///   int16 in units of 0.006 degree for formats 6-10), user_data (uint8),
///   point_source_id (uint16), gps_time (float64), red, green, blue, nir (uint16,
///   values as stored: many files keep 8-bit values in these 16-bit fields).
///   Then the one-bit flags synthetic, key_point, withheld, overlap (6-10),
///   scanner_channel (2 bits, 6-10), scan_direction_flag and
///   edge_of_flight_line, as uint8 fields, only when some point has them non-zero.
///   Waveform packet data (formats 4, 5, 9, 10) is skipped.
/// - Extra bytes (the "LASF_Spec" record 4 VLR) become fields named after their
///   descriptors, after the standard ones. Scaled or offset values (options
///   bits 3 and 4) are stored as float64, others keep their type. The
///   deprecated array types 11-30 become 2 or 3 fields name_0, name_1, name_2;
///   type 0 (undocumented bytes) is skipped; no_data/min/max are not applied.
///   A name that is empty or already taken gets a suffix ("extra_3", "intensity_extra").
///   Extended VLRs (EVLRs, LAS 1.4) are not read.
///
/// Throws io_error, naming the file, for anything malformed: no "LASF"
/// signature, unsupported version or point format, LAZ items it does not
/// decode (point formats 4, 5, 9, 10: waveforms) or whose chunks are
/// damaged (a LAZ file is decoded, src/io/laz.hpp), a header or VLR that does not fit, a record
/// length too small for the format or its extra bytes, zero or non-finite
/// scale factors, and more points declared than the file holds (checked
/// before allocating).
///
/// Threading: reentrant (no shared state).
/// With `fields`, only the fields it selects are decoded (the others cost
/// nothing but their bytes in the file).
point_cloud read_las(const std::string& path, las_read_info* info = nullptr, const field_selection& fields = {});
/// Same, from the bytes of a whole LAS file; `name` names it in error messages.
point_cloud read_las_buffer(std::string_view bytes, const std::string& name, las_read_info* info = nullptr,
                            const field_selection& fields = {});

/// The one-bit flag fields read_las() gives only when some point sets them
/// (synthetic, key_point, withheld, overlap, scanner_channel,
/// scan_direction_flag, edge_of_flight_line), as point_stream::read_run()
/// takes their names.
const std::vector<std::string>& las_flag_fields();

/// The box a LAS header's bounds (min, max) vouch for: [min, max] grown on
/// each axis by `growth` times the largest extent and one scale step; false
/// when the bounds are not finite or not ordered. A file whose points all
/// lie in its header's box grown by 1 % takes its origin from the header's
/// bounds (read_las(), streams and tiles alike), so that a tile read through
/// a COPC index, which sees only some points, has the whole file's origin.
bool las_header_box(const double min[3], const double max[3], const double scale[3], double growth,
                    double box[6]) noexcept;

/// Options for write_las().
struct las_write_options {
  las_write_options() = default;
  /// `las_write_options{scale, version_minor}`, as when these were its only members.
  las_write_options(const std::array<double, 3>& scale_, int version_minor_ = 4)
      : scale(scale_), version_minor(version_minor_) {}

  /// Coordinate resolution per axis (> 0). With the default offset (the
  /// cloud's origin), absolute coordinates round-trip to within scale / 2.
  std::array<double, 3> scale{0.001, 0.001, 0.001};
  /// LAS 1.x: 4 writes point formats 6 (no colour), 7 (red/green/blue) or 8
  /// (red/green/blue and nir); 2 or 3 write the legacy formats 0-3 (1 and 3
  /// when a gps_time field is present, 2 and 3 with colour).
  int version_minor = 4;
  /// The header's offsets (X = raw X * scale + offset); unset: the cloud's
  /// origin. Each coordinate is written as round((origin + position -
  /// offset) / scale).
  std::optional<std::array<double, 3>> offset;
  /// The point data record format: 0-3, or 6-8 with version_minor 4 (the
  /// waveform formats 4, 5, 9 and 10 are not written); -1 (the default):
  /// the one version_minor gives, as above. Fields that the format has no
  /// slot for are written as extra bytes.
  int point_format = -1;
  /// Sets bit 0 of the global encoding: gps_time is adjusted standard GPS
  /// time, not seconds of the GPS week.
  bool adjusted_standard_gps_time = false;
};

/// The options that write `cloud`, read by read_las() from a file that
/// `source` describes, back as that file held it: the source's version,
/// point format, scale and offset, so that LAS -> LAS keeps the point
/// records byte for byte (see below for the positions).
///
/// - `copc`: for a COPC file, which holds only LAS 1.4 point formats 6-8:
///   formats 0-5 become 6 or 7 (with colour), 9 and 10 become 6 and 8.
/// - The waveform formats become those without waveform packets (4 -> 1,
///   5 -> 3, 9 -> 6, 10 -> 8; read_las() skips the packets); LAS 1.0 and 1.1
///   are written as 1.2.
/// - The GPS time type (global encoding bit 0) is kept.
/// - The scale and offset are kept when every position is exact in them:
///   when the integer round((origin + position - offset) / scale) reads
///   back as the same float position, as it does for a cloud nothing moved.
///   Otherwise (e.g. voxel centroids) the defaults are kept instead: scale
///   0.001, offset the cloud's origin.
///
/// Each change from the source is described by one line added to `changes`.
/// Positions are floats relative to the cloud's origin, so a file whose
/// scale is finer than a float's resolution there (about 6e-8 times the
/// distance from the origin) cannot give back its own integers: the first
/// write moves them by less than that resolution, and writes after it are
/// stable.
las_write_options las_write_options_like(const las_read_info& source, const point_cloud& cloud, bool copc = false,
                                         std::vector<std::string>* changes = nullptr);

/// Writes `cloud` as uncompressed LAS to `path` atomically (see
/// atomic_output_file), with the smallest point format that holds its fields
/// unless options.point_format says which.
///
/// Fields with a standard LAS name (those read_las() produces; any case, an
/// exact match first; colour as found by find_rgb_fields()) go into their
/// slot, whatever their type: values are rounded and clamped to the slot's
/// range (NaN becomes 0), flags become 1 when non-zero. Colour values are
/// written as they are (uint8 colour is not scaled to 16 bits). scan_angle
/// fields of type int8 are taken as whole degrees, others as 0.006-degree
/// units, and converted to the point format's unit. Missing return numbers are
/// written as 1 of 1. Every other field is written as an extra-bytes field
/// with its own type (no scale/offset).
///
/// Throws io_error on I/O failure and std::invalid_argument for what cannot be
/// written: a field of the wrong size, an extra-bytes field name that is
/// empty, longer than 32 characters or named x/y/z, a non-finite coordinate or
/// origin, a coordinate beyond the int32 range at the chosen scale, an
/// invalid scale, offset, version or point format (for the version), more than 2^32-1 points in LAS 1.2/1.3.
void write_las(const std::string& path, const point_cloud& cloud, const las_write_options& options = {});
/// Same, to a stream opened in binary mode.
void write_las(std::ostream& out, const point_cloud& cloud, const las_write_options& options = {});

}  // namespace ced::io
