// SPDX-License-Identifier: MIT
// Private to src/tiled: the keypoints' whole records, fetched from the input in the last pass (fetch.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <future>
#include <memory>
#include <string>
#include <vector>

#include "ced/io/stream.hpp"
#include "ced/tiled.hpp"
#include "tiled/records.hpp"

namespace ced::tiled_detail {

/// The last pass of a run whose parts carry only the tile fields: the
/// keypoints' whole records, read from the input in one sequential pass (a
/// merge join: the keypoints come in ascending file index), or, when every
/// point is finite and the stream can (LAS, LAZ, binary PCD, PLY of fixed
/// records), only their records, or the LAZ chunks that hold them
/// (point_stream::read_points). Every keypoint's index and position must be
/// the input's, and the input's counts the plan's: else io_error, the input
/// changed since the plan. For the positions alone of a plan with a
/// bytes_hash (LAZ, COPC), the input's bytes are checked against it
/// instead, and the parts' positions taken.
class record_fetcher {
 public:
  /// With `fields` false, the keypoints' positions only (still checked).
  record_fetcher(const tile_plan& plan, bool fields);
  ~record_fetcher();
  record_fetcher(const record_fetcher&) = delete;
  record_fetcher& operator=(const record_fetcher&) = delete;
  /// `c` with every field of the input (or none); c's keypoints follow the previous call's.
  void fetch(tile_part& c);
  /// Reads the rest of the input and checks its counts.
  void finish();

 private:
  bool advance();
  void fetch_records(tile_part& c);
  /// Every point finite (records, or bytes checked): c's keypoints follow
  /// the last call's, lie in the file and have index = file index.
  void check_places(const tile_part& c);
  [[noreturn]] void changed(const std::string& what) const;
  /// changed(): file point `file_index` is not keypoint `index` as detected.
  [[noreturn]] void not_the_keypoint(std::uint64_t file_index, std::uint64_t index) const;
  const tile_plan& m_plan;
  std::unique_ptr<io::point_stream> m_stream;
  bool m_records = false;  ///< reading only the keypoints' records
  /// Positions only, of an input whose bytes are the plan's (tile_plan::bytes_hash): the parts' own.
  bool m_bytes_checked = false;
  std::vector<std::string> m_field_names;  ///< of the plan; none when only positions are fetched
  std::uint64_t m_last = 0;                ///< records: file index past the last keypoint fetched
  point_cloud m_chunk, m_next;
  std::size_t m_next_size = 0;
  std::future<void> m_reading;
  std::uint64_t m_base = 0, m_finite_base = 0;  // of m_chunk's first point
  std::size_t m_scan = 0;                       // m_chunk's points counted in m_finite
  std::uint64_t m_finite = 0;                   // finite points before m_scan
};

/// A sink that hands `to` the chunks with their records fetched by `f`
/// (and, at begin, totals whose keypoints have every field of the plan).
merge_sink fetching_sink(const tile_plan& plan, record_fetcher& f, const merge_sink& to);

}  // namespace ced::tiled_detail
