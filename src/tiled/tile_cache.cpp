// SPDX-License-Identifier: MIT
// Tiled runs: the tile cache of a run in one process (or of ced-mpi's
// ranks). Pass 2 over the input writes every point into the cache file of
// each tile that reads it (work_dir/cache/t<id>.bin: records.cpp), so that
// each tile is then read from its own file, not from the whole input.
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <vector>

#include "ced/io/output_file.hpp"
#include "tiled/internal.hpp"

namespace ced {

using namespace tiled_detail;

namespace {

/// A tile's records not yet written, and the coder of its next record.
struct tile_buffer {
  std::string b;
  cache_coder coder;
};

/// Buffers of tile-cache records, written out to one file a tile when they
/// hold more than `budget` bytes. Each file starts with its header.
class cache_writer {
 public:
  cache_writer(std::string work_dir, std::size_t budget) : m_work_dir(std::move(work_dir)), m_budget(budget) {}
  tile_buffer& buffer(std::uint64_t t) {
    const auto [it, fresh] = m_buffers.try_emplace(t);
    if (fresh) it->second.b = tiled_header(cache_kind);
    return it->second;
  }
  void maybe_flush(std::size_t bytes_added) {
    m_held += bytes_added;
    if (m_held > m_budget) flush();
  }
  void flush() {
    for (auto& [t, tb] : m_buffers) {
      std::string& b = tb.b;
      if (b.empty()) continue;
      const std::string path = cache_file(m_work_dir, t);
      std::FILE* f = std::fopen(path.c_str(), "ab");
      if (!f) throw io::io_error(path, std::string("cannot write the tile cache: ") + std::strerror(errno));
      const bool ok = std::fwrite(b.data(), 1, b.size(), f) == b.size();
      if (std::fclose(f) != 0 || !ok) throw io::io_error(path, "cannot write the tile cache (disk full?)");
      // Released, so that the buffers of many tiles never hold more than the
      // budget between them (their memory is reused, not faulted in anew:
      // keep_freed_memory()).
      std::string().swap(b);
    }
    m_held = 0;
  }

 private:
  std::string m_work_dir;
  std::size_t m_budget, m_held = 0;
  std::unordered_map<std::uint64_t, tile_buffer> m_buffers;
};

/// About how many tiles read a point: the tile and its halo, per axis, at
/// most the grid's extent.
double tiles_per_point(const tile_grid& g) {
  double n = 1;
  for (std::size_t k = 0; k < 3; ++k) n *= std::min<double>(g.dims[k], (g.size + 2 * g.halo) / g.size);
  return n;
}

/// Which tiles own points (all of them until told).
class tile_owners {
 public:
  tile_owners() = default;
  explicit tile_owners(const tile_plan& p) : m_all(false) {
    for (const auto& t : p.tiles) m_ids.push_back(t.id);  // ascending
  }
  bool owns(std::uint64_t t) const { return m_all || std::binary_search(m_ids.begin(), m_ids.end(), t); }

 private:
  bool m_all = true;
  std::vector<std::uint64_t> m_ids;
};

/// Pass 2: the points of each chunk into the cache of every tile (of
/// `owners`) that reads them, counted per tile.
struct cache_filler {
  const tile_plan& plan;
  const tile_owners& owners;
  tile_counter counts;
  cache_writer writer;
  std::uint64_t file_index = 0, index = 0;

  std::vector<plan_field> tile_fields = tile_fields_of(plan);
  std::vector<column> converted;

  void add(const point_cloud& c) {
    const field_bytes fields = conform_fields(c, tile_fields, converted);
    const tile_grid& g = plan.grid;
    for (std::size_t i = 0; i < c.size(); ++i, ++file_index) {
      const float* q = c.position(i);
      if (!finite3(q)) continue;
      std::int64_t own[3], c0[3], c1[3];
      g.locate(q, own, c0, c1);
      counts.core((std::uint64_t(own[2]) * g.dims[1] + std::uint64_t(own[1])) * g.dims[0] + std::uint64_t(own[0]));
      std::size_t added = 0;
      for (std::int64_t z = c0[2]; z <= c1[2]; ++z)
        for (std::int64_t y = c0[1]; y <= c1[1]; ++y)
          for (std::int64_t x = c0[0]; x <= c1[0]; ++x) {
            const std::uint64_t t = (std::uint64_t(z) * g.dims[1] + std::uint64_t(y)) * g.dims[0] + std::uint64_t(x);
            counts.near(t);
            if (!owners.owns(t)) continue;
            tile_buffer& tb = writer.buffer(t);
            const std::size_t before = tb.b.size();
            tb.coder.append(tb.b, index, file_index, c.positions().data(), fields, i);
            added += tb.b.size() - before;
          }
      writer.maybe_flush(added);  // a point at a time: the buffers never hold much more than their budget
      ++index;
    }
  }
};

}  // namespace

namespace tiled_detail {

std::string cache_file(const std::string& work_dir, std::uint64_t id) {
  return (fs::path(work_dir) / "cache" / ("t" + std::to_string(id) + ".bin")).string();
}

tile_plan build_cache(const tiled_request& request, const tiled_run_options& o, const fs::path& dir, bool& announced) {
  const fs::path plan_path = dir / "plan.json", cache = dir / "cache";
  std::error_code ec;
  fs::create_directories(cache, ec);
  if (ec) throw io::io_error(cache.string(), "cannot create the tile cache directory: " + ec.message());
  auto s = io::open_point_stream(request.input, request.read);
  tile_plan plan = plan_grid(request, *s, o.progress);
  // The cache carries only what detection reads (the merge fetches the
  // keypoints' records), read by a stream that decodes only that.
  plan.tile_fields = detection_fields(plan);
  if (plan.tile_fields) {
    io::read_options slim = request.read;
    slim.fields = field_selection::only(*plan.tile_fields);
    s = io::open_point_stream(request.input, slim);
  }
  // Small tiles under a large halo: a point lands in many tiles, most of
  // which may own none (the air above the ground). Then the tiles are
  // counted first (one more pass), the plan is reported before anything
  // is written, and only tiles that own points are cached.
  tile_owners owners;
  if (tiles_per_point(plan.grid) > 2) {
    plan.tiles = count_tiles(*s, plan, o.progress, nullptr);
    owners = tile_owners(plan);
    if (o.planned) o.planned(plan);
    announced = true;
  }
  // Pass 2: every point into the cache file of each tile that reads it.
  cache_filler fill{plan,
                    owners,
                    tile_counter(plan.grid.count()),
                    cache_writer(dir.string(), std::size_t(64) << 20),
                    0,
                    0,
                    tile_fields_of(plan),
                    {}};
  for_each_chunk(*s, plan.origin, [&](const point_cloud& c) {
    fill.add(c);
    if (o.progress) o.progress("reading (pass 2: tile cache)", double(fill.file_index) / double(plan.file_points));
  });
  fill.writer.flush();
  plan.tiles = fill.counts.entries();
  io::write_text_file_atomic(plan_path.string(), plan.to_json());
  return plan;
}

tile_points load_cached(const tile_plan& plan, const std::string& work_dir, std::uint64_t id) {
  const std::string file = cache_file(work_dir, id);
  const std::string bytes = io::detail::read_whole_file(file);
  check_tiled_header(bytes.data(), bytes.size(), bytes.size(), cache_kind, file);
  return points_from_cache(plan, id, static_cast<std::size_t>(plan.tile(id).points), bytes, tiled_header_bytes, file);
}

}  // namespace tiled_detail

}  // namespace ced
