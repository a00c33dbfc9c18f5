// SPDX-License-Identifier: MIT
// Exact tiles: the union of the tiles' core keypoints is the whole cloud's
// result, index for index, whatever the tile size.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "ced/core.hpp"
#include "ced/io/io.hpp"
#include "ced/tiled.hpp"
#include "file_support.hpp"
#include "test_support.hpp"

namespace {

std::vector<ced::any_modality> specs(const std::vector<std::string>& s) {
  std::vector<ced::any_modality> out;
  for (const auto& x : s) out.push_back(ced::make_modality(x));
  return out;
}

/// The room of test_support, its colour as 16-bit fields that hold 8-bit
/// values except in one corner (so a tile far from it sees only 8-bit values).
ced::point_cloud room16(std::size_t n, std::uint32_t seed) {
  ced::point_cloud c = ced_test::make_room(n, seed);
  for (auto& f : c.fields())
    if (f.name == "red" || f.name == "green" || f.name == "blue") {
      std::vector<double> v(c.size());
      for (std::size_t i = 0; i < c.size(); ++i) v[i] = f.values[i];
      f.values = ced::column(ced::scalar_type::uint16, v);
    }
  auto& red = c.fields()[0];
  for (std::size_t i = 0; i < c.size(); ++i)
    if (c.position(i)[0] < 0.05f && c.position(i)[1] < 0.05f) red.values.set(i, 40000);
  return c;
}

void expect_tiles_exact(const ced::point_cloud& c, const ced::detect_params& p,
                        const std::vector<std::string>& modalities, double tile, const std::string& what) {
  const auto m = specs(modalities);
  const auto whole = ced::detect(c, p, m).keypoints;
  const auto tiled = ced::detect_tiled(c, p, m, tile);
  EXPECT_EQ(tiled, whole) << what << ", tile size " << tile << ": " << tiled.size() << " against " << whole.size();
}

}  // namespace

TEST(Tiles, GridCoversEveryPointOnceAndHalosHoldTheirCores) {
  const auto c = ced_test::make_room(4000, 3);
  ced::detect_params p;
  const double lo[3] = {-0.01, -0.01, -0.01}, hi[3] = {0.33, 0.33, 0.33};
  const auto g = ced::make_tile_grid(lo, hi, 0.07, p);
  EXPECT_EQ(g.dims[0], 5u);
  EXPECT_GT(g.halo, p.nms_radius + p.block_scale * p.radius + p.radius);
  std::vector<std::uint64_t> near;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const std::uint64_t t = g.tile_of(c.position(i));
    ASSERT_LT(t, g.count());
    const auto box = g.core_box(t);
    const auto co = g.coords(t);
    for (std::size_t k = 0; k < 3; ++k) {
      const double x = c.position(i)[k];
      if (co[k] > 0) {
        EXPECT_GE(x, box[k]);
      }
      if (co[k] + 1 < g.dims[k]) {
        EXPECT_LT(x, box[k + 3]);
      }
    }
    g.tiles_near(c.position(i), near);
    EXPECT_TRUE(std::find(near.begin(), near.end(), t) != near.end());
  }
}

TEST(Tiles, UnionOfTilesIsTheWholeResultOnRandomClouds) {
  std::mt19937 rng(2026);
  for (int trial = 0; trial < 6; ++trial) {
    const auto c = room16(5000 + 1000 * std::size_t(trial), 100u + unsigned(trial));
    ced::detect_params p;
    p.radius = 0.03 + 0.01 * (trial % 3);
    p.nms_radius = trial % 2 ? p.radius : p.radius * 1.5;
    p.min_neighbors = 5 + unsigned(trial);
    p.threads = 1 + unsigned(trial % 2);
    const double tile = std::uniform_real_distribution<double>(0.05, 0.4)(rng);
    expect_tiles_exact(c, p, {"xyz:0.2", "rgb:0.1"}, tile, "ced6d, trial " + std::to_string(trial));
    expect_tiles_exact(c, p, {"xyz:0.2"}, tile, "ced3d, trial " + std::to_string(trial));
    expect_tiles_exact(c, p, {"xyz:0.2", "lab:0.1", "intensity:0.05,range=auto", "bands(nir,blue):0.1,range=auto"},
                       tile * 0.7, "four modalities, trial " + std::to_string(trial));
  }
}

TEST(Tiles, CoreSalienciesAreBitwiseThoseOfTheWholeCloud) {
  // Stronger than equal keypoints (which float rounding rarely flips): every
  // saliency of a core point, in every modality, is bitwise the whole
  // cloud's, so no decision can differ.
  const auto c = room16(12000, 77);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.03;
  const auto m = specs({"xyz:0.2", "lab:0.1", "intensity:0.05,range=auto", "bands(nir,blue,red):0.1"});
  const auto whole = ced::detect(c, p, m);
  const double lo[3] = {0, 0, 0}, hi[3] = {0.55, 0.55, 0.55};
  const auto g = ced::make_tile_grid(lo, hi, 0.12, p);
  const auto ranges = ced::field_ranges(c);
  std::size_t checked = 0;
  for (std::uint64_t t = 0; t < g.count(); ++t) {
    const auto tile = ced::extract_tile(c, g, t, ranges);
    if (tile.cloud.empty()) continue;
    const auto r = ced::detect(tile.cloud, p, m);
    for (std::size_t i = 0; i < tile.cloud.size(); ++i) {
      if (g.tile_of(tile.cloud.position(i)) != t) continue;
      for (std::size_t k = 0; k < m.size(); ++k)
        ASSERT_EQ(r.saliency[k][i], whole.saliency[k][tile.index[i]])
            << "tile " << t << ", point " << tile.index[i] << ", " << whole.names[k];
      ++checked;
    }
  }
  EXPECT_EQ(checked, c.size());
}

TEST(Tiles, KeypointsOnTileBordersAndTies) {
  // A lattice of 1/128 m (every coordinate and sum exact in float) with a
  // regular pattern of bumps and colour patches: equal saliencies along the
  // lattice's edges and patches (ties keep both), and points lying exactly
  // on the borders of tiles of 1/8 m.
  ced::point_cloud c;
  std::vector<double> red, green, blue;
  for (int i = 0; i < 64; ++i)
    for (int j = 0; j < 64; ++j) {
      const bool bump = i % 16 == 8 && j % 16 == 8;
      c.push_back(float(i) / 128, float(j) / 128, bump ? 1.0f / 64 : 0.0f);
      const bool patch = (i / 16 + j / 16) % 2 == 0;
      red.push_back(patch ? 250 : 10);
      green.push_back(20);
      blue.push_back(patch ? 10 : 250);
    }
  c.add_field("red", ced::scalar_type::uint8, red);
  c.add_field("green", ced::scalar_type::uint8, green);
  c.add_field("blue", ced::scalar_type::uint8, blue);
  ced::detect_params p;
  const auto m = specs({"xyz:0.2", "rgb:0.1"});
  const auto whole = ced::detect(c, p, m);
  // The case is what it claims: keypoints with equal, non-zero scores closer
  // than the NMS radius, and keypoints on the tile borders.
  bool tie = false, on_border = false;
  const auto score = [&](std::uint32_t i) { return whole.saliency[0][i] * whole.saliency[1][i]; };
  for (std::size_t a = 0; a < whole.keypoints.size(); ++a) {
    const float* pa = c.position(whole.keypoints[a]);
    for (int k = 0; k < 2; ++k) on_border = on_border || (pa[k] > 0 && std::fmod(pa[k], 0.125f) == 0);
    for (std::size_t b = a + 1; b < whole.keypoints.size(); ++b) {
      const float* pb = c.position(whole.keypoints[b]);
      const float d2 =
          (pa[0] - pb[0]) * (pa[0] - pb[0]) + (pa[1] - pb[1]) * (pa[1] - pb[1]) + (pa[2] - pb[2]) * (pa[2] - pb[2]);
      const float sa = score(whole.keypoints[a]);
      tie = tie || (d2 < float(p.nms_radius * p.nms_radius) && sa > 0 && sa == score(whole.keypoints[b]));
    }
  }
  ASSERT_TRUE(tie);
  ASSERT_TRUE(on_border);
  for (double tile : {0.125, 0.0625, 0.25, 0.01})
    EXPECT_EQ(ced::detect_tiled(c, p, m, tile), whole.keypoints) << "tile size " << tile;
}

TEST(Tiles, SparseAndEmptyTiles) {
  // Two clusters far apart (every tile between them is empty), a few lone
  // points (tiles with fewer points than min_neighbors), and tiles smaller
  // than the radius (the halo outweighs the core).
  ced::point_cloud a = ced_test::make_room(3000, 11);
  ced::point_cloud c;
  std::vector<double> red;
  for (std::size_t i = 0; i < a.size(); ++i) {
    c.push_back(a.position(i)[0], a.position(i)[1], a.position(i)[2]);
    red.push_back(a.fields()[0].values[i]);
  }
  for (std::size_t i = 0; i < a.size(); ++i) {
    c.push_back(a.position(i)[0] + 3.0f, a.position(i)[1] + 2.0f, a.position(i)[2]);
    red.push_back(a.fields()[0].values[i]);
  }
  for (int k = 0; k < 4; ++k) {
    c.push_back(1.0f + 0.3f * float(k), 1.0f, 0.5f);
    red.push_back(100);
  }
  c.add_field("intensity", ced::scalar_type::uint8, red);
  ced::detect_params p;
  p.radius = 0.04;
  p.nms_radius = 0.04;
  for (double tile : {0.5, 0.2, 0.02}) expect_tiles_exact(c, p, {"xyz:0.2", "intensity:0.05"}, tile, "two clusters");
}

TEST(Tiles, PartsDecideDataDependentRangesFromTheWholeCloud) {
  // The corner with 16-bit colour makes the whole cloud's colour 16-bit; a
  // tile away from it must not take its own colour for 8-bit.
  const auto c = room16(8000, 5);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.02;
  const double lo[3] = {0, 0, 0}, hi[3] = {0.45, 0.45, 0.45};
  const auto g = ced::make_tile_grid(lo, hi, 0.15, p);
  const auto tile = ced::extract_tile(c, g, 2);  // x from 0.3: away from the 16-bit corner
  ASSERT_GT(tile.cloud.size(), 100u);
  for (std::size_t i = 0; i < tile.cloud.size(); ++i) ASSERT_LE(tile.cloud.fields()[0].values[i], 255.0);
  ASSERT_TRUE(tile.cloud.fields()[0].whole_range.has_value());
  EXPECT_EQ(tile.cloud.fields()[0].whole_range->hi, 40000.0);
  ced::point_cloud alone = tile.cloud;
  for (auto& f : alone.fields()) f.whole_range.reset();
  const auto m = specs({"rgb:0.1"});
  const auto with = ced::detect(tile.cloud, p, m), without = ced::detect(alone, p, m);
  EXPECT_NE(with.saliency[0], without.saliency[0]);
}

TEST(Tiles, BadTileSizesAreErrors) {
  ced::detect_params p;
  const double lo[3] = {0, 0, 0}, hi[3] = {1000, 1000, 10};
  for (double s : {0.0, -1.0, std::nan(""), double(INFINITY)})
    EXPECT_THROW(ced::make_tile_grid(lo, hi, s, p), std::invalid_argument);
  EXPECT_THROW(ced::make_tile_grid(lo, hi, 0.001, p), std::invalid_argument);  // 10^13 tiles
  try {
    ced::make_tile_grid(lo, hi, 0.001, p);
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("too small"), std::string::npos) << e.what();
  }
}

namespace {
/// A request for room16(n, seed) written as a LAS file (with `origin`): xyz + rgb, r = 0.02.
ced::tiled_request room_request(std::size_t n, std::uint32_t seed, const std::string& name, double tile,
                                const std::array<double, 3>& origin = {0, 0, 0}) {
  ced::point_cloud c = room16(n, seed);
  c.set_origin(origin);
  ced::tiled_request r;
  r.input = ced_test::temp_file(name);
  ced::io::write_cloud(r.input, c);
  r.tile_size = tile;
  r.params.radius = r.params.nms_radius = 0.02;
  r.modalities = {"xyz:0.2", "rgb:0.1"};
  return r;
}

void expect_same_part(const ced::tile_part& a, const ced::tile_part& b, const std::string& what) {
  EXPECT_EQ(a.index, b.index) << what;
  EXPECT_EQ(a.file_index, b.file_index) << what;
  EXPECT_EQ(a.keypoints.positions(), b.keypoints.positions()) << what;
  ASSERT_EQ(a.keypoints.fields().size(), b.keypoints.fields().size()) << what;
  for (std::size_t f = 0; f < a.keypoints.fields().size(); ++f) {
    const auto& x = a.keypoints.fields()[f];
    const auto& y = b.keypoints.fields()[f];
    EXPECT_EQ(x.name, y.name) << what;
    ASSERT_EQ(x.type(), y.type()) << what;
    EXPECT_EQ(0, std::memcmp(x.values.bytes(), y.values.bytes(), ced::size_of(x.type()) * a.index.size()))
        << what << ", field " << x.name;
  }
  EXPECT_EQ(a.saliency, b.saliency) << what;
  EXPECT_EQ(a.names, b.names) << what;
  EXPECT_EQ(a.candidates, b.candidates) << what;
  EXPECT_EQ(a.any_candidates, b.any_candidates) << what;
}
}  // namespace

TEST(Tiles, StreamedMergeOfPartFilesIsTheMergeInMemory) {
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

TEST(Tiles, AFailedMergeKeepsThePartsForResume) {
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

// ---------------------------------------------------------------- tampered plans and parts (issue #25)

namespace {
ced::tile_part detect_planned_tile(const ced::tile_plan& plan, std::uint64_t id) {
  return ced::detect_tile(plan, ced::read_tile(plan, id));
}
}  // namespace

TEST(Tiles, PartsOfAnotherPlanOrTamperedAreRefusedInMemory) {
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

TEST(Tiles, TamperedPlansAreRefusedOnLoad) {
  const ced::tiled_request r = room_request(3000, 22, "tamper_plan.las", 0.3);
  const ced::tile_plan p = ced::plan_tiles(r);
  const std::string json = p.to_json();
  EXPECT_NO_THROW(ced::tile_plan::from_json(json, "plan"));
  auto edited = [&](const std::string& from, const std::string& to) {
    const std::size_t at = json.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    std::string j = json;
    if (at != std::string::npos) j.replace(at, from.size(), to);
    return j;
  };
  const std::string halo = "\"halo\": " + nlohmann::json(p.grid.halo).dump();
  const std::string k = "\"min_neighbors\": 5";
  for (const std::string& bad :
       {edited(halo, "\"halo\": 0"), edited(k, "\"min_neighbors\": -1"), edited(k, "\"min_neighbors\": 2.5"),
        edited(k, "\"min_neighbors\": 4294967296"), edited("\"modalities\": [", "\"modalities\": [\"xyz:zero\", ")})
    EXPECT_THROW(ced::tile_plan::from_json(bad, "plan"), ced::io::io_error) << bad.substr(0, 400);
}

TEST(Tiles, ATileOfAChangedInputIsRefused) {
  const ced::tiled_request r = room_request(3000, 23, "changed_room.las", 0.3);
  const ced::tile_plan p = ced::plan_tiles(r);
  ASSERT_FALSE(p.content.empty());
  EXPECT_NO_THROW(ced::read_tile(p, p.tiles.front().id));
  // The same bytes but one point moved: the same size, maybe the same fingerprint.
  ced::point_cloud c = ced::io::read_cloud(r.input);
  c.positions()[3 * 1500] += 0.013f;
  ced::io::write_cloud(r.input, c);
  try {
    ced::read_tile(p, p.tiles.front().id);
    ADD_FAILURE() << "a changed input was read";
  } catch (const ced::io::io_error& e) {
    const std::string what = e.what();
    EXPECT_TRUE(what.find("changed since the plan") != std::string::npos ||
                what.find("not the file the plan was made for") != std::string::npos)
        << what;
  }
}
