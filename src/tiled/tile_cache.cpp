// SPDX-License-Identifier: MIT
// Tiled runs: the tile cache of a run in one process (or of ced-mpi's
// ranks). Pass 2 over the input writes every point into the cache file of
// each tile that reads it (work_dir/cache/t<id>.bin: records.cpp), so that
// each tile is then read from its own file, not from the whole input.
#include "tiled/tile_cache.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <future>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <vector>

#include "ced/io/catalogue.hpp"
#include "ced/io/output_file.hpp"
#include "core/raw_vector.hpp"
#include "tiled/chunks.hpp"
#include "tiled/fingerprint.hpp"
#include "tiled/modalities.hpp"
#include "tiled/plan_file.hpp"
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
  /// `piece`: the files are pieces of the tiles' caches (cache_piece()), of a share of a pass.
  cache_writer(std::string work_dir, std::size_t budget, unsigned shards, std::uint64_t tiles,
               std::optional<unsigned> piece = std::nullopt)
      : m_work_dir(std::move(work_dir)), m_budget(budget), m_piece(piece), m_buffers(shards) {
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
    const std::string path = m_piece ? cache_piece(m_work_dir, t, *m_piece) : cache_file(m_work_dir, t);
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
  std::optional<unsigned> m_piece;
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

std::string cache_piece(const std::string& work_dir, std::uint64_t id, unsigned share) {
  return (fs::path(work_dir) / "cache" / ("t" + std::to_string(id) + "s" + std::to_string(share) + ".bin")).string();
}

void remove_cached(const tile_plan& plan, const std::string& work_dir, std::uint64_t id) {
  std::error_code ec;
  if (plan.cache_shares <= 1) {
    fs::remove(cache_file(work_dir, id), ec);
    return;
  }
  for (unsigned k = 0; k < plan.cache_shares; ++k) fs::remove(cache_piece(work_dir, id, k), ec);
}

namespace {

/// The cache writer of a pass (`piece`: of a share of it). The threads
/// locate and code while the next chunk is read: as many as asked, at most
/// 4 (each codes its shard from the whole chunk).
cache_writer cache_writer_of(const tile_plan& plan, const tiled_run_options& o, const std::string& work_dir,
                             std::optional<unsigned> piece = std::nullopt) {
  std::size_t budget = std::size_t(64) << 20;
  // The tests' hook: buffers that fill and flush on small clouds.
  if (const char* b = std::getenv("CED_TEST_CACHE_BUDGET"))
    budget = std::max<std::size_t>(1, std::strtoull(b, nullptr, 10));
  return cache_writer(work_dir, budget, std::min(4u, resolve_threads(o.threads)), plan.grid.count(), piece);
}

/// The input as the cache reads it: only what detection reads (the merge
/// fetches the keypoints' records), by a stream that decodes only that.
std::unique_ptr<io::point_stream> slim_stream(const tiled_request& request, const tile_plan& p) {
  io::read_options slim = request.read;
  if (p.tile_fields) slim.fields = field_selection::only(*p.tile_fields);
  return io::open_point_stream(request.input, slim);
}

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
  cache_filler fill{plan, owners, tile_counter(plan.grid.count()), cache_writer_of(plan, o, dir.string())};
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
  // LAZ and COPC: their bytes, before the pass that decodes them (tile_plan::bytes_hash).
  const std::string bytes = compressed_input(request.input, request.read) ? bytes_hash_of(request.input) : "";
  std::error_code ec;
  fs::create_directories(cache, ec);
  if (ec) throw io::io_error(cache.string(), "cannot create the tile cache directory: " + ec.message());
  // LAS and LAZ: the plan from the header, and one pass, which fills the
  // cache and checks what the header said.
  if (!request.scan && request.memory_limit == 0) {
    auto s = io::open_point_stream(request.input, request.read);
    if (std::optional<tile_plan> plan = plan_from_header(request, *s)) {
      s = slim_stream(request, *plan);
      scan_result scan;
      fill_cache(*plan, *s, o, dir, announced, &scan);
      if (settle_header_plan(*plan, *s, scan)) {
        sample_fields(*plan, o.progress);
        plan->bytes_hash = bytes;
        io::write_text_file_atomic(plan_path.string(), plan->to_json());
        return std::move(*plan);
      }
      clear_tiles(dir);  // the header's bounds were not the points': the passes below
      fs::create_directories(cache, ec);
    }
  }
  return build_cache_by_passes(request, o, dir, announced, bytes);
}

tile_plan build_cache_by_passes(const tiled_request& request, const tiled_run_options& o, const fs::path& dir,
                                bool& announced, const std::string& bytes) {
  auto s = io::open_point_stream(request.input, request.read);
  tile_plan plan = plan_grid(request, *s, o.progress);
  plan.tile_fields = detection_fields(plan);
  if (plan.tile_fields) s = slim_stream(request, plan);
  fill_cache(plan, *s, o, dir, announced, nullptr);
  sample_fields(plan, o.progress);
  plan.bytes_hash = bytes;
  io::write_text_file_atomic((dir / "plan.json").string(), plan.to_json());
  return plan;
}

std::optional<tile_plan> plan_for_shares(const tiled_request& request, unsigned shares) {
  if (shares < 2 || request.scan || request.memory_limit > 0) return std::nullopt;
  auto s = io::open_point_stream(request.input, request.read);
  std::optional<tile_plan> plan = plan_from_header(request, *s);
  // Runs to share out. (Where one process counts the tiles first, so as to
  // cache only the tiles that own points, the shares cache every tile that
  // reads points, and the others' pieces go once all are counted.)
  if (!plan || s->chunk_runs().empty()) return std::nullopt;
  plan->cache_shares = shares;
  return plan;
}

namespace {

/// The share of the point at `first` of `total` among `shares` blocks of as many points (the last fewer).
unsigned share_of(std::uint64_t first, std::uint64_t total, unsigned shares) {
  const std::uint64_t block = total / shares + (total % shares != 0);
  return static_cast<unsigned>(first / block);
}

}  // namespace

}  // namespace tiled_detail

std::string fill_cache_share(const std::string& begun, unsigned share, const tiled_run_options& o) {
  const tile_plan plan = plan_from_json(begun, "the plan from the headers", false);
  if (share >= plan.cache_shares)
    throw std::invalid_argument("fill_cache_share: share " + std::to_string(share) + " of " +
                                std::to_string(plan.cache_shares));
  auto s = io::open_point_stream(plan.request.input, plan.request.read);
  if (s->declared_points() != plan.file_points)
    throw io::io_error(plan.request.input, "the file changed since the plan was made (" +
                                               std::to_string(s->declared_points()) + " points; the plan says " +
                                               std::to_string(plan.file_points) + ")");
  // LAZ and COPC: its share of the files' bytes, before the pass that decodes them (tile_plan::bytes_hash).
  nlohmann::json file_hashes = nlohmann::json::array();
  if (compressed_input(plan.request.input, plan.request.read)) {
    const std::vector<std::string> files = io::names_catalogue(plan.request.input)
                                               ? io::catalogue_files({plan.request.input})
                                               : std::vector<std::string>{plan.request.input};
    for (std::size_t f = share; f < files.size(); f += plan.cache_shares)
      file_hashes.push_back({f, hex(file_bytes_hash(files[f]))});
  }
  std::vector<io::point_stream::point_run> mine;
  for (const auto& r : s->chunk_runs())
    if (share_of(r.first, plan.file_points, plan.cache_shares) == share) mine.push_back(r);
  // The tile fields, and the flags, which the points decide.
  const std::vector<plan_field> tile_fields = tile_fields_of(plan);
  std::vector<std::string> names, flags;
  for (const plan_field& f : tile_fields) names.push_back(f.name);
  for (const plan_field& f : plan.fields)
    if (is_las_flag(f.name)) {
      flags.push_back(f.name);
      if (std::find(names.begin(), names.end(), f.name) == names.end()) names.push_back(f.name);
    }
  const tile_owners all;
  cache_filler fill{plan, all, tile_counter(plan.grid.count()), cache_writer_of(plan, o, o.work_dir, share)};
  fill.tile_fields = tile_fields;
  scan_result scan;
  std::uint64_t total = 0;
  for (const auto& r : mine) total += r.count;
  float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for_each_run_group(*s, mine, names, plan.origin, [&](const point_cloud& c, std::size_t r0, std::size_t) {
    fill.file_index = fill.index = mine[r0].first;  // (every point of a file planned from its header is finite)
    if (scan.file_points == 0 && c.size() > 0)
      for (std::size_t k = 0; k < 3; ++k) lo[k] = hi[k] = c.position(0)[k];
    scan_chunk(c, scan);
    for (std::size_t i = 0; i < c.size(); ++i)
      for (std::size_t k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], c.position(i)[k]);
        hi[k] = std::max(hi[k], c.position(i)[k]);
      }
    fill.add(c);
    if (o.progress) o.progress("reading (a share of the tile cache)", double(scan.file_points) / double(total));
  });
  fill.writer.flush();
  nlohmann::json j;
  j["share"] = share;
  if (!file_hashes.empty()) j["file_hashes"] = file_hashes;
  j["points"] = scan.file_points;
  if (scan.file_points > 0) j["box"] = {lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]};
  auto& set = j["flags"] = nlohmann::json::array();
  for (const std::string& f : flags) {
    const auto it = scan.ranges.find(f);
    if (it != scan.ranges.end() && it->second.second && it->second.first.hi > 0) set.push_back(f);
  }
  auto& ranges = j["ranges"] = nlohmann::json::object();
  for (const plan_field& f : tile_fields) {
    const auto it = scan.ranges.find(f.name);
    if (it != scan.ranges.end() && it->second.second) ranges[f.name] = {it->second.first.lo, it->second.first.hi};
  }
  auto& tiles = j["tiles"] = nlohmann::json::array();
  const tile_counter& n = fill.counts;
  if (n.dense) {
    for (std::uint64_t t = 0; t < n.all_v.size(); ++t)
      if (n.all_v[t]) tiles.push_back({t, n.core_v[t], n.all_v[t]});
  } else {
    for (const auto& [t, v] : n.sparse) tiles.push_back({t, v.first, v.second});
  }
  return j.dump();
}

tile_plan finish_cache_shares(const std::string& begun, const std::vector<std::string>& learnt,
                              const tiled_run_options& o) {
  tile_plan plan = plan_from_json(begun, "the plan from the headers", false);
  if (learnt.size() != plan.cache_shares)
    throw std::invalid_argument("finish_cache_shares: " + std::to_string(learnt.size()) + " reports of " +
                                std::to_string(plan.cache_shares) + " shares");
  const fs::path dir(o.work_dir);
  std::uint64_t points = 0;
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  bool any = false;
  std::vector<std::string> set;
  std::map<std::string, value_range> ranges;
  std::map<std::uint64_t, std::pair<std::uint64_t, std::uint64_t>> counts;
  std::map<std::size_t, std::uint64_t> file_hashes;
  for (std::size_t k = 0; k < learnt.size(); ++k) {
    const auto j = nlohmann::json::parse(learnt[k]);
    if (j.contains("file_hashes"))
      for (const auto& h : j.at("file_hashes"))
        file_hashes[h.at(0).get<std::size_t>()] = std::stoull(h.at(1).get<std::string>(), nullptr, 16);
    if (j.at("share").get<std::size_t>() != k)
      throw std::invalid_argument("finish_cache_shares: the reports are not in share order");
    points += j.at("points").get<std::uint64_t>();
    if (j.contains("box")) {
      const auto& b = j.at("box");
      for (std::size_t d = 0; d < 3; ++d) {
        const double a = b.at(d).get<double>() + plan.origin[d], z = b.at(3 + d).get<double>() + plan.origin[d];
        lo[d] = any ? std::min(lo[d], a) : a;
        hi[d] = any ? std::max(hi[d], z) : z;
      }
      any = true;
    }
    for (const auto& f : j.at("flags"))
      if (std::find(set.begin(), set.end(), f.get<std::string>()) == set.end()) set.push_back(f.get<std::string>());
    for (const auto& [name, r] : j.at("ranges").items()) {
      const value_range v{r.at(0).get<double>(), r.at(1).get<double>()};
      const auto it = ranges.find(name);
      ranges[name] = it == ranges.end() ? v : value_range{std::min(it->second.lo, v.lo), std::max(it->second.hi, v.hi)};
    }
    for (const auto& t : j.at("tiles")) {
      auto& c = counts[t.at(0).get<std::uint64_t>()];
      c.first += t.at(1).get<std::uint64_t>();
      c.second += t.at(2).get<std::uint64_t>();
    }
  }
  // What a pass of one process checks (settle_header_plan): every point, in
  // the grid and within the headers' bounds grown by 1 % (so that a whole
  // read takes the plan's origin; a margin covers the float positions).
  bool stands = any && points == plan.file_points;
  double box[6];
  stands = stands && io::open_point_stream(plan.request.input, plan.request.read)->header_box(0.01, box);
  for (std::size_t k = 0; stands && k < 3; ++k) {
    const double g0 = plan.origin[k] + plan.grid.lo[k], g1 = g0 + plan.grid.dims[k] * plan.grid.size;
    const double margin = 1e-6 * std::max({std::fabs(box[k] - plan.origin[k]), std::fabs(box[3 + k] - plan.origin[k]),
                                           box[3 + k] - box[k], 1.0});
    stands = lo[k] >= g0 && hi[k] <= g1 && lo[k] >= box[k] + margin && hi[k] <= box[3 + k] - margin;
  }
  const auto unset_flag = [&](const std::string& name) {
    return is_las_flag(name) && std::find(set.begin(), set.end(), name) == set.end();
  };
  for (const plan_field& f : tile_fields_of(plan)) stands = stands && !unset_flag(f.name);
  // LAZ and COPC: the files' bytes as the shares hashed them before their pass (any missing: hashed here).
  std::string bytes;
  if (compressed_input(plan.request.input, plan.request.read)) {
    std::vector<std::uint64_t> hashes;
    for (std::size_t f = 0; file_hashes.count(f); ++f) hashes.push_back(file_hashes.at(f));
    bytes = bytes_hash_of(plan.request.input, hashes);
  }
  std::error_code ec;
  bool announced = false;
  if (!stands) {
    // The headers were not the points': the passes, in this process.
    clear_tiles(dir);
    fs::create_directories(dir / "cache", ec);
    plan = build_cache_by_passes(plan.request, o, dir, announced, bytes);
  } else {
    plan.fields.erase(
        std::remove_if(plan.fields.begin(), plan.fields.end(), [&](const plan_field& f) { return unset_flag(f.name); }),
        plan.fields.end());
    for (plan_field& f : plan.fields)
      if (ranges.count(f.name)) f.range = ranges.at(f.name);  // the tile fields' (as settle_header_plan)
    plan.tiles.clear();
    for (const auto& [t, c] : counts)
      if (c.first)
        plan.tiles.push_back({t, c.first, c.second});
      else
        remove_cached(plan, o.work_dir, t);  // read points, owns none: not a tile of the plan
    sample_fields(plan, o.progress);
    plan.bytes_hash = bytes;
    io::write_text_file_atomic((dir / "plan.json").string(), plan.to_json());
  }
  fs::create_directories(dir / "parts", ec);
  if (ec) throw io::io_error((dir / "parts").string(), "cannot create the parts directory: " + ec.message());
  if (o.planned && !announced) o.planned(plan);
  return plan;
}

namespace tiled_detail {

tile_points load_cached(const tile_plan& plan, const std::string& work_dir, std::uint64_t id) {
  const std::size_t n = static_cast<std::size_t>(plan.tile(id).points);
  if (plan.cache_shares <= 1) {
    const std::string file = cache_file(work_dir, id);
    const std::string bytes = io::detail::read_whole_file(file);
    check_tiled_header(bytes.data(), bytes.size(), bytes.size(), cache_kind, file);
    return points_from_cache(plan, id, n, {bytes}, tiled_header_bytes, file);
  }
  // The pieces of the shares that read points of the tile, in share order.
  std::vector<std::string> pieces;
  std::error_code ec;
  for (unsigned k = 0; k < plan.cache_shares; ++k) {
    const std::string file = cache_piece(work_dir, id, k);
    if (!fs::exists(file, ec)) continue;
    pieces.push_back(io::detail::read_whole_file(file));
    check_tiled_header(pieces.back().data(), pieces.back().size(), pieces.back().size(), cache_kind, file);
  }
  return points_from_cache(plan, id, n, pieces, tiled_header_bytes, cache_piece(work_dir, id, 0));
}

}  // namespace tiled_detail

}  // namespace ced
