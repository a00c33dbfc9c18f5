// SPDX-License-Identifier: MIT
// Tiled runs, the merge (src/tiled/merge.cpp): streamed from part files it is
// the merge in memory; parts missing, repeated, damaged or of another plan are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "ced/tiled.hpp"
#include "tiled_support.hpp"

namespace {
using ced_test::detect_planned_tile;
using ced_test::expect_same_part;
using ced_test::room_request;
using ced_test::specs;

/// Appends a merged chunk's keypoints, indices, saliencies and fields to `got`.
void append_chunk(ced::tile_part& got, const ced::tile_part& chunk) {
  const std::size_t n = chunk.index.size();
  got.index.insert(got.index.end(), chunk.index.begin(), chunk.index.end());
  got.file_index.insert(got.file_index.end(), chunk.file_index.begin(), chunk.file_index.end());
  for (std::size_t k = 0; k < chunk.saliency.size(); ++k)
    got.saliency[k].insert(got.saliency[k].end(), chunk.saliency[k].begin(), chunk.saliency[k].end());
  const std::size_t at = got.keypoints.size();
  got.keypoints.resize(at + n);
  std::copy_n(chunk.keypoints.positions().begin(), 3 * n, got.keypoints.positions().begin() + 3 * at);
  for (std::size_t f = 0; f < chunk.keypoints.fields().size(); ++f) {
    auto& col = got.keypoints.fields()[f].values;
    const std::size_t w = ced::size_of(col.type());
    ced::column grown(col.type(), at + n);
    if (at > 0) std::memcpy(grown.bytes(), col.bytes(), w * at);  // an empty column has no buffer
    std::memcpy(grown.bytes() + w * at, chunk.keypoints.fields()[f].values.bytes(), w * n);
    col = std::move(grown);
  }
}
}  // namespace

TEST(TiledMerge, StreamedMergeOfPartFilesIsTheMergeInMemory) {
  const ced::tiled_request r = room_request(6000, 9, "merge_room.las", 0.15, {431000.0, 5091000.0, 120.0});
  const std::string& input = r.input;
  const ced::tile_plan plan = ced::plan_tiles(r);
  ASSERT_GT(plan.tiles.size(), 4u);
  std::vector<ced::tile_part> parts;
  std::vector<std::string> paths;
  for (const auto& t : plan.tiles) {
    parts.push_back(ced::detect_tile(plan, ced::read_tile(plan, t.id), 1));
    paths.push_back(ced_test::temp_file("merge_t" + std::to_string(t.id) + ".part"));
    ced::write_part(paths.back(), plan, parts.back());
  }
  const ced::tile_part merged = ced::merge_parts(plan, parts);
  ASSERT_GT(merged.index.size(), 20u);
  // The whole cloud's keypoints, as the file holds them.
  ced::detect_params p = r.params;
  const auto whole = ced::detect(ced::io::read_cloud(input), p, specs(r.modalities));
  EXPECT_EQ(merged.index, std::vector<std::uint64_t>(whole.keypoints.begin(), whole.keypoints.end()));
  // Streamed with buffers of one record (and chunks of one keypoint), and with the default.
  for (std::size_t memory : {std::size_t(1), std::size_t(3000), std::size_t(64) << 20}) {
    ced::tile_part got;
    std::uint64_t announced = 0;
    std::size_t chunks = 0;
    ced::merge_sink sink;
    sink.begin = [&](const ced::tile_part& totals, std::uint64_t n) {
      EXPECT_TRUE(totals.index.empty());
      got = totals;
      announced = n;
    };
    sink.chunk = [&](const ced::tile_part& chunk) {
      ++chunks;
      append_chunk(got, chunk);
    };
    ced::merge_part_files(plan, paths, sink, memory);
    EXPECT_EQ(announced, merged.index.size());
    if (memory == 1) {
      EXPECT_EQ(chunks, merged.index.size());
    }
    expect_same_part(got, merged, "memory " + std::to_string(memory));
  }
  // Missing, repeated and damaged parts.
  const ced::merge_sink none;
  auto fewer = paths;
  fewer.pop_back();
  try {
    ced::merge_part_files(plan, fewer, none);
    ADD_FAILURE() << "a missing part was not an error";
  } catch (const ced::io::io_error& e) {
    EXPECT_NE(std::string(e.what()).find("have no part"), std::string::npos) << e.what();
  }
  auto twice = paths;
  twice.push_back(paths.front());
  EXPECT_THROW(ced::merge_part_files(plan, twice, none), ced::io::io_error);
  const std::string bytes = ced_test::read_bytes(paths.front());
  for (std::size_t keep : {std::size_t(5), std::size_t(60), bytes.size() - 3}) {
    auto damaged = paths;
    damaged.front() = ced_test::temp_file("merge_damaged.part");
    ced_test::write_bytes(damaged.front(), bytes.substr(0, keep));
    try {
      ced::merge_part_files(plan, damaged, none);
      ADD_FAILURE() << "a part cut to " << keep << " bytes was not an error";
    } catch (const ced::io::io_error& e) {
      EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
    }
  }
}

// ---------------------------------------------------------------- tampered parts (issue #25)

TEST(TiledMerge, PartsOfAnotherPlanOrTamperedAreRefusedInMemory) {
  ced::tiled_request r = room_request(3000, 21, "tamper_room.las", 0.06);
  const ced::tile_plan a = ced::plan_tiles(r);
  r.modalities = {"xyz:0.2", "rgb:0.1", "lab:0.1", "intensity:0.05,range=auto"};
  const ced::tile_plan b = ced::plan_tiles(r);
  std::vector<ced::tile_part> parts;
  for (const auto& t : a.tiles) parts.push_back(detect_planned_tile(a, t.id));
  EXPECT_NO_THROW(ced::merge_parts(a, parts));
  // Plan b has four modalities, a's parts one saliency array each: read past them before.
  EXPECT_THROW(ced::merge_parts(b, parts), ced::io::io_error);
  std::size_t k = 0;
  while (k < parts.size() && parts[k].index.size() < 2) ++k;
  ASSERT_LT(k, parts.size());
  auto tampered = [&](auto change) {
    auto copy = parts;
    change(copy[k]);
    return copy;
  };
  EXPECT_THROW(ced::merge_parts(a, tampered([&](ced::tile_part& p) { p.index[0] = std::uint64_t(1) << 40; })),
               ced::io::io_error);
  EXPECT_THROW(ced::merge_parts(a, tampered([&](ced::tile_part& p) { std::swap(p.index[0], p.index[1]); })),
               ced::io::io_error);
  EXPECT_THROW(ced::merge_parts(a, tampered([&](ced::tile_part& p) { p.saliency[0].pop_back(); })), ced::io::io_error);
  EXPECT_THROW(ced::merge_parts(a, tampered([&](ced::tile_part& p) { p.plan.clear(); })), ced::io::io_error);
  // A keypoint index that another part holds: repeated (or out of order in its part).
  std::size_t other = 0;
  while (other < parts.size() && (other == k || parts[other].index.empty())) ++other;
  ASSERT_LT(other, parts.size());
  EXPECT_THROW(ced::merge_parts(a, tampered([&](ced::tile_part& p) { p.index[0] = parts[other].index[0]; })),
               ced::io::io_error);
}

// ---------------------------------------------------------------- the N strongest (issue #28)

namespace {
/// merge_part_files() collected into one part.
ced::tile_part streamed_merge(const ced::tile_plan& plan, const std::vector<std::string>& paths, std::size_t memory,
                              std::uint64_t& announced) {
  ced::tile_part got;
  ced::merge_sink sink;
  sink.begin = [&](const ced::tile_part& totals, std::uint64_t n) {
    got = totals;
    announced = n;
  };
  sink.chunk = [&](const ced::tile_part& chunk) {
    got.index.insert(got.index.end(), chunk.index.begin(), chunk.index.end());
    for (std::size_t k = 0; k < chunk.saliency.size(); ++k)
      got.saliency[k].insert(got.saliency[k].end(), chunk.saliency[k].begin(), chunk.saliency[k].end());
    got.rank.insert(got.rank.end(), chunk.rank.begin(), chunk.rank.end());
  };
  ced::merge_part_files(plan, paths, sink, memory);
  return got;
}

/// A request over two twin rooms of 6,000 points each (written to `name`):
/// 0.15 m tiles, ced6d's modalities.
ced::tiled_request twins_request(const std::string& name, std::uint32_t seed) {
  ced::tiled_request r;
  r.input = ced_test::temp_file(name);
  ced::io::write_cloud(r.input, ced_test::twin_rooms(6000, seed));
  r.tile_size = 0.15;
  r.modalities = {"xyz:0.2", "rgb:0.1"};
  return r;
}

/// Every tile of `plan` detected on one thread, each part also written to a
/// file named after `prefix` (parts and paths in the plan's tile order).
void detect_all_tiles(const ced::tile_plan& plan, const std::string& prefix, std::vector<ced::tile_part>& parts,
                      std::vector<std::string>& paths) {
  for (const auto& t : plan.tiles) {
    parts.push_back(ced::detect_tile(plan, ced::read_tile(plan, t.id), 1));
    paths.push_back(ced_test::temp_file(prefix + std::to_string(t.id) + ".part"));
    ced::write_part(paths.back(), plan, parts.back());
  }
}
}  // namespace

namespace {
void max_keypoints_case(bool refine) {
  ced::tiled_request r = twins_request("twins.ply", 25);
  r.params.refine = refine;
  const ced::point_cloud cloud = ced::io::read_cloud(r.input);
  const auto all = ced::detect(cloud, r.params, specs(r.modalities));
  ASSERT_GT(all.keypoints.size(), 40u);
  for (std::size_t limit :
       {std::size_t(1), std::size_t(9), all.keypoints.size() / 2 + 1, all.keypoints.size(), all.keypoints.size() + 7}) {
    SCOPED_TRACE("max_keypoints " + std::to_string(limit));
    ced::tiled_request rl = r;
    rl.params.max_keypoints = limit;
    const ced::tile_plan plan = ced::plan_tiles(rl);
    ASSERT_GT(plan.tiles.size(), 4u);
    ced::detect_params p = r.params;
    p.max_keypoints = limit;
    const auto whole = ced::detect(cloud, p, specs(r.modalities));
    ASSERT_EQ(whole.keypoints.size(), std::min(limit, all.keypoints.size()));
    const std::vector<std::uint64_t> expected(whole.keypoints.begin(), whole.keypoints.end());
    std::vector<ced::tile_part> parts;
    std::vector<std::string> paths;
    detect_all_tiles(plan, "twins_t", parts, paths);
    const ced::tile_part merged = ced::merge_parts(plan, parts);
    EXPECT_EQ(merged.index, expected);
    EXPECT_EQ(merged.rank, whole.rank_score);
    for (std::size_t k = 0; k < merged.saliency.size(); ++k)
      for (std::size_t q = 0; q < merged.index.size(); ++q)
        EXPECT_EQ(merged.saliency[k][q], whole.saliency[k][merged.index[q]]);
    for (std::size_t memory : {std::size_t(1), std::size_t(64) << 20}) {
      std::uint64_t announced = 0;
      const ced::tile_part got = streamed_merge(plan, paths, memory, announced);
      EXPECT_EQ(announced, expected.size()) << "memory " << memory;
      EXPECT_EQ(got.index, expected) << "memory " << memory;
      EXPECT_EQ(got.saliency, merged.saliency) << "memory " << memory;
      EXPECT_EQ(got.rank, merged.rank) << "memory " << memory;
    }
  }
}
}  // namespace

// A tiled run keeps the strongest keypoints of all tiles: the whole run's,
// with exact ties between twins in different tiles going to the smaller index.
// Refined, a keypoint ranks by its maximum (detection_result::rank_score),
// which the parts carry.
TEST(TiledMerge, MaxKeypointsIsTheWholeRunsStrongest) {
  for (const bool refine : {false, true}) {
    SCOPED_TRACE(refine ? "refined" : "not refined");
    max_keypoints_case(refine);
  }
}

// --keypoint-share in a tiled run: the share of all tiles' candidates, the
// strongest of all tiles' keypoints, as the whole run keeps.
TEST(TiledMerge, KeypointShareIsTheWholeRunsShare) {
  const ced::tiled_request r = twins_request("twins_share.ply", 29);
  const ced::point_cloud cloud = ced::io::read_cloud(r.input);
  const auto all = ced::detect(cloud, r.params, specs(r.modalities));
  const auto candidates =
      static_cast<double>(std::count_if(all.candidate.begin(), all.candidate.end(), [](auto v) { return v; }));
  ASSERT_GT(all.keypoints.size(), 40u);
  for (double share : {0.5 / candidates, 17.0 / candidates, 0.3 * double(all.keypoints.size()) / candidates, 1.0}) {
    SCOPED_TRACE("keypoint_share " + std::to_string(share));
    ced::tiled_request rl = r;
    rl.params.keypoint_share = share;
    const ced::tile_plan plan = ced::plan_tiles(rl);
    ASSERT_GT(plan.tiles.size(), 4u);
    ced::detect_params p = r.params;
    p.keypoint_share = share;
    const auto whole = ced::detect(cloud, p, specs(r.modalities));
    if (share < 1) {
      ASSERT_LT(whole.keypoints.size(), all.keypoints.size());
    }
    const std::vector<std::uint64_t> expected(whole.keypoints.begin(), whole.keypoints.end());
    std::vector<ced::tile_part> parts;
    std::vector<std::string> paths;
    detect_all_tiles(plan, "twins_s", parts, paths);
    EXPECT_EQ(ced::merge_parts(plan, parts).index, expected);
    std::uint64_t announced = 0;
    const ced::tile_part got = streamed_merge(plan, paths, std::size_t(1) << 20, announced);
    EXPECT_EQ(announced, expected.size());
    EXPECT_EQ(got.index, expected);
  }
}
