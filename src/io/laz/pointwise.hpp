// SPDX-License-Identifier: MIT
// Private to src/io: LAZ's pointwise chunks (point formats 0-5): each record
// decoded or encoded item by item from the record before it (chunks.cpp),
// with the items of version 1 (read only: items_v1.hpp) or 2
// (items.hpp).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "io/laz/types.hpp"
#include "io/laz/coder.hpp"
#include "io/laz/items.hpp"
#include "io/laz/items_v1.hpp"

namespace ced::io::detail::laz {

/// The items of one chunk's records (laz_layout's, in record order), each
/// coded from the record before it, starting from the chunk's first record:
/// Point, Time, Rgb and Bytes are the items' coders of one version.
template <class Point, class Time, class Rgb, class Bytes>
class pointwise_items {
 public:
  /// `first`: the chunk's first record, stored as it is.
  pointwise_items(const std::vector<laz_item>& items, const unsigned char* first) : m_point(first) {
    // The items always come in this order (parse_laszip_vlr checks it).
    std::size_t at = items.empty() ? 0 : items[0].size;
    for (std::size_t i = 1; i < items.size(); ++i) {
      if (items[i].type == laz_item::gpstime11) m_time = std::make_unique<Time>(first + (m_time_at = at));
      if (items[i].type == laz_item::rgb12) m_rgb = std::make_unique<Rgb>(first + (m_rgb_at = at));
      if (items[i].type == laz_item::byte) m_extra = std::make_unique<Bytes>(first + (m_extra_at = at), items[i].size);
      at += items[i].size;
    }
  }

  void decode(decoder& d, unsigned char* r) {
    m_point.decode(d, r);
    if (m_time) m_time->decode(d, r + m_time_at);
    if (m_rgb) m_rgb->decode(d, r + m_rgb_at);
    if (m_extra) m_extra->decode(d, r + m_extra_at);
  }
  void encode(encoder& e, const unsigned char* r) {
    m_point.encode(e, r);
    if (m_time) m_time->encode(e, r + m_time_at);
    if (m_rgb) m_rgb->encode(e, r + m_rgb_at);
    if (m_extra) m_extra->encode(e, r + m_extra_at);
  }

 private:
  Point m_point;
  std::unique_ptr<Time> m_time;
  std::unique_ptr<Rgb> m_rgb;
  std::unique_ptr<Bytes> m_extra;
  std::size_t m_time_at = 0, m_rgb_at = 0, m_extra_at = 0;
};

using pointwise_v1 = pointwise_items<point10_v1, gpstime11_v1, rgb12_v1, bytes_v1>;  ///< read only
using pointwise_v2 = pointwise_items<point10_v2, gpstime11_v2, rgb12_v2, bytes_v2>;

/// decode_pointwise() with the items' coders of one version.
template <class Items>
void decode_pointwise_with(const std::vector<laz_item>& items, const unsigned char* p, const unsigned char* end,
                           unsigned char* out, std::size_t stride, std::uint64_t points, bool exact_end) {
  Items coder(items, out);
  decoder d;
  d.start(p, end);
  for (std::uint64_t i = 1; i < points; ++i) coder.decode(d, out + i * stride);
  if (exact_end && d.position() != end)
    throw corrupt(std::to_string(end - d.position()) +
                  " bytes after its last point: it holds more than its points, or it is corrupt");
}

/// Decodes records 1 to points - 1 of a chunk into out (record 0, the first,
/// is already there) from the coded bytes [p, end), with the items' version
/// (1 or 2, the same for all: parse_laszip_vlr checks it). With `exact_end`,
/// the coded bytes must end where the last point does (a chunk of a chunk
/// table: the encoder ends each with the bytes its decoder reads ahead).
inline void decode_pointwise(const std::vector<laz_item>& items, const unsigned char* p, const unsigned char* end,
                             unsigned char* out, std::size_t stride, std::uint64_t points, bool exact_end) {
  if (!items.empty() && items[0].version == 1)
    decode_pointwise_with<pointwise_v1>(items, p, end, out, stride, points, exact_end);
  else
    decode_pointwise_with<pointwise_v2>(items, p, end, out, stride, points, exact_end);
}

/// A chunk of `points` records (`stride` bytes apart from `records`), coded:
/// the first record as it is, then the rest (appended to `out`).
inline void encode_pointwise(const std::vector<laz_item>& items, const unsigned char* records, std::size_t stride,
                             std::uint64_t points, std::string& out) {
  if (points == 0) return;
  out.append(reinterpret_cast<const char*>(records), stride);
  pointwise_v2 coder(items, records);
  encoder e(out);
  for (std::uint64_t i = 1; i < points; ++i) coder.encode(e, records + i * stride);
  e.done();
}

}  // namespace ced::io::detail::laz
