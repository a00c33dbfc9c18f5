// SPDX-License-Identifier: MIT
// COPC (src/io/laz/copc.cpp, src/io/las/stream.cpp): runs within a box, points read at
// random, plans from the index, the written octree; and LAZ's layered writer.

#include "laz_test_support.hpp"

using namespace laz_test;

namespace {

/// The COPC sample with its info VLR's root page pointed at `offset`, `size`.
std::string copc_with_root(std::uint64_t offset, std::uint64_t size) {
  std::string b = read_bytes(data_path("1.2-with-color.copc.laz"));
  put<std::uint64_t>(b, 375 + 54 + 40, offset);
  put<std::uint64_t>(b, 375 + 54 + 48, size);
  return b;
}

/// The io_error that asking `bytes`' stream for its runs in a box throws.
std::string runs_error(const std::string& bytes) {
  const std::string path = temp_file("copc.laz");
  write_bytes(path, bytes);
  return ced_test::io_error_of([&] {
    const double lo[3] = {-1e300, -1e300, -1e300}, hi[3] = {1e300, 1e300, 1e300};
    (void)ced::io::open_point_stream(path)->runs_within(lo, hi);
  });
}

}  // namespace

TEST(Copc, RunsWithinABoxHoldItsPoints) {
  const std::string path = data_path("1.2-with-color.copc.laz");
  const ced::point_cloud all = ced::io::read_cloud(path);
  const auto s = ced::io::open_point_stream(path);
  // Plain LAS and LAZ have no index.
  const double any_lo[3] = {0, 0, 0}, any_hi[3] = {1, 1, 1};
  EXPECT_FALSE(ced::io::open_point_stream(data_path("autzen_trim.laz"))->runs_within(any_lo, any_hi));
  // A box of a quarter of the cloud: its runs hold every point in it, and fewer than all.
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = 1e300;
    hi[k] = -1e300;
  }
  for (std::size_t i = 0; i < all.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], all.origin()[k] + all.position(i)[k]);
      hi[k] = std::max(hi[k], all.origin()[k] + all.position(i)[k]);
    }
  const double box_lo[3] = {lo[0], lo[1], lo[2]};
  const double box_hi[3] = {(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, hi[2]};
  const auto runs = s->runs_within(box_lo, box_hi);
  ASSERT_TRUE(runs);
  std::vector<char> in_run(all.size(), 0);
  std::uint64_t total = 0, last_end = 0;
  for (const auto& r : *runs) {
    EXPECT_GE(r.first, last_end);  // ascending, apart
    last_end = r.first + r.count;
    total += r.count;
    for (std::uint64_t i = r.first; i < r.first + r.count; ++i) in_run[i] = 1;
  }
  EXPECT_LT(total, all.size());
  std::size_t inside = 0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    bool in = true;
    for (int k = 0; k < 3; ++k) {
      const double v = all.origin()[k] + all.position(i)[k];
      in = in && v >= box_lo[k] && v <= box_hi[k];
    }
    if (!in) continue;
    ++inside;
    EXPECT_TRUE(in_run[i]) << "point " << i << " is in the box but in no run";
  }
  EXPECT_GT(inside, 100u);
  // A run reads as the whole file's points, with the fields the names give.
  std::vector<std::string> names;
  for (const auto& f : all.fields()) names.push_back(f.name);
  ced::point_cloud c;
  const auto& r = runs->back();
  s->read_run(r, names, all.origin(), c);
  ASSERT_EQ(c.size(), r.count);
  ASSERT_EQ(c.fields().size(), all.fields().size());
  for (std::size_t i = 0; i < c.size(); ++i)
    for (int k = 0; k < 3; ++k) ASSERT_EQ(c.position(i)[k], all.position(r.first + i)[k]);
}

TEST(Las, PointsReadAtRandomAreTheWholeFilesPoints) {
  // LAS reads only the records asked, LAZ decodes only the chunks that hold
  // them (the fetch of tiled runs' keypoints); each point as the whole read
  // gives it, the flags named. autzen in chunks of 997 points: runs of
  // neighbouring chunks (decoded 8 at a time) and chunks skipped.
  const std::string small_chunks = temp_file("autzen_997.laz");
  write_bytes(small_chunks,
              ced::io::detail::laz_from_las(read_bytes(data_path("autzen_trim.las")), "autzen_trim.las", 997));
  for (const std::string& path : {data_path("autzen_trim.las"), data_path("1_4_w_evlr.las"), data_path("simple.las"),
                                  data_path("autzen_trim.laz"), data_path("1_4_w_evlr.laz"), data_path("simple.laz"),
                                  data_path("1.2-with-color.copc.laz"), small_chunks}) {
    SCOPED_TRACE(path);
    const ced::point_cloud all = ced::io::read_cloud(path);
    std::vector<std::string> names;
    for (const auto& f : all.fields()) names.push_back(f.name);
    std::vector<std::uint64_t> at;  // ends, a dense run, gaps of every size
    for (std::uint64_t i = 0; i < all.size(); i += 1 + i / 3) at.push_back(i);
    for (std::uint64_t i :
         {std::uint64_t(all.size() / 2), std::uint64_t(all.size() / 2 + 1), std::uint64_t(all.size() - 1)})
      if (i > at.back()) at.push_back(i);
    auto s = ced::io::open_point_stream(path);
    ced::point_cloud c;
    ASSERT_TRUE(s->read_points(at, names, all.origin(), c));
    ASSERT_EQ(c.size(), at.size());
    ASSERT_EQ(c.fields().size(), all.fields().size());
    for (std::size_t j = 0; j < at.size(); ++j) {
      ASSERT_EQ(0, std::memcmp(c.position(j), all.position(at[j]), 12)) << j;
      for (std::size_t f = 0; f < c.fields().size(); ++f) {
        ASSERT_EQ(c.fields()[f].name, all.fields()[f].name);
        ASSERT_EQ(c.fields()[f].values[j], all.fields()[f].values[at[j]]) << c.fields()[f].name << " " << j;
      }
    }
    // Indices not ascending, or past the points: a caller's bug, refused.
    EXPECT_THROW(ced::io::open_point_stream(path)->read_points({3, 2}, names, all.origin(), c), std::logic_error);
    EXPECT_THROW(ced::io::open_point_stream(path)->read_points({all.size()}, names, all.origin(), c), std::logic_error);
  }
}

TEST(Copc, DamagedHierarchy) {
  const std::string file = read_bytes(data_path("1.2-with-color.copc.laz"));
  EXPECT_CONTAINS(runs_error(copc_with_root(file.size() - 10, 64)), "outside the file");
  EXPECT_CONTAINS(runs_error(copc_with_root(31604, 33)), "not a whole number of 32-byte entries");
  {
    std::string b = copc_with_root(31604, 2080);
    put<std::int32_t>(b, 31604 + 4, 5);  // the root node 0-5-0-0: outside a depth-0 octree
    EXPECT_CONTAINS(runs_error(b), "is outside the octree");
  }
  {
    std::string b = copc_with_root(31604, 2080);
    put<std::uint64_t>(b, 31604 + 16, 100);  // the root node's points at byte 100: no chunk there
    EXPECT_CONTAINS(runs_error(b), "is not a chunk of the chunk table");
  }
  {
    std::string b = copc_with_root(31604, 2080);  // the first entry a child page: the root page itself
    put<std::uint64_t>(b, 31604 + 16, 31604);
    put<std::int32_t>(b, 31604 + 24, 2080);
    put<std::int32_t>(b, 31604 + 28, -1);
    EXPECT_CONTAINS(runs_error(b), "reached twice");
  }
}

namespace {

/// The keypoints (indices) of every tile of `plan` merged.
std::vector<std::uint64_t> merged_keypoints(const ced::tile_plan& plan) {
  std::vector<ced::tile_part> parts;
  for (const auto& t : plan.tiles) parts.push_back(ced::detect_tile(plan, ced::read_tile(plan, t.id)));
  return ced::merge_parts(plan, std::move(parts)).index;
}

/// `file` with its header's bounds on axis k set to [lo, hi].
std::string with_bounds(std::string file, int k, double lo, double hi) {
  put<double>(file, 179 + 16 * std::size_t(k), hi);
  put<double>(file, 187 + 16 * std::size_t(k), lo);
  return file;
}

/// A plan over the COPC file `path` from its index, and the whole run's
/// keypoints; the plan has several tiles.
struct index_plan {
  ced::tiled_request request;
  ced::tile_plan plan;
  std::vector<std::uint64_t> whole;
};
index_plan plan_from_the_index(const std::string& path, const char* preset, double radius, double tile_size) {
  index_plan out;
  ced::detect_params p;
  p.radius = p.nms_radius = radius;
  const auto whole = ced::detect(ced::io::read_cloud(path), p, ced::preset(preset));
  out.whole.assign(whole.keypoints.begin(), whole.keypoints.end());
  out.request.input = path;
  out.request.params = p;
  out.request.modalities = ced::preset_specs(preset);
  out.request.tile_size = tile_size;
  out.plan = ced::plan_tiles(out.request);
  EXPECT_TRUE(out.plan.indexed) << preset;
  EXPECT_GT(out.plan.tiles.size(), 3u);
  EXPECT_FALSE(out.whole.empty());
  return out;
}

}  // namespace

TEST(Copc, PlanFromTheIndexGivesTheWholeResult) {
  const std::string path = data_path("1.2-with-color.copc.laz");
  const ced::point_cloud all = ced::io::read_cloud(path);
  for (const char* preset : {"ced6d", "ced3d"}) {
    index_plan ip = plan_from_the_index(path, preset, 60, 800);
    const ced::tile_plan& plan = ip.plan;
    ced::tiled_request& r = ip.request;
    EXPECT_EQ(plan.file_points, all.size());
    // The plan survives its file, and the tiles read through the index give the whole result.
    const ced::tile_plan again = ced::tile_plan::from_json(plan.to_json(), "plan.json");
    EXPECT_TRUE(again.indexed);
    EXPECT_EQ(merged_keypoints(again), ip.whole) << preset;
    // With scan: a plan by passes over the points (exact counts), the same keypoints.
    r.scan = true;
    const ced::tile_plan scanned = ced::plan_tiles(r);
    EXPECT_FALSE(scanned.indexed);
    EXPECT_EQ(merged_keypoints(scanned), merged_keypoints(plan)) << preset;
    EXPECT_EQ(scanned.origin, plan.origin);
  }
  // A grid of more than 2^20 tiles: planned by the passes, which list only
  // the tiles that own points (a plan from the index would list them all).
  ced::tiled_request fine;
  fine.input = path;
  fine.params.radius = fine.params.nms_radius = 1;
  fine.modalities = ced::preset_specs("ced3d");
  fine.tile_size = 8;
  const ced::tile_plan many = ced::plan_tiles(fine);
  EXPECT_GT(many.grid.count(), std::uint64_t(1) << 20);
  EXPECT_FALSE(many.indexed);
  EXPECT_LE(many.tiles.size(), all.size());
}

TEST(Copc, PlanFromTheIndexTrustsTheHeaderOnlyAsFarAsItHolds) {
  const std::string file = read_bytes(data_path("1.2-with-color.copc.laz"));
  const auto* h = reinterpret_cast<const unsigned char*>(file.data());
  const double lo = load_le<double>(h + 187), hi = load_le<double>(h + 179);
  ced::detect_params p;
  p.radius = p.nms_radius = 60;
  ced::tiled_request r;
  r.params = p;
  r.modalities = ced::preset_specs("ced6d");
  r.tile_size = 800;
  // Bounds looser than the points (by 0.4 % of the extent): the whole read
  // and the plan both take their origin from them, and the tiles are exact.
  {
    const std::string path = temp_file("loose.copc.laz");
    write_bytes(path, with_bounds(file, 0, lo - 0.004 * (hi - lo), hi));
    const ced::point_cloud all = ced::io::read_cloud(path);
    r.input = path;
    const ced::tile_plan plan = ced::plan_tiles(r);
    EXPECT_EQ(plan.origin, all.origin());
    const auto whole = ced::detect(all, p, ced::preset("ced6d"));
    EXPECT_EQ(merged_keypoints(plan), std::vector<std::uint64_t>(whole.keypoints.begin(), whole.keypoints.end()));
  }
  // Bounds that miss points: a tile names the point and says to scan.
  {
    const std::string path = temp_file("tight.copc.laz");
    write_bytes(path, with_bounds(file, 0, lo, hi - 0.1 * (hi - lo)));
    r.input = path;
    const ced::tile_plan plan = ced::plan_tiles(r);
    std::string error;
    for (const auto& t : plan.tiles) {
      error = ced_test::io_error_of([&] { (void)ced::read_tile(plan, t.id); });
      if (!error.empty()) break;
    }
    EXPECT_CONTAINS(error, "lies outside the header's bounds");
    EXPECT_CONTAINS(error, "--scan");
    r.scan = true;  // the passes do not need the header
    const ced::tile_plan scanned = ced::plan_tiles(r);
    const auto whole = ced::detect(ced::io::read_cloud(path), p, ced::preset("ced6d"));
    EXPECT_EQ(merged_keypoints(scanned), std::vector<std::uint64_t>(whole.keypoints.begin(), whole.keypoints.end()));
    r.scan = false;
  }
  // An index that does not hold the header's points.
  {
    std::string b = file;
    put<std::uint32_t>(b, 107, 1064);  // legacy point count one short
    put<std::uint64_t>(b, 247, 1064);  // LAS 1.4 point count
    r.input = temp_file("short.copc.laz");
    write_bytes(r.input, b);
    EXPECT_CONTAINS(ced_test::io_error_of([&] { (void)ced::plan_tiles(r); }), "1064");
  }
}

namespace {

/// The chunks of a LAZ file held in `bytes`, and its layout.
std::vector<ced::io::detail::laz_chunk> chunks_of(const std::string& bytes, ced::io::detail::laz_layout& layout) {
  const auto* d = reinterpret_cast<const unsigned char*>(bytes.data());
  const laz_offsets o = offsets_of(bytes);
  const int format = d[104] & 0x3F;
  const std::size_t record = load_le<std::uint16_t>(d + 105);
  const std::uint64_t count = d[25] >= 4 ? load_le<std::uint64_t>(d + 247) : load_le<std::uint32_t>(d + 107);
  layout = ced::io::detail::parse_laszip_vlr(d + o.vlr, o.vlr_len, format, record, "t.laz");
  const ced::io::detail::laz_read_fn read = [&](std::uint64_t at, std::size_t n, char* out) {
    std::memcpy(out, bytes.data() + at, n);
  };
  return ced::io::detail::laz_chunks(layout, o.points, bytes.size(), count, read, "t.laz");
}

}  // namespace

TEST(LazWriter, LayeredChunksAreThoseOfTheirWriters) {
  // Each layered chunk of files written by LASzip (through laspy and PDAL),
  // re-coded from its decoded records by ced's encoder, byte for byte.
  for (const char* name : {"1_4_w_evlr.laz", "1.2-with-color.copc.laz", "append-bug.laz"}) {
    SCOPED_TRACE(name);
    const std::string bytes = read_bytes(data_path(name));
    ced::io::detail::laz_layout layout;
    const auto chunks = chunks_of(bytes, layout);
    ASSERT_EQ(layout.compressor, 3);
    const std::string records = las_point_records(bytes, name);
    std::size_t same = 0;
    for (const auto& c : chunks) {
      std::string got;
      ced::io::detail::encode_laz_chunk(
          layout, reinterpret_cast<const unsigned char*>(records.data()) + c.first_point * layout.record_length,
          c.points, got);
      if (got == bytes.substr(c.offset, c.bytes))
        ++same;
      else
        ADD_FAILURE() << "chunk at " << c.offset << ": " << got.size() << " bytes, LASzip " << c.bytes;
    }
    EXPECT_EQ(same, chunks.size());
  }
}

namespace {

/// n records of LAS 1.4 point format `format` (6-8) with `extra` extra
/// bytes: every byte random (`mode` 0); scan-like (1: small steps, returns,
/// GPS times in two interleaved lines, switches between scanner channels);
/// or scan-like with every field but the position the same (2: layers of 0
/// bytes).
std::string make_records14(int format, std::size_t extra, std::size_t n, int mode, unsigned seed) {
  const std::size_t stride = (format == 6 ? 30 : format == 7 ? 36 : 38) + extra;
  std::mt19937 rng(seed);
  std::string r(n * stride, '\0');
  for (char& c : r) c = static_cast<char>(rng());
  if (mode == 0) return r;
  std::int32_t xyz[3] = {1000, -2000, 300};
  double line_time[2] = {1e5, 3.7e8};
  const std::string first = r.substr(0, stride);
  for (std::size_t i = 0; i < n; ++i) {
    unsigned char* p = reinterpret_cast<unsigned char*>(&r[i * stride]);
    if (mode == 2) std::memcpy(p, first.data(), stride);
    for (int k = 0; k < 3; ++k) xyz[k] += static_cast<std::int32_t>(rng() % 41) - 20 + (rng() % 97 == 0 ? 100000 : 0);
    std::memcpy(p, xyz, 12);
    if (mode == 2) continue;
    const unsigned returns = 1 + rng() % 5, number = 1 + (rng() % 5 == 0 ? rng() % 15 : rng() % returns);
    p[14] = static_cast<unsigned char>(number | returns << 4);
    const unsigned channel = (i / 37) % 4 == 3 ? unsigned(rng() % 4) : unsigned((i / 37) % 4);
    p[15] = static_cast<unsigned char>((rng() % 7 == 0 ? rng() % 16 : 0) | channel << 4 | (i % 50 == 0 ? 0x80 : 0));
    p[16] = static_cast<unsigned char>(rng() % 6 == 0 ? rng() % 64 : 2);
    const std::int16_t angle = static_cast<std::int16_t>(static_cast<int>(i % 600) - 300);
    std::memcpy(p + 18, &angle, 2);
    const std::uint16_t source = static_cast<std::uint16_t>(i / 400);
    std::memcpy(p + 20, &source, 2);
    const int line = (i / 3) % 2;
    const unsigned step = rng() % 10;
    line_time[line] += step == 0 ? 0.0 : step < 7 ? 1e-5 : step < 9 ? 3e-5 * (rng() % 20) : 1e4;
    double t = line_time[line];
    if (rng() % 211 == 0) t = -t;
    std::memcpy(p + 22, &t, 8);
    if (format >= 7 && rng() % 3 != 0) std::memcpy(p + 30, p - stride + 30 + (i == 0 ? stride : 0), 6);
  }
  return r;
}

}  // namespace

TEST(LazWriter, LayeredRecordsOfAnyBytesRoundTrip) {
  namespace d = ced::io::detail;
  for (int format = 6; format <= 8; ++format)
    for (std::size_t extra : {std::size_t(0), std::size_t(3)})
      for (int mode = 0; mode < 3; ++mode) {
        SCOPED_TRACE("format " + std::to_string(format) + ", extra " + std::to_string(extra) + ", mode " +
                     std::to_string(mode));
        const std::size_t n = 2500;
        const std::string records = make_records14(format, extra, n, mode, unsigned(format * 10 + extra + mode));
        const std::size_t stride = records.size() / n;
        const d::laz_layout layout = d::layered_layout(format, stride);
        for (std::size_t chunk : {std::size_t(1), std::size_t(2), std::size_t(700), n}) {
          std::string out(records.size(), '\0');
          std::size_t coded = 0;
          for (std::size_t at = 0; at < n; at += chunk) {
            const std::size_t m = std::min(chunk, n - at);
            std::string bytes;
            d::encode_laz_chunk(layout, reinterpret_cast<const unsigned char*>(records.data()) + at * stride, m, bytes);
            coded += bytes.size();
            const d::laz_chunk c{at, m, 0, bytes.size()};
            d::decode_laz_chunk(layout, c, 0, reinterpret_cast<const unsigned char*>(bytes.data()),
                                reinterpret_cast<unsigned char*>(out.data()) + at * stride, "t.laz");
          }
          EXPECT_TRUE(out == records) << "chunks of " << chunk;
          if (mode > 0 && chunk > 2) {  // it compresses (mode 1 keeps intensity, user data, NIR, extra bytes random)
            EXPECT_LT(coded, records.size() * 3 / 4) << "chunks of " << chunk;
          }
        }
      }
}

namespace {

/// The rows (position, then every field) of a cloud, sorted: the cloud as a
/// set of points, whatever their order.
std::vector<std::vector<double>> sorted_rows(const ced::point_cloud& c) {
  std::vector<std::vector<double>> rows(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    for (int k = 0; k < 3; ++k) rows[i].push_back(c.origin()[k] + double(c.position(i)[k]));
    for (const auto& f : c.fields()) rows[i].push_back(f.values[i]);
  }
  std::sort(rows.begin(), rows.end());
  return rows;
}

}  // namespace

TEST(Copc, WrittenFileHoldsTheCloudInItsOctree) {
  // write_cloud(.copc.laz): LAS 1.4 records grouped by octree node, one
  // layered chunk a node. The points are those of the cloud written as
  // LAS 1.4 (in node order), each inside its node's cube; whole and in
  // pieces, the same bytes.
  const ced::point_cloud c = autzen_with_saliency();
  const std::string copc = temp_file("out.copc.laz"), las = temp_file("out14.las");
  EXPECT_EQ(ced::io::format_of(copc), ced::io::file_format::copc);
  EXPECT_EQ(ced::io::format_of("A.COPC.LAZ"), ced::io::file_format::copc);
  ced::io::write_cloud(copc, c);
  ced::io::write_las(las, c);
  ced::io::read_report r;
  const ced::point_cloud got = ced::io::read_cloud(copc, {}, &r);
  EXPECT_EQ(r.details, "LAZ 1.4, point format 7, COPC");
  const ced::point_cloud want = ced::io::read_cloud(las);
  ASSERT_EQ(got.size(), want.size());
  ASSERT_EQ(got.fields().size(), want.fields().size());
  EXPECT_TRUE(sorted_rows(got) == sorted_rows(want));
  EXPECT_LT(std::filesystem::file_size(copc), std::filesystem::file_size(las) / 3);
  // The hierarchy: nodes at several depths, each a chunk, holding every point once, inside its cube.
  const auto s = ced::io::open_point_stream(copc);
  const auto nodes = s->index_nodes();
  ASSERT_TRUE(nodes);
  EXPECT_GT(nodes->size(), 8u);
  std::vector<int> seen(got.size(), 0);
  for (const auto& n : *nodes)
    for (std::uint64_t i = n.run.first; i < n.run.first + n.run.count; ++i) {
      ++seen[i];
      for (int k = 0; k < 3; ++k) {
        const double v = got.origin()[k] + double(got.position(i)[k]);
        ASSERT_GE(v, n.box[k] - 1e-3);
        ASSERT_LE(v, n.box[3 + k] + 1e-3);
      }
    }
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), std::ptrdiff_t(got.size()));
  // In pieces (a tiled run's merge), the same bytes.
  const std::string pieces = temp_file("pieces.copc.laz");
  write_in_pieces(pieces, c, ced::io::file_format::copc);
  EXPECT_TRUE(read_bytes(pieces) == read_bytes(copc));
  // What it cannot write is refused, naming it.
  EXPECT_THROW(ced::io::detail::copc_from_las(read_bytes(data_path("autzen_trim.las")), "autzen_trim.las"),
               std::invalid_argument);
}

TEST(Copc, WrittenFileTilesThroughItsIndexAsTheWholeRun) {
  const ced::point_cloud c = ced::io::read_cloud(data_path("autzen_trim.laz"));
  const std::string copc = temp_file("tiles.copc.laz");
  ced::io::write_cloud(copc, c);
  for (const char* preset : {"ced6d", "ced3d"}) {
    const index_plan ip = plan_from_the_index(copc, preset, 3, 100);
    EXPECT_EQ(merged_keypoints(ip.plan), ip.whole) << preset;
  }
}
