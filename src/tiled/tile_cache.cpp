// SPDX-License-Identifier: MIT
// Tiled runs: the tile cache of a run in one process (or of ced-mpi's
// ranks). Pass 2 over the input writes every point into the cache file of
// each tile that reads it (work_dir/cache/t<id>.bin: records.cpp), so that
// each tile is then read from its own file, not from the whole input.
#include "tiled/tile_cache.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <future>
#include <string>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <vector>

#include "ced/io/output_file.hpp"
#include "core/raw_vector.hpp"
#include "tiled/chunks.hpp"
#include "tiled/modalities.hpp"
#include "tiled/planning.hpp"
#include "tiled/records.hpp"
#include "tiled/work_dir.hpp"

namespace ced {

using namespace tiled_detail;

namespace {

/// A tile's records not yet written (the first `used` bytes of `b`, which
/// grows to its capacity once), and the coder of its next record.
struct tile_buffer {
  detail::raw_vector<char> b;
  std::size_t used = 0;
  bool started = false;  ///< its header is in b or in its file
  cache_coder coder;
};

/// Buffers of tile-cache records, one a tile, written out to the tile's
/// file when full (each file starts with its header). The tiles are shared
/// between `shards` (tile id modulo shards), which may fill and write their
/// own tiles' buffers from as many threads. All are written out when they
/// hold more than `budget` bytes between them.
class cache_writer {
 public:
  /// `tiles`: the grid's cells (tile ids are below it). A tile's buffer
  /// grows to budget / tiles bytes (16 KiB, or the budget when smaller, to
  /// 4 MiB), so that they fit the budget together.
  cache_writer(std::string work_dir, std::size_t budget, unsigned shards, std::uint64_t tiles)
      : m_work_dir(std::move(work_dir)), m_budget(budget), m_buffers(shards) {
    m_capacity = std::clamp<std::uint64_t>(budget / std::max<std::uint64_t>(tiles, 1),
                                           std::min<std::uint64_t>(budget, 16 << 10), 4 << 20);
    if (tiles <= (1u << 20)) m_slots.assign(tiles, nullptr);  // else looked up in the maps
  }
  unsigned shards() const noexcept { return unsigned(m_buffers.size()); }
  /// Tile t's buffer, in shard `shard` (t % shards()), with room for n more
  /// bytes at b.data() + used (full ones written out first). Each shard's
  /// thread touches only its own tiles. Returns the bytes written out.
  std::size_t buffer(unsigned shard, std::uint64_t t, std::size_t n, tile_buffer*& out) {
    tile_buffer* tb = m_slots.empty() ? nullptr : m_slots[t];
    if (!tb) {
      tb = &m_buffers[shard][t];  // (elements stay where they are)
      if (!m_slots.empty()) m_slots[t] = tb;
    }
    out = tb;
    std::size_t written = 0;
    if (tb->b.size() - tb->used < n) {
      // Grown up to its capacity (a tile of a few points takes little),
      // then written out when full.
      const std::size_t capacity = std::max(m_capacity, n + tiled_header_bytes);
      if (tb->b.size() < capacity)
        tb->b.resize(std::min(capacity, std::max(2 * tb->b.size(), n + tiled_header_bytes + 256)));
      if (tb->b.size() - tb->used < n) written = write(t, *tb);
      if (!tb->started) {
        const std::string h = tiled_header(cache_kind);
        std::memcpy(tb->b.data(), h.data(), h.size());
        tb->used = h.size();
        tb->started = true;
      }
    }
    return written;
  }
  /// Counts the bytes that a chunk left in the buffers (`added` less
  /// `written` out), and writes them all out when they hold more than the
  /// budget.
  void maybe_flush(std::size_t added, std::size_t written) {
    m_held = m_held + added > written ? m_held + added - written : 0;
    if (m_held > m_budget) flush();
  }
  void flush() {
    std::size_t tiles = 0;
    for (const auto& m : m_buffers) tiles += m.size();
    for (auto& m : m_buffers)
      for (auto& [t, tb] : m) {
        write(t, tb);
        // Released when all tiles' buffers would not fit the budget.
        if (tb.b.capacity() * tiles > m_budget) detail::raw_vector<char>().swap(tb.b);
      }
    m_held = 0;
  }

 private:
  std::size_t write(std::uint64_t t, tile_buffer& tb) {
    if (tb.used == 0) return 0;
    const std::string path = cache_file(m_work_dir, t);
    std::FILE* f = std::fopen(path.c_str(), "ab");
    if (!f) throw io::io_error(path, std::string("cannot write the tile cache: ") + std::strerror(errno));
    const bool ok = std::fwrite(tb.b.data(), 1, tb.used, f) == tb.used;
    if (std::fclose(f) != 0 || !ok) throw io::io_error(path, "cannot write the tile cache (disk full?)");
    const std::size_t n = tb.used;
    tb.used = 0;
    return n;
  }
  std::string m_work_dir;
  std::size_t m_budget, m_capacity, m_held = 0;
  std::vector<std::unordered_map<std::uint64_t, tile_buffer>> m_buffers;
  std::vector<tile_buffer*> m_slots;  ///< by tile id, on grids of up to 2^20 cells
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

/// Where a point of a chunk lies in the grid: its own cell and the cells
/// its halo box meets (c0 to c1); c0[0] < 0: not finite.

/// Runs f(k) for k in [0, n) on n threads (this one included); rethrows the
/// first exception once all are done.
template <class F>
void on_threads(unsigned n, F&& f) {
  std::vector<std::future<void>> others;
  for (unsigned k = 1; k < n; ++k) others.push_back(std::async(std::launch::async, [&f, k] { f(k); }));
  std::exception_ptr error;
  try {
    f(0u);
  } catch (...) {
    error = std::current_exception();
  }
  for (auto& o : others) try {
      o.get();
    } catch (...) {
      if (!error) error = std::current_exception();
    }
  if (error) std::rethrow_exception(error);
}

/// Pass 2: the points of each chunk into the cache of every tile (of
/// `owners`) that reads them, counted per tile. The threads first locate
/// a share of the chunk's points each, then code a shard of the writer's
/// tiles each: a tile's records are those of one thread, in the input's
/// order, so the files are the same for any number of threads.
struct cache_filler {
  const tile_plan& plan;
  const tile_owners& owners;
  tile_counter counts;
  cache_writer writer;
  std::uint64_t file_index = 0, index = 0;
  std::vector<plan_field> tile_fields = {};
  std::vector<column> converted = {};
  /// Per point of the chunk, tile_grid::locate_many's 9 values: its own
  /// tile's coordinates, then the lowest and highest whose halo holds it.
  std::vector<std::int32_t> where = {};

  void add(const point_cloud& c) {
    const field_bytes fields = conform_fields(c, tile_fields, converted);
    const unsigned shards = writer.shards();
    where.resize(9 * c.size());
    on_threads(shards, [&](unsigned k) { locate(c, c.size() * k / shards, c.size() * (k + 1) / shards); });
    std::vector<std::pair<std::size_t, std::size_t>> bytes(shards);  // added, written out
    std::uint64_t finite = 0;
    on_threads(shards, [&](unsigned k) { bytes[k] = code(c, fields, k, k == 0 ? &finite : nullptr); });
    file_index += c.size();
    index += finite;
    std::size_t added = 0, written = 0;
    for (const auto& [a, w] : bytes) added += a, written += w;
    // A chunk at a time: the buffers never hold much more than the budget and a chunk.
    writer.maybe_flush(added, written);
  }

  void locate(const point_cloud& c, std::size_t from, std::size_t to) {
    plan.grid.locate_many(c.positions().data() + 3 * from, to - from, where.data() + 9 * from);
  }

  /// Shard k's records of chunk c; shard 0 also counts the tiles' points and
  /// the chunk's finite points (`finite`). Returns the bytes it added and
  /// those it wrote out.
  std::pair<std::size_t, std::size_t> code(const point_cloud& c, const field_bytes& fields, unsigned k,
                                           std::uint64_t* finite) {
    const tile_grid& g = plan.grid;
    const unsigned shards = writer.shards();
    auto id = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
      return g.tile_id(std::uint64_t(x), std::uint64_t(y), std::uint64_t(z));
    };
    std::uint64_t fi = file_index, idx = index;
    std::size_t added = 0, written = 0, width = 0;
    for (const auto& f : fields) width += f.second;
    for (std::size_t i = 0; i < c.size(); ++i, ++fi) {
      const std::int32_t* own = where.data() + 9 * i;
      const std::int32_t *c0 = own + 3, *c1 = own + 6;
      if (c0[0] < 0) continue;  // not finite
      if (finite) counts.core(id(own[0], own[1], own[2]));
      for (std::int64_t z = c0[2]; z <= c1[2]; ++z)
        for (std::int64_t y = c0[1]; y <= c1[1]; ++y)
          for (std::int64_t x = c0[0]; x <= c1[0]; ++x) {
            const std::uint64_t t = id(x, y, z);
            if (finite) counts.near(t);
            if (t % shards != k || !owners.owns(t)) continue;
            tile_buffer* tb;
            written += writer.buffer(k, t, cache_coder::max_record_bytes(width), tb);
            char* const at = tb->b.data() + tb->used;
            const std::size_t n = std::size_t(tb->coder.write(at, idx, fi, c.positions().data(), fields, i) - at);
            tb->used += n;
            added += n;
          }
      ++idx;
    }
    if (finite) *finite = idx - index;
    return {added, written};
  }
};

}  // namespace

namespace tiled_detail {

std::string cache_file(const std::string& work_dir, std::uint64_t id) {
  return (fs::path(work_dir) / "cache" / ("t" + std::to_string(id) + ".bin")).string();
}

namespace {

/// The cache of `plan` from one pass over `s`: every point into the cache
/// of each tile that reads it; the plan gets the tiles' counts. `scan`,
/// when given, learns the fields' ranges on the way.
void fill_cache(tile_plan& plan, io::point_stream& s, const tiled_run_options& o, const fs::path& dir, bool& announced,
                scan_result* scan) {
  // Small tiles under a large halo: a point lands in many tiles, most of
  // which may own none (the air above the ground). Then the tiles are
  // counted first (one more pass), the plan is reported before anything
  // is written, and only tiles that own points are cached.
  tile_owners owners;
  if (tiles_per_point(plan.grid) > 2) {
    plan.tiles = count_tiles(s, plan, o.progress, nullptr);
    owners = tile_owners(plan);
    if (o.planned && !scan) o.planned(plan);
    announced = !scan;
  }
  // Every point into the cache file of each tile that reads it. The threads
  // locate and code while the next chunk is read: as many as asked, at
  // most 4 (each codes its shard from the whole chunk).
  const unsigned shards = std::min(4u, resolve_threads(o.threads));
  std::size_t budget = std::size_t(64) << 20;
  // The tests' hook: buffers that fill and flush on small clouds.
  if (const char* b = std::getenv("CED_TEST_CACHE_BUDGET"))
    budget = std::max<std::size_t>(1, std::strtoull(b, nullptr, 10));
  cache_filler fill{plan, owners, tile_counter(plan.grid.count()),
                    cache_writer(dir.string(), budget, shards, plan.grid.count())};
  fill.tile_fields = tile_fields_of(plan);
  for_each_chunk(s, plan.origin, [&](const point_cloud& c) {
    if (scan) scan_chunk(c, *scan);
    fill.add(c);
    if (o.progress) o.progress("reading (pass 2: tile cache)", double(fill.file_index) / double(plan.file_points));
  });
  fill.writer.flush();
  plan.tiles = fill.counts.entries();
}

/// After a pass over `s` that filled the cache of a plan made from the
/// header (plan_from_header): true when the whole file's read would take
/// the plan's origin and its points lie in the plan's grid, and then the
/// plan gets what the pass learnt (the flags some point sets, the tile
/// fields' ranges). False: the plan cannot stand.
bool settle_header_plan(tile_plan& plan, const io::point_stream& s, const scan_result& scan) {
  if (s.origin() != plan.origin || scan.file_points != plan.file_points) return false;
  double lo[3], hi[3];
  s.bounds(lo, hi);
  for (std::size_t k = 0; k < 3; ++k) {
    const double g0 = plan.origin[k] + plan.grid.lo[k], g1 = g0 + plan.grid.dims[k] * plan.grid.size;
    if (lo[k] < g0 || hi[k] > g1) return false;
  }
  const std::vector<std::string> set = s.flags_set();
  const auto unset_flag = [&](const std::string& name) {
    return is_las_flag(name) && std::find(set.begin(), set.end(), name) == set.end();
  };
  for (const plan_field& f : tile_fields_of(plan))
    if (unset_flag(f.name)) return false;  // a whole read has no such field: the scanned plan says so
  plan.fields.erase(
      std::remove_if(plan.fields.begin(), plan.fields.end(), [&](const plan_field& f) { return unset_flag(f.name); }),
      plan.fields.end());
  set_ranges(plan.fields, scan);
  return true;
}

}  // namespace

tile_plan build_cache(const tiled_request& request, const tiled_run_options& o, const fs::path& dir, bool& announced) {
  const fs::path plan_path = dir / "plan.json", cache = dir / "cache";
  std::error_code ec;
  fs::create_directories(cache, ec);
  if (ec) throw io::io_error(cache.string(), "cannot create the tile cache directory: " + ec.message());
  // The cache carries only what detection reads (the merge fetches the
  // keypoints' records), read by a stream that decodes only that.
  const auto slim_stream = [&](const tile_plan& p) {
    io::read_options slim = request.read;
    if (p.tile_fields) slim.fields = field_selection::only(*p.tile_fields);
    return io::open_point_stream(request.input, slim);
  };
  // LAS and LAZ: the plan from the header, and one pass, which fills the
  // cache and checks what the header said.
  if (!request.scan && request.memory_limit == 0) {
    auto s = io::open_point_stream(request.input, request.read);
    if (std::optional<tile_plan> plan = plan_from_header(request, *s)) {
      s = slim_stream(*plan);
      scan_result scan;
      fill_cache(*plan, *s, o, dir, announced, &scan);
      if (settle_header_plan(*plan, *s, scan)) {
        sample_fields(*plan, o.progress);
        io::write_text_file_atomic(plan_path.string(), plan->to_json());
        return std::move(*plan);
      }
      clear_tiles(dir);  // the header's bounds were not the points': the passes below
      fs::create_directories(cache, ec);
    }
  }
  auto s = io::open_point_stream(request.input, request.read);
  tile_plan plan = plan_grid(request, *s, o.progress);
  plan.tile_fields = detection_fields(plan);
  if (plan.tile_fields) s = slim_stream(plan);
  fill_cache(plan, *s, o, dir, announced, nullptr);
  sample_fields(plan, o.progress);
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
