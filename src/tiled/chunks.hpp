// SPDX-License-Identifier: MIT
// Private to src/tiled: chunks of the input, read on a second thread while the caller works on the last (planning,
// sizing, detect_tile, tile_cache, fetch).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <future>
#include <string>
#include <vector>

#include "ced/io/stream.hpp"

namespace ced::tiled_detail {

constexpr std::size_t chunk_points = std::size_t(1) << 20;

inline bool finite3(const float* p) noexcept {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

/// Reads `s` chunk by chunk (positions relative to `origin`) and calls
/// f(chunk) for each, in order: a thread reads and decodes the next chunk
/// while f works on this one. An exception of either is rethrown here.
template <class F>
void for_each_chunk(io::point_stream& s, const std::array<double, 3>& origin, F&& f) {
  point_cloud chunks[2];
  std::size_t got[2] = {0, 0};
  got[0] = s.read(chunk_points, origin, chunks[0]);
  for (int k = 0; got[k] > 0; k ^= 1) {
    auto next = std::async(std::launch::async, [&, k] { got[k ^ 1] = s.read(chunk_points, origin, chunks[k ^ 1]); });
    try {
      f(static_cast<const point_cloud&>(chunks[k]));
    } catch (...) {
      next.wait();
      throw;
    }
    next.get();
  }
}

/// Reads the runs `runs` of `s` (ascending and apart), those next to each
/// other joined into one read of up to chunk_points points (at least one
/// run), with the fields `fields` names (as point_stream::read_run()), and
/// calls f(cloud, r0, r1) for each read: `cloud` holds runs [r0, r1) back to
/// back. A thread reads the next while f works on this one.
template <class F>
void for_each_run_group(io::point_stream& s, const std::vector<io::point_stream::point_run>& runs,
                        const std::vector<std::string>& fields, const std::array<double, 3>& origin, F&& f) {
  const auto group_end = [&](std::size_t r0) {
    std::size_t r1 = r0 + 1;
    std::uint64_t n = runs[r0].count;
    while (r1 < runs.size() && runs[r1].first == runs[r1 - 1].first + runs[r1 - 1].count &&
           n + runs[r1].count <= chunk_points)
      n += runs[r1++].count;
    return r1;
  };
  const auto read = [&](std::size_t r0, std::size_t r1, point_cloud& out) {
    const std::uint64_t end = runs[r1 - 1].first + runs[r1 - 1].count;
    s.read_run({runs[r0].first, end - runs[r0].first}, fields, origin, out);
  };
  if (runs.empty()) return;
  point_cloud clouds[2];
  std::size_t r0 = 0, r1 = group_end(0);
  read(r0, r1, clouds[0]);
  for (int k = 0;; k ^= 1) {
    const std::size_t n0 = r1, n1 = n0 < runs.size() ? group_end(n0) : n0;
    std::future<void> next;
    if (n0 < runs.size()) next = std::async(std::launch::async, [&, k, n0, n1] { read(n0, n1, clouds[k ^ 1]); });
    try {
      f(static_cast<const point_cloud&>(clouds[k]), r0, r1);
    } catch (...) {
      if (next.valid()) next.wait();
      throw;
    }
    if (!next.valid()) return;
    next.get();
    r0 = n0;
    r1 = n1;
  }
}

}  // namespace ced::tiled_detail
