// SPDX-License-Identifier: MIT
// Tiled runs in a work directory (src/tiled/run.cpp, tile_cache.cpp): a failed
// merge keeps the parts for --resume; a tile cache of another format version is refused;
// the keypoints' records are fetched from the input (its first and last point, non-finite
// points, fields detection does not read), and an input changed before the merge is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/tiled.hpp"
#include "tiled_support.hpp"

namespace {
using ced_test::room_request;
using ced_test::specs;
}  // namespace

TEST(TiledRun, AFailedMergeKeepsThePartsForResume) {
  const ced::tiled_request r = room_request(4000, 11, "resume_room.las", 0.2);
  const std::string& input = r.input;
  ced::tiled_run_options o;
  o.work_dir = ced_test::temp_file("resume_work");
  ced::merge_sink failing;
  failing.chunk = [](const ced::tile_part&) { throw std::runtime_error("disk full"); };
  o.sink = &failing;
  EXPECT_THROW(ced::run_tiled(r, o), std::runtime_error);
  ASSERT_TRUE(std::filesystem::exists(std::filesystem::path(o.work_dir) / "plan.json"));
  const auto whole = ced::detect(ced::io::read_cloud(input), r.params, specs(r.modalities)).keypoints;
  ASSERT_GT(whole.size(), 5u);
  // Resumed: every part is there and the tile caches are gone (each went
  // when its part was written), so the merge runs from the parts alone.
  o.sink = nullptr;
  o.resume = true;
  const auto parts = std::distance(std::filesystem::directory_iterator(std::filesystem::path(o.work_dir) / "parts"),
                                   std::filesystem::directory_iterator{});
  EXPECT_GT(parts, 1);
  const ced::tile_part merged = ced::run_tiled(r, o);
  EXPECT_EQ(merged.index, std::vector<std::uint64_t>(whole.begin(), whole.end()));
  EXPECT_FALSE(std::filesystem::exists(o.work_dir));
}

TEST(TiledRun, ATileCacheOfAnotherFormatVersionIsRefused) {
  const ced::tiled_request r = room_request(3000, 12, "cache_version.las", 0.2);
  ced::tiled_run_options o;
  o.work_dir = ced_test::temp_file("cache_version_work");
  const ced::tile_plan plan = ced::prepare_tiled(r, o);
  ASSERT_GT(plan.tiles.size(), 1u);
  const std::uint64_t id = plan.tiles.front().id;
  const std::string cache =
      (std::filesystem::path(o.work_dir) / "cache" / ("t" + std::to_string(id) + ".bin")).string();
  const std::string bytes = ced_test::read_bytes(cache);
  ASSERT_GT(bytes.size(), 12u);
  EXPECT_EQ(bytes.substr(0, 12), std::string("CEDTILE\0\x04\0\0\0", 12));  // magic, format version 4
  std::string bumped = bytes;
  bumped[8] = 7;
  ced_test::write_bytes(cache, bumped);
  try {
    ced::detect_cached_tile(plan, o.work_dir, id);
    ADD_FAILURE() << "a tile cache of format version 7 was read";
  } catch (const ced::io::io_error& e) {
    EXPECT_NE(std::string(e.what()).find(cache + ": tile cache format version 7, this ced reads version 4"),
              std::string::npos)
        << e.what();
  }
  // The cache of a ced before format versions: no header at all.
  ced_test::write_bytes(cache, bytes.substr(12));
  try {
    ced::detect_cached_tile(plan, o.work_dir, id);
    ADD_FAILURE() << "a tile cache without a header was read";
  } catch (const ced::io::io_error& e) {
    EXPECT_NE(std::string(e.what()).find(cache + ": not a ced tile cache (or one of format version 1"),
              std::string::npos)
        << e.what();
  }
  ced_test::write_bytes(cache, bytes);
  EXPECT_NO_THROW(ced::detect_cached_tile(plan, o.work_dir, id));
  ced::remove_work_dir(o.work_dir);
  EXPECT_FALSE(std::filesystem::exists(o.work_dir));
}

namespace {

std::uint64_t le(const std::string& b, std::size_t at, std::size_t n) {
  std::uint64_t v = 0;
  for (std::size_t k = 0; k < n; ++k) v |= std::uint64_t(static_cast<unsigned char>(b[at + k])) << (8 * k);
  return v;
}

/// `c` with the points `keep` says (positions and fields).
ced::point_cloud subset(const ced::point_cloud& c, const std::vector<bool>& keep) {
  ced::point_cloud out;
  out.set_origin(c.origin());
  std::vector<std::size_t> at;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (keep[i]) at.push_back(i);
  out.resize(at.size());
  for (std::size_t j = 0; j < at.size(); ++j) std::copy_n(c.position(at[j]), 3, out.positions().data() + 3 * j);
  for (const auto& f : c.fields()) {
    std::vector<double> v(at.size());
    for (std::size_t j = 0; j < at.size(); ++j) v[j] = f.values[at[j]];
    out.add_field(f.name, f.type(), v);
  }
  return out;
}

/// The whole run's keypoints of the file (its finite points, as `ced detect`).
std::vector<std::uint32_t> whole_keypoints(const std::string& path, const ced::detect_params& p,
                                           const std::vector<std::string>& mods) {
  ced::io::read_options all;
  all.keep_nonfinite = true;
  const ced::point_cloud c = ced::io::read_cloud(path, all);
  std::vector<bool> finite(c.size());
  for (std::size_t i = 0; i < c.size(); ++i)
    finite[i] = std::isfinite(c.position(i)[0]) && std::isfinite(c.position(i)[1]) && std::isfinite(c.position(i)[2]);
  return ced::detect(subset(c, finite), p, ced_test::specs(mods)).keypoints;
}

/// room16(n, seed) with more fields than detection reads (a float64, an
/// int8), a non-finite point before each index of `nans` (PLY keeps them),
/// and two of the whole run's keypoints moved to the first and the last
/// point; written to `path`. Returns the whole run's keypoints.
std::vector<std::uint32_t> write_edge_keypoints(const std::string& path, std::size_t n, std::uint32_t seed,
                                                const std::vector<std::size_t>& nans, const ced::detect_params& p,
                                                const std::vector<std::string>& mods) {
  ced::point_cloud c = ced_test::room16(n, seed);
  std::vector<double> q(n), label(n);
  for (std::size_t i = 0; i < n; ++i) q[i] = 0.25 * double(i), label[i] = double(int(i % 7) - 3);
  c.add_field("quality", ced::scalar_type::float64, q);
  c.add_field("label", ced::scalar_type::int8, label);
  auto swap_points = [&](std::size_t a, std::size_t b) {
    for (std::size_t k = 0; k < 3; ++k) std::swap(c.positions()[3 * a + k], c.positions()[3 * b + k]);
    for (auto& f : c.fields()) {
      const double v = f.values[a];
      f.values.set(a, f.values[b]);
      f.values.set(b, v);
    }
  };
  // With the non-finite points: a NaN point inserted before each of `nans`.
  auto write = [&] {
    std::vector<bool> keep(n + nans.size(), true);
    ced::point_cloud with;
    with.set_origin(c.origin());
    with.resize(n + nans.size());
    std::vector<std::size_t> from;
    for (std::size_t i = 0, k = 0; i < n; ++i) {
      while (k < nans.size() && nans[k] == i) from.push_back(n), ++k;  // n: a NaN point
      from.push_back(i);
    }
    for (std::size_t j = 0; j < from.size(); ++j)
      for (std::size_t k = 0; k < 3; ++k)
        with.positions()[3 * j + k] = from[j] == n ? std::nanf("") : c.position(from[j])[k];
    for (const auto& f : c.fields()) {
      std::vector<double> v(from.size(), 1.0);
      for (std::size_t j = 0; j < from.size(); ++j)
        if (from[j] < n) v[j] = f.values[from[j]];
      with.add_field(f.name, f.type(), v);
    }
    ced::io::write_cloud(path, with);
    return whole_keypoints(path, p, mods);
  };
  // Keypoints of the whole cloud at its ends (the order can move a saliency's
  // last bits: try pairs until both ends are keypoints).
  const auto kp = write();
  for (std::size_t t = 0; t + 1 < kp.size() && t < 20; ++t) {
    const ced::point_cloud before = c;
    swap_points(0, kp[t]);
    swap_points(n - 1, kp[kp.size() - 1 - t]);
    const auto moved = write();
    if (!moved.empty() && moved.front() == 0 && moved.back() == n - 1) return moved;
    c = before;
  }
  return write();
}

}  // namespace

TEST(TiledRun, KeypointRecordsAreFetchedFromTheInput) {
  for (const std::string ext : {"ply", "las"}) {
    ced::tiled_request r = room_request(3000, 14, "fetch_seed." + ext, 0.2);
    r.input = ced_test::temp_file("fetch." + ext);
    r.read.keep_nonfinite = true;
    // LAS holds no NaN positions: the PLY file has three non-finite points.
    const std::vector<std::size_t> nans =
        ext == "ply" ? std::vector<std::size_t>{1, 1500, 2900} : std::vector<std::size_t>{};
    const auto whole = write_edge_keypoints(r.input, 3000, 14, nans, r.params, r.modalities);
    ASSERT_GT(whole.size(), 5u);
    ASSERT_EQ(whole.front(), 0u) << ext;
    ASSERT_EQ(whole.back(), 2999u) << ext;
    ced::io::read_options all;
    all.keep_nonfinite = true;
    const ced::point_cloud file = ced::io::read_cloud(r.input, all);
    ced::tiled_run_options o;
    o.work_dir = ced_test::temp_file("fetch_work_" + ext);
    ced::tile_plan plan;
    const ced::tile_part merged = ced::run_tiled(r, o, &plan);
    // The tiles carried the colour only; the merge fetched every field.
    ASSERT_TRUE(plan.tile_fields.has_value()) << ext;
    EXPECT_EQ(*plan.tile_fields, (std::vector<std::string>{"red", "green", "blue"})) << ext;
    EXPECT_EQ(merged.index, std::vector<std::uint64_t>(whole.begin(), whole.end())) << ext;
    ASSERT_EQ(merged.keypoints.fields().size(), file.fields().size()) << ext;
    for (std::size_t j = 0; j < merged.index.size(); ++j) {
      const std::uint64_t fi = merged.file_index[j];
      std::uint64_t before = 0;  // non-finite points before it: one before each of `nans`
      for (std::size_t k : nans) before += k <= merged.index[j];
      ASSERT_EQ(fi, merged.index[j] + before) << ext;
      EXPECT_EQ(0, std::memcmp(merged.keypoints.position(j), file.position(fi), 12)) << ext << " keypoint " << j;
      for (std::size_t f = 0; f < file.fields().size(); ++f) {
        const auto& a = merged.keypoints.fields()[f];
        const auto& b = file.fields()[f];
        ASSERT_EQ(a.name, b.name);
        ASSERT_EQ(a.type(), b.type());
        const std::size_t w = ced::size_of(a.type());
        EXPECT_EQ(0, std::memcmp(a.values.bytes() + w * j, b.values.bytes() + w * fi, w)) << ext << " " << a.name;
      }
    }
    // Reading only what detection reads, there is nothing to fetch.
    r.read.fields = ced::field_selection::only({"red", "green", "blue"});
    o.work_dir = ced_test::temp_file("fetch_work_slim_" + ext);
    const ced::tile_part slim = ced::run_tiled(r, o, &plan);
    EXPECT_FALSE(plan.tile_fields.has_value()) << ext;
    EXPECT_EQ(slim.index, merged.index) << ext;
  }
}

namespace {
/// Changes the X of one of `keypoints` (file indices) in the LAS file `path`
/// where the input's fingerprint does not look (its first and last 64 KiB,
/// 64 blocks of 4 KiB): only the merge can tell.
void change_a_keypoint_unseen(const std::string& path, const std::vector<std::uint64_t>& keypoints) {
  std::string bytes = ced_test::read_bytes(path);
  const std::uint64_t size = bytes.size(), offset = le(bytes, 96, 4), record = le(bytes, 105, 2);
  auto sampled = [&](std::uint64_t a, std::uint64_t b) {
    if (a < 65536 || b + 65536 > size) return true;
    for (std::uint64_t k = 1; k <= 64; ++k)
      if (a < size / 65 * k + 4096 && size / 65 * k < b) return true;
    return false;
  };
  std::uint64_t at = 0;
  for (std::uint64_t fi : keypoints)
    if (!sampled(offset + fi * record, offset + (fi + 1) * record)) at = offset + fi * record;
  ASSERT_GT(at, 0u);
  bytes[at] = char(bytes[at] + 1);
  ced_test::write_bytes(path, bytes);
}

/// `merge` must throw the io_error of an input changed since the plan, at a keypoint.
template <class Merge>
void expect_a_changed_keypoint(const std::string& input, Merge&& merge) {
  try {
    merge();
    ADD_FAILURE() << "a changed input was merged";
  } catch (const ced::io::io_error& e) {
    EXPECT_NE(std::string(e.what()).find(input + ": the file changed since the plan was made (point "),
              std::string::npos)
        << e.what();
  }
}
}  // namespace

TEST(TiledRun, AnInputChangedBeforeTheMergeIsRefused) {
  const ced::tiled_request r = room_request(40000, 15, "changed.las", 0.2);
  ced::tiled_run_options o;
  o.work_dir = ced_test::temp_file("changed_work");
  const ced::tile_plan plan = ced::prepare_tiled(r, o);
  ASSERT_TRUE(plan.tile_fields.has_value());
  std::vector<std::uint64_t> keypoints;
  for (const auto& t : plan.tiles)
    for (std::uint64_t fi : ced::detect_cached_tile(plan, o.work_dir, t.id).file_index) keypoints.push_back(fi);
  change_a_keypoint_unseen(r.input, keypoints);
  EXPECT_NO_THROW(ced::check_plan_input(plan));  // the fingerprint is blind to it
  expect_a_changed_keypoint(r.input, [&] { ced::finish_tiled(plan, o.work_dir); });
  ced::remove_work_dir(o.work_dir);
}

TEST(TiledRun, AMergeThatWritesNoKeypointCloudFetchesPositionsOnly) {
  // merge_sink::records false (the CLI without -o): the same keypoints, in
  // positions only; and a changed input is still refused.
  const ced::tiled_request r = room_request(20000, 17, "positions_only.las", 0.2);
  ced::tiled_run_options o;
  o.work_dir = ced_test::temp_file("positions_only_work");
  const ced::tile_plan plan = ced::prepare_tiled(r, o);
  ASSERT_TRUE(plan.tile_fields.has_value());
  for (const auto& t : plan.tiles) ced::detect_cached_tile(plan, o.work_dir, t.id);
  auto merged = [&](bool records, std::vector<std::uint64_t>& index, std::vector<float>& xyz) {
    ced::merge_sink sink;
    sink.records = records;
    sink.chunk = [&](const ced::tile_part& c) {
      index.insert(index.end(), c.index.begin(), c.index.end());
      xyz.insert(xyz.end(), c.keypoints.positions().begin(), c.keypoints.positions().end());
      EXPECT_EQ(c.keypoints.fields().size(), records ? plan.fields.size() : 0u);
    };
    ced::finish_tiled(plan, o.work_dir, &sink, true);
  };
  std::vector<std::uint64_t> with, without;
  std::vector<float> with_xyz, without_xyz;
  merged(true, with, with_xyz);
  merged(false, without, without_xyz);
  ASSERT_GT(with.size(), 10u);
  EXPECT_EQ(with, without);
  EXPECT_EQ(with_xyz, without_xyz);
  // A keypoint's position changed where the fingerprint does not look: refused without records too.
  change_a_keypoint_unseen(r.input, with);
  EXPECT_NO_THROW(ced::check_plan_input(plan));
  std::vector<std::uint64_t> index;
  std::vector<float> xyz;
  expect_a_changed_keypoint(r.input, [&] { merged(false, index, xyz); });
  ced::remove_work_dir(o.work_dir);
}

TEST(TiledRun, ATruncatedOrOversizedTileCacheIsRefused) {
  const ced::tiled_request r = room_request(3000, 16, "cache_cut.las", 0.2);
  ced::tiled_run_options o;
  o.work_dir = ced_test::temp_file("cache_cut_work");
  const ced::tile_plan plan = ced::prepare_tiled(r, o);
  const std::uint64_t id = plan.tiles.front().id;
  const std::string cache =
      (std::filesystem::path(o.work_dir) / "cache" / ("t" + std::to_string(id) + ".bin")).string();
  const std::string bytes = ced_test::read_bytes(cache);
  for (const auto& [changed, says] :
       {std::pair<std::string, std::string>{bytes.substr(0, bytes.size() - 3), "truncated or corrupt tile cache"},
        {bytes.substr(0, 13), "truncated or corrupt tile cache"},
        {bytes + std::string(5, '\x01'), "the tile cache holds more than the tile's points"}}) {
    ced_test::write_bytes(cache, changed);
    try {
      ced::detect_cached_tile(plan, o.work_dir, id);
      ADD_FAILURE() << "a tile cache of " << changed.size() << " bytes was read";
    } catch (const ced::io::io_error& e) {
      EXPECT_NE(std::string(e.what()).find(cache + ": " + says), std::string::npos) << e.what();
    }
  }
  ced::remove_work_dir(o.work_dir);
}

namespace {

/// run_tiled's keypoints and fields of `r`, and whether it made a pass to
/// learn the bounds before the tile cache (its progress says "pass 1").
struct tiled_outcome {
  std::vector<std::uint64_t> index;
  std::vector<std::string> fields;
  bool first_pass = false;
  std::array<double, 3> origin{};
};

tiled_outcome run_and_watch(const ced::tiled_request& r, const std::string& work) {
  tiled_outcome out;
  ced::tiled_run_options o;
  o.work_dir = ced_test::temp_file(work);
  o.progress = [&](const std::string& step, double) {
    if (step.find("pass 1") != std::string::npos) out.first_pass = true;
  };
  ced::tile_plan plan;
  const ced::tile_part merged = ced::run_tiled(r, o, &plan);
  out.index = merged.index;
  for (const auto& f : merged.keypoints.fields()) out.fields.push_back(f.name);
  out.origin = plan.origin;
  return out;
}

}  // namespace

TEST(TiledRun, LasIsPlannedFromItsHeaderInOnePassWhenTheHeaderHolds) {
  // A georeferenced room (the origin is the bounds' rounded centre) with a
  // flag some later points set and one no point sets.
  ced::tiled_request r = room_request(6000, 16, "header_seed.las", 0.2, {500000.5, 4000000.25, 100});
  ced::point_cloud c = ced::io::read_cloud(r.input);
  std::vector<double> withheld(c.size(), 0.0), key(c.size(), 0.0);
  for (std::size_t i = c.size() * 3 / 4; i < c.size(); i += 7) withheld[i] = 1;
  c.add_field("withheld", ced::scalar_type::uint8, withheld);
  c.add_field("key_point", ced::scalar_type::uint8, key);
  ced::io::write_cloud(r.input, c);
  const std::string bytes = ced_test::read_bytes(r.input);
  const auto header = [&](std::size_t at) {
    double v;
    std::memcpy(&v, bytes.data() + at, sizeof v);
    return v;
  };
  const double max_x = header(179), min_x = header(187), extent = max_x - min_x;
  const auto with_max_x = [&](double v, const std::string& name) {
    std::string b = bytes;
    std::memcpy(&b[179], &v, sizeof v);
    ced::tiled_request q = r;
    q.input = ced_test::temp_file(name);
    ced_test::write_bytes(q.input, b);
    return q;
  };
  for (const auto& [q, one_pass] :
       {std::pair{r, true}, std::pair{with_max_x(max_x + 0.005 * extent, "header_loose.las"), true},
        std::pair{with_max_x(max_x - 0.6 * extent, "header_tight.las"), false}}) {
    SCOPED_TRACE(q.input);
    const ced::point_cloud file = ced::io::read_cloud(q.input);
    const auto whole = ced::detect(file, q.params, specs(q.modalities)).keypoints;
    ASSERT_GT(whole.size(), 5u);
    std::vector<std::string> names;
    for (const auto& f : file.fields()) names.push_back(f.name);
    ASSERT_NE(std::find(names.begin(), names.end(), "withheld"), names.end());
    EXPECT_EQ(std::find(names.begin(), names.end(), "key_point"), names.end());
    const tiled_outcome t = run_and_watch(q, "header_work");
    EXPECT_EQ(t.first_pass, !one_pass);
    EXPECT_EQ(t.index, std::vector<std::uint64_t>(whole.begin(), whole.end()));
    EXPECT_EQ(t.fields, names);  // the flags some point sets, as a whole read has them
    EXPECT_EQ(t.origin, file.origin());
  }
  // With scan: the two passes.
  r.scan = true;
  EXPECT_TRUE(run_and_watch(r, "header_scan_work").first_pass);
}

// A LAZ input (tile_plan::bytes_hash): a merge of positions alone checks the
// file's bytes, not the decoded keypoints, and gives the same keypoints as a
// merge that fetches their records; a byte changed where the fingerprint
// does not look is refused. Also through the shares of ced-mpi.
TEST(TiledRun, ACompressedInputIsCheckedByItsBytes) {
  ced::tiled_request r = room_request(40000, 18, "bytes_room.las", 0.2, {512000.0, 4012000.0, 100.0});
  const std::string laz = ced_test::temp_file("bytes_room.laz");
  ced::io::write_cloud(laz, ced::io::read_cloud(r.input));
  r.input = laz;
  const auto whole = ced::detect(ced::io::read_cloud(laz), r.params, ced_test::specs(r.modalities)).keypoints;
  ASSERT_GT(whole.size(), 10u);
  for (unsigned shares : {1u, 3u}) {
    SCOPED_TRACE(std::to_string(shares) + " share(s)");
    ced::tiled_run_options o;
    o.work_dir = ced_test::temp_file("bytes_work");
    ced::tile_plan plan;
    const std::string begun = ced::begin_cache_shares(r, o, shares, plan);
    if (!begun.empty()) {
      std::vector<std::string> learnt(shares);
      for (unsigned k = 0; k < shares; ++k) learnt[k] = ced::fill_cache_share(begun, k, o);
      plan = ced::finish_cache_shares(begun, learnt, o);
    }
    EXPECT_EQ(plan.bytes_hash.size(), 16u);
    EXPECT_EQ(plan.cache_shares, shares);
    for (const auto& t : plan.tiles) ced::detect_cached_tile(plan, o.work_dir, t.id);
    auto merged = [&](bool records) {
      std::vector<std::uint64_t> index;
      std::vector<float> xyz;
      ced::merge_sink sink;
      sink.records = records;
      sink.chunk = [&](const ced::tile_part& c) {
        index.insert(index.end(), c.index.begin(), c.index.end());
        xyz.insert(xyz.end(), c.keypoints.positions().begin(), c.keypoints.positions().end());
      };
      ced::finish_tiled(plan, o.work_dir, &sink, true);
      return std::make_pair(index, xyz);
    };
    const auto with = merged(true), without = merged(false);
    EXPECT_EQ(with.first, std::vector<std::uint64_t>(whole.begin(), whole.end()));
    EXPECT_EQ(without.first, with.first);
    EXPECT_EQ(without.second, with.second);
    // One byte of the compressed points, away from the fingerprint's samples.
    const std::string bytes = ced_test::read_bytes(laz);
    std::string changed = bytes;
    const std::size_t step = bytes.size() / 65, at = step * 30 + 4096 + (step - 4096) / 2;  // between two samples
    ASSERT_GT(step, 4096u);
    ASSERT_TRUE(at > 65536 && at + 65536 < bytes.size());
    changed[at] = static_cast<char>(changed[at] ^ 0x10);
    ced_test::write_bytes(laz, changed);
    EXPECT_NO_THROW(ced::check_plan_input(plan));
    try {
      merged(false);
      ADD_FAILURE() << "a changed LAZ file was merged";
    } catch (const ced::io::io_error& e) {
      EXPECT_NE(std::string(e.what()).find("the file changed since the plan was made (its bytes hash to"),
                std::string::npos)
          << e.what();
    }
    ced_test::write_bytes(laz, bytes);
    ced::remove_work_dir(o.work_dir);
  }
}
