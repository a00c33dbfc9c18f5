// SPDX-License-Identifier: MIT
// Tiled runs: the parts of every tile merged into the whole cloud's result,
// in memory (merge_parts) or as a k-way merge of part files streamed into a
// sink (merge_part_files). Each keypoint is checked as it is taken.
#include <algorithm>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <queue>
#include <string>
#include <utility>
#include <vector>

#include "core/ranking.hpp"
#include "tiled/chunks.hpp"
#include "tiled/fetch.hpp"
#include "tiled/modalities.hpp"
#include "tiled/part_file.hpp"
#include "tiled/records.hpp"

namespace ced {

using namespace tiled_detail;
using detail::rank_key;
using detail::stronger;

namespace {

/// Checks one keypoint of tile `tile`'s part as a merge takes it: indices in
/// range and after the previous keypoint's (`last`, none yet: UINT64_MAX),
/// and the position in the tile's core. io_error naming `where` otherwise.
void check_keypoint(const tile_plan& plan, const std::string& where, std::uint64_t tile, std::uint64_t index,
                    std::uint64_t file_index, const float* xyz, std::uint64_t& last) {
  auto bad = [&](const std::string& what) {
    throw io::io_error(where, "not a whole part of this plan: keypoint " + std::to_string(index) + " " + what);
  };
  if (index >= plan.finite_points || file_index >= plan.file_points)
    bad("is out of the input's range (" + std::to_string(plan.finite_points) + " finite points)");
  if (last != std::numeric_limits<std::uint64_t>::max() && index <= last)
    bad(index == last ? "is given twice" : "comes after keypoint " + std::to_string(last));
  if (file_index < index) bad("has a file index below its index");
  if (!finite3(xyz) || plan.grid.tile_of(xyz) != tile) bad("lies outside tile " + std::to_string(tile) + "'s core");
  last = index;
}

/// Throws io_error naming the tiles of the plan that own points and have
/// no part, and a tile given twice.
void check_complete(const tile_plan& plan, const std::vector<std::uint64_t>& tiles) {
  std::map<std::uint64_t, std::size_t> seen;
  for (std::uint64_t t : tiles) {
    plan.tile(t);  // a tile of the plan
    if (++seen[t] > 1) throw io::io_error("tile " + std::to_string(t) + " is given twice");
  }
  std::vector<std::uint64_t> missing;
  for (const auto& t : plan.tiles)
    if (!seen.count(t.id)) missing.push_back(t.id);
  if (!missing.empty()) {
    std::string list;
    for (std::size_t i = 0; i < missing.size() && i < 10; ++i) list += (i ? ", " : "") + std::to_string(missing[i]);
    if (missing.size() > 10) list += ", ...";
    throw io::io_error(std::to_string(missing.size()) + " of the plan's " + std::to_string(plan.tiles.size()) +
                       " tiles have no part: " + list);
  }
}

/// A merge's part before any part is added: the plan's modality names and
/// thresholds, no candidates, no keypoints.
tile_part empty_merge(const tile_plan& plan) {
  tile_part out;
  out.plan = plan.digest();
  const auto modalities = modalities_of(plan.request.modalities);
  name_modalities(plan, modalities, out);
  out.candidates.assign(modalities.size(), 0);
  out.saliency.assign(modalities.size(), {});
  out.keypoints = empty_cloud(plan, 0);
  return out;
}

/// Adds a part's counts (candidates, detection time) to `totals`.
void add_counts(tile_part& totals, const tile_part& part) {
  for (std::size_t k = 0; k < totals.candidates.size(); ++k) totals.candidates[k] += part.candidates[k];
  totals.any_candidates += part.any_candidates;
  totals.detect_ms += part.detect_ms;
}

/// Throws io_error unless `p` is a whole part of `plan`: its digest, its
/// arrays' sizes, its keypoints (check_keypoint()).
void check_part(const tile_plan& plan, const tile_part& out, const tile_part& p) {
  const std::size_t m = out.names.size();
  const std::string where = "the part of tile " + std::to_string(p.tile);
  if (p.plan != out.plan)
    throw io::io_error(where, "it belongs to another plan (plan digest " +
                                  (p.plan.empty() ? std::string("none") : p.plan) + ", expected " + out.plan + ")");
  const std::size_t n = p.index.size();
  const std::vector<plan_field> fields = tile_fields_of(plan);
  bool whole = p.names == out.names && p.saliency.size() == m && p.candidates.size() == m && p.file_index.size() == n &&
               p.rank.size() == n && p.keypoints.size() == n && p.keypoints.fields().size() == fields.size();
  for (std::size_t k = 0; whole && k < m; ++k) whole = p.saliency[k].size() == n;
  for (std::size_t f = 0; whole && f < fields.size(); ++f)
    whole = p.keypoints.fields()[f].name == fields[f].name && p.keypoints.fields()[f].type() == fields[f].type;
  if (!whole) throw io::io_error(where, "its modalities, fields or array sizes differ from the plan's");
  std::uint64_t last = std::numeric_limits<std::uint64_t>::max();
  for (std::size_t j = 0; j < n; ++j)
    check_keypoint(plan, where, p.tile, p.index[j], p.file_index[j], p.keypoints.position(j), last);
}

/// The key of a part record (its index first, its rank last).
rank_key key_of_record(const char* r, std::size_t record_bytes) {
  return {load_le<float>(r + record_bytes - 4), load_le<std::uint64_t>(r)};
}

/// The weakest of the `n` strongest keypoints of the part files (one pass
/// over their records, n keys held): a keypoint is among the n strongest
/// when it does not rank after it. Nothing when there are at most n.
std::optional<rank_key> strongest_cutoff(const tile_plan& plan, const std::vector<std::string>& paths,
                                         const std::string& digest, std::size_t n, std::size_t buffer) {
  std::priority_queue<rank_key, std::vector<rank_key>, decltype(&stronger)> kept(&stronger);  // top: the weakest
  std::uint64_t total = 0;
  for (const auto& path : paths) {
    part_reader reader(path, plan, digest);
    while (const char* r = reader.next(buffer)) {
      ++total;
      const rank_key k = key_of_record(r, reader.record_bytes());
      if (kept.size() < n) {
        kept.push(k);
      } else if (stronger(k, kept.top())) {
        kept.pop();
        kept.push(k);
      }
    }
  }
  if (total <= n) return std::nullopt;
  return kept.top();
}

/// merge_part_files() of parts that carry every field of the plan, or of
/// the keypoints with their tile fields only (fetched after).
void merge_records(const tile_plan& plan, const std::vector<std::string>& paths, const merge_sink& sink,
                   std::size_t memory) {
  const std::string digest = plan.digest();
  std::vector<part_reader> readers;
  readers.reserve(paths.size());
  std::vector<std::uint64_t> tiles;
  for (const auto& path : paths) {
    readers.emplace_back(path, plan, digest);
    tiles.push_back(readers.back().totals.tile);
  }
  check_complete(plan, tiles);
  tile_part totals = empty_merge(plan);
  std::uint64_t all = 0;
  for (const auto& r : readers) {
    add_counts(totals, r.totals);
    all += r.count();
  }
  // --max-keypoints, --keypoint-share: the strongest of all tiles' keypoints,
  // as a whole run keeps (the share of all tiles' candidates).
  const std::size_t limit = keypoint_limit(plan.request.params, totals.any_candidates);
  const std::optional<rank_key> cutoff =
      limit ? strongest_cutoff(plan, paths, digest, limit, std::max<std::size_t>(std::size_t(1) << 16, memory / 4))
            : std::nullopt;
  const std::uint64_t count = cutoff ? limit : all;
  for (auto& f : totals.keypoints.fields()) f.whole_range.reset();
  if (sink.begin) sink.begin(totals, count);
  // A k-way merge by index (the parts' are ascending and disjoint): half the
  // memory for the parts' buffers, half for the chunk handed to the sink.
  const std::size_t record = record_size(plan) + 4 * totals.names.size() + 4;
  const std::size_t buffer = std::max<std::size_t>(record, memory / 2 / std::max<std::size_t>(1, readers.size()));
  const std::size_t chunk_cap = std::max<std::size_t>(1, memory / 2 / record);
  using head = std::pair<std::uint64_t, std::pair<std::size_t, const char*>>;  // index, (part, record)
  std::priority_queue<head, std::vector<head>, std::greater<>> heap;
  auto push = [&](std::size_t i) {
    if (const char* r = readers[i].next(buffer))
      heap.push({load_le<std::uint64_t>(r), {i, r}});
    else
      readers[i].release();
  };
  for (std::size_t i = 0; i < readers.size(); ++i) push(i);
  tile_part chunk = totals;
  std::uint64_t emitted = 0, last = std::numeric_limits<std::uint64_t>::max();
  while (emitted < count) {
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(chunk_cap, count - emitted));
    resize_part(chunk, plan, n);
    for (auto& f : chunk.keypoints.fields()) f.whole_range.reset();
    for (std::size_t j = 0; j < n;) {
      if (heap.empty()) throw io::io_error("the parts changed while they were merged");
      const auto where = heap.top().second;
      heap.pop();
      const std::size_t r = where.first;
      // Every record is checked; one weaker than the cutoff is then dropped.
      const bool kept = !cutoff || !stronger(*cutoff, key_of_record(where.second, readers[r].record_bytes()));
      decode_part_record(where.second, chunk, j);
      check_keypoint(plan, paths[r], readers[r].totals.tile, chunk.index[j], chunk.file_index[j],
                     chunk.keypoints.position(j), last);
      push(r);
      j += kept;
    }
    emitted += n;
    if (sink.chunk) sink.chunk(chunk);
  }
}

}  // namespace

void merge_part_files(const tile_plan& plan, const std::vector<std::string>& paths, const merge_sink& sink,
                      std::size_t memory) {
  if (!plan.tile_fields) return merge_records(plan, paths, sink, memory);
  // The parts carry the tile fields only: the keypoints' records come from
  // the input, in one more pass over it.
  record_fetcher fetch(plan, sink.records);
  merge_records(plan, paths, fetching_sink(plan, fetch, sink), memory);
  fetch.finish();
}

tile_part merge_parts(const tile_plan& plan, std::vector<tile_part> parts) {
  std::vector<std::uint64_t> tiles;
  for (const auto& p : parts) tiles.push_back(p.tile);
  tile_part out = empty_merge(plan);
  const std::size_t m = out.names.size();
  for (const auto& p : parts) check_part(plan, out, p);
  check_complete(plan, tiles);
  // Keypoints of all parts, by index (the parts' are disjoint).
  std::vector<std::pair<std::uint64_t, std::pair<std::size_t, std::size_t>>> order;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    add_counts(out, parts[i]);
    for (std::size_t j = 0; j < parts[i].index.size(); ++j) order.push_back({parts[i].index[j], {i, j}});
  }
  std::sort(order.begin(), order.end());
  for (std::size_t q = 1; q < order.size(); ++q)
    if (order[q].first == order[q - 1].first)
      throw io::io_error("the parts of tiles " + std::to_string(parts[order[q - 1].second.first].tile) + " and " +
                             std::to_string(parts[order[q].second.first].tile),
                         "both have keypoint " + std::to_string(order[q].first) + ": not parts of one plan's run");
  const std::size_t limit = keypoint_limit(plan.request.params, out.any_candidates);
  if (limit && order.size() > limit) {  // the strongest of all tiles' keypoints, still by index
    std::vector<rank_key> keys(order.size());
    for (std::size_t q = 0; q < order.size(); ++q)
      keys[q] = {parts[order[q].second.first].rank[order[q].second.second], order[q].first};
    std::vector<rank_key> sorted = keys;
    std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(limit - 1), sorted.end(), stronger);
    const rank_key cutoff = sorted[limit - 1];
    std::size_t kept = 0;
    for (std::size_t q = 0; q < order.size(); ++q)
      if (!stronger(cutoff, keys[q])) order[kept++] = order[q];
    order.resize(kept);
  }
  out.keypoints = empty_cloud(plan, order.size());
  out.saliency.assign(m, std::vector<float>(order.size()));
  out.rank.resize(order.size());
  for (std::size_t q = 0; q < order.size(); ++q) {
    const auto [i, j] = order[q].second;
    const tile_part& p = parts[i];
    out.index.push_back(p.index[j]);
    out.file_index.push_back(p.file_index[j]);
    copy_points(p.keypoints, j, out.keypoints, q);
    for (std::size_t k = 0; k < m; ++k) out.saliency[k][q] = p.saliency[k][j];
    out.rank[q] = p.rank[j];
  }
  for (auto& f : out.keypoints.fields()) f.whole_range.reset();
  return out;
}

}  // namespace ced
