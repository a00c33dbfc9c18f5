// SPDX-License-Identifier: MIT
// Tiled runs: the keypoints' whole records, fetched from the input in a last
// pass. The tile cache and the parts of a run carry only what detection
// reads (tile_plan::tile_fields); the merge hands its chunks of keypoints,
// in ascending index and so in ascending file index, to a record_fetcher,
// which reads the input once, in order (a merge join), and copies each
// keypoint's record: the same positions and fields a whole run reads.
#include "tiled/fetch.hpp"

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "core/text.hpp"
#include "tiled/chunks.hpp"
#include "tiled/fingerprint.hpp"
#include "tiled/records.hpp"

namespace ced::tiled_detail {

namespace {
/// n records of every field of the plan, with no whole_range: the merge's
/// keypoints, whose ranges are their own.
point_cloud keypoint_records(const tile_plan& plan, std::size_t n) {
  point_cloud c = record_cloud(plan, n);
  for (auto& f : c.fields()) f.whole_range.reset();
  return c;
}
}  // namespace

record_fetcher::record_fetcher(const tile_plan& plan, bool fields) : m_plan(plan) {
  check_plan_input(plan);
  if (!fields && !plan.bytes_hash.empty()) {
    // The same bytes decode to the same points: no decoding to check positions.
    const std::string now = bytes_hash_of(plan.request.input);
    if (now != plan.bytes_hash) changed("its bytes hash to " + now + ", the plan's to " + plan.bytes_hash);
    m_bytes_checked = true;
    return;
  }
  io::read_options read = plan.request.read;
  if (!fields) read.fields = field_selection::only({});
  m_stream = io::open_point_stream(plan.request.input, read);
  if (fields) m_field_names = field_names(plan);
  // Every point finite: a keypoint's index among the finite points is its file index.
  point_cloud none;
  m_records = plan.finite_points == plan.file_points && m_stream->declared_points() == plan.file_points &&
              m_stream->read_points({}, m_field_names, plan.origin, none);
  if (m_records) return;
  m_reading =
      std::async(std::launch::async, [this] { m_next_size = m_stream->read(chunk_points, m_plan.origin, m_next); });
}

record_fetcher::~record_fetcher() {
  if (m_reading.valid()) m_reading.wait();
}

void record_fetcher::changed(const std::string& what) const {
  throw io::io_error(m_plan.request.input,
                     "the file changed since the plan was made (" + what + "): run again without --resume");
}

void record_fetcher::not_the_keypoint(std::uint64_t file_index, std::uint64_t index) const {
  changed("point " + std::to_string(file_index) + " is not the one detected as keypoint " + std::to_string(index));
}

/// The next chunk of the input; false at its end.
bool record_fetcher::advance() {
  for (; m_scan < m_chunk.size(); ++m_scan) m_finite += finite3(m_chunk.position(m_scan));
  m_base += m_chunk.size();
  m_chunk = point_cloud();
  m_scan = 0;
  if (!m_reading.valid()) return false;
  m_reading.get();
  if (m_next_size == 0) return false;
  std::swap(m_chunk, m_next);
  for (const auto& f : m_chunk.fields())
    if (std::none_of(m_plan.fields.begin(), m_plan.fields.end(), [&](const plan_field& p) { return p.name == f.name; }))
      changed("it has a field '" + f.name + "' the plan has not");
  m_reading =
      std::async(std::launch::async, [this] { m_next_size = m_stream->read(chunk_points, m_plan.origin, m_next); });
  return true;
}

void record_fetcher::check_places(const tile_part& c) {
  for (std::size_t j = 0; j < c.index.size(); ++j) {
    if (c.file_index[j] < m_last) changed("keypoints out of order");
    if (c.file_index[j] >= m_plan.file_points)
      changed("it has fewer points than the plan's " + std::to_string(m_plan.file_points));
    if (c.index[j] != c.file_index[j]) not_the_keypoint(c.file_index[j], c.index[j]);
    m_last = c.file_index[j] + 1;
  }
}

void record_fetcher::fetch_records(tile_part& c) {
  if (c.index.empty()) {
    c.keypoints = keypoint_records(m_plan, 0);
    return;
  }
  check_places(c);
  point_cloud read;
  m_stream->read_points(c.file_index, m_field_names, m_plan.origin, read);
  for (std::size_t j = 0; j < c.index.size(); ++j) {
    const float* p = read.position(j);
    if (std::memcmp(p, c.keypoints.position(j), 3 * sizeof(float)) != 0) not_the_keypoint(c.file_index[j], c.index[j]);
  }
  if (m_field_names.empty()) {  // positions only
    c.keypoints = std::move(read);
    return;
  }
  point_cloud full = keypoint_records(m_plan, c.index.size());
  std::vector<column> keep;
  const field_bytes from = conform_fields(read, m_plan.fields, keep);
  std::copy_n(read.positions().data(), 3 * c.index.size(), full.positions().data());
  std::size_t f = 0;
  for (auto& to : full.fields()) {
    const std::size_t w = size_of(to.type());
    std::memcpy(to.values.bytes(), from[f].first, w * c.index.size());
    ++f;
  }
  c.keypoints = std::move(full);
}

void record_fetcher::fetch(tile_part& c) {
  if (m_records) return fetch_records(c);
  if (m_bytes_checked) {
    check_places(c);
    point_cloud at = position_cloud(m_plan, c.index.size());
    std::copy_n(c.keypoints.positions().data(), 3 * c.index.size(), at.positions().data());
    c.keypoints = std::move(at);
    return;
  }
  const bool fields = !m_field_names.empty();
  point_cloud full = fields ? keypoint_records(m_plan, c.index.size()) : position_cloud(m_plan, c.index.size());
  std::vector<column> keep;
  field_bytes from;
  std::vector<std::pair<unsigned char*, std::size_t>> to;
  for (auto& f : full.fields()) to.push_back({f.values.bytes(), size_of(f.type())});
  for (std::size_t j = 0; j < c.index.size(); ++j) {
    const std::uint64_t fi = c.file_index[j];
    if (fi < m_base + m_scan) changed("keypoints out of order");
    while (fi >= m_base + m_chunk.size()) {
      if (!advance()) changed("it has fewer points than the plan's " + std::to_string(m_plan.file_points));
      from.clear();
    }
    const std::size_t i = static_cast<std::size_t>(fi - m_base);
    for (; m_scan < i; ++m_scan) m_finite += finite3(m_chunk.position(m_scan));
    const float* p = m_chunk.position(i);
    if (!finite3(p) || m_finite != c.index[j] || std::memcmp(p, c.keypoints.position(j), 3 * sizeof(float)) != 0)
      not_the_keypoint(fi, c.index[j]);
    if (from.empty() && fields) from = conform_fields(m_chunk, m_plan.fields, keep);
    std::copy_n(p, 3, full.positions().data() + 3 * j);
    for (std::size_t f = 0; f < to.size(); ++f)
      std::memcpy(to[f].first + to[f].second * j, from[f].first + from[f].second * i, to[f].second);
  }
  c.keypoints = std::move(full);
}

void record_fetcher::finish() {
  if (m_records || m_bytes_checked) return;  // the counts are the header's (checked when opened), every point finite
  while (advance()) {
  }
  if (m_base != m_plan.file_points || m_finite != m_plan.finite_points)
    changed(std::to_string(m_base) + " points, " + std::to_string(m_finite) + " finite; the plan says " +
            std::to_string(m_plan.file_points) + ", " + std::to_string(m_plan.finite_points));
}

merge_sink fetching_sink(const tile_plan& plan, record_fetcher& f, const merge_sink& to) {
  merge_sink s;
  s.begin = [&plan, &to](const tile_part& totals, std::uint64_t n) {
    tile_part t = totals;
    t.keypoints = keypoint_records(plan, 0);
    if (to.begin) to.begin(t, n);
  };
  s.chunk = [&f, &to](const tile_part& c) {
    tile_part full = c;
    f.fetch(full);
    if (to.chunk) to.chunk(full);
  };
  return s;
}

}  // namespace ced::tiled_detail
