// SPDX-License-Identifier: MIT
// Tiled runs, the plan (src/tiled/plan_file.cpp, fingerprint.cpp, detect_tile.cpp):
// a tampered plan is refused on load, a tile of a changed input when read.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>

#include "ced/io/io.hpp"
#include "ced/tiled.hpp"
#include "tiled_support.hpp"

namespace {
using ced_test::room_request;

/// `rows` rows of `cols` points 1 cm apart, row after row, with a wave in z
/// and in colour: the runs of its LAS file and the chunks of its LAZ file
/// are bands of rows.
ced::point_cloud rows_cloud(std::size_t rows, std::size_t cols) {
  ced::point_cloud c;
  c.resize(rows * cols);
  std::vector<std::array<std::uint8_t, 3>> rgb(rows * cols);
  for (std::size_t y = 0; y < rows; ++y)
    for (std::size_t x = 0; x < cols; ++x) {
      const std::size_t i = y * cols + x;
      float* p = c.positions().data() + 3 * i;
      p[0] = 0.01f * float(x);
      p[1] = 0.01f * float(y);
      p[2] = 0.02f * std::sin(0.07f * float(x)) * std::cos(0.05f * float(y));
      for (std::size_t k = 0; k < 3; ++k) rgb[i][k] = static_cast<std::uint8_t>((x * (k + 3) + y * (5 - k)) % 256);
    }
  c.add_rgb(rgb);
  return c;
}

/// Expects the same points (indices, positions, every field) in a and b.
void expect_same_points(const ced::tile_points& a, const ced::tile_points& b, const std::string& what) {
  EXPECT_EQ(a.index, b.index) << what;
  EXPECT_EQ(a.file_index, b.file_index) << what;
  ASSERT_EQ(a.cloud.size(), b.cloud.size()) << what;
  EXPECT_EQ(a.cloud.positions(), b.cloud.positions()) << what;
  ASSERT_EQ(a.cloud.fields().size(), b.cloud.fields().size()) << what;
  for (std::size_t f = 0; f < a.cloud.fields().size(); ++f)
    for (std::size_t i = 0; i < a.cloud.size(); ++i)
      ASSERT_EQ(a.cloud.fields()[f].values[i], b.cloud.fields()[f].values[i]) << what << " " << f << " " << i;
}
}  // namespace

TEST(TiledPlan, TamperedPlansAreRefusedOnLoad) {
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
  // Its runs: from the first point to the last, boxes ordered, hashes of 16 hex digits.
  const nlohmann::json j = nlohmann::json::parse(json);
  ASSERT_TRUE(j.contains("runs"));
  const auto run_edited = [&](std::size_t at, const nlohmann::json& v) {
    nlohmann::json e = j;
    e["runs"][0][at] = v;
    return e.dump();
  };
  for (const std::string& bad :
       {run_edited(0, 1), run_edited(1, 2999), run_edited(1, 0), run_edited(2, 1e9), run_edited(3, "x"),
        run_edited(8, "123"), run_edited(8, "zzzzzzzzzzzzzzzz"), run_edited(9, 0)})
    EXPECT_THROW(ced::tile_plan::from_json(bad, "plan"), ced::io::io_error) << bad.substr(bad.find("runs"), 200);
}

TEST(TiledPlan, ATileOfAChangedInputIsRefused) {
  const ced::tiled_request r = room_request(3000, 23, "changed_room.las", 0.3);
  const ced::tile_plan p = ced::plan_tiles(r);
  ASSERT_EQ(p.runs.size(), 1u);  // a LAS plan hashes each run of the file (here one) instead of all its points
  EXPECT_TRUE(p.content.empty());
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

TEST(TiledPlan, ATileOfLasReadsTheFileOnceWithThePlansFields) {
  // LAS and LAZ take their fields (the flags a whole pass finds) from the
  // plan, so a tile reads its runs (here the one run: the whole file) once,
  // not in two passes; its points are those of the whole file's read. CSV
  // has no runs: its tiles still make two passes.
  const ced::tiled_request r = room_request(6000, 24, "once.las", 0.3);
  const ced::tile_plan p = ced::plan_tiles(r);
  ASSERT_GT(p.tiles.size(), 1u);
  const ced::point_cloud whole = ced::io::read_cloud(r.input);
  for (const auto& t : p.tiles) {
    const ced::tile_points pts = ced::read_tile(p, t.id);
    EXPECT_EQ(pts.decoded, p.file_points);
    ASSERT_EQ(pts.cloud.fields().size(), p.tile_fields ? p.tile_fields->size() : p.fields.size());
    for (std::size_t i = 0; i < pts.cloud.size(); ++i) {
      const std::size_t w = static_cast<std::size_t>(pts.file_index[i]);
      for (int k = 0; k < 3; ++k) ASSERT_EQ(pts.cloud.position(i)[k], whole.position(w)[k]);
      for (const auto& f : pts.cloud.fields()) {
        const auto* g = whole.find_field(f.name);
        ASSERT_NE(g, nullptr) << f.name;
        ASSERT_EQ(f.values[i], g->values[w]) << f.name;
      }
    }
  }
  ced::tiled_request csv = r;
  csv.input = ced_test::temp_file("once.csv");
  ced::io::write_cloud(csv.input, whole);
  const ced::tile_plan q = ced::plan_tiles(csv);
  EXPECT_TRUE(q.runs.empty());
  EXPECT_EQ(ced::read_tile(q, q.tiles.front().id).decoded, 2 * q.file_points);
}

TEST(TiledPlan, ATileReadsOnlyTheRunsNearIt) {
  // 240,000 points in bands of rows: 4 runs of 65,536 points in LAS, binary
  // PLY and binary PCD, 5 LAZ chunks of 50,000. A tile of 1 m reads the 2
  // or 3 runs its band meets, and gets the points and keypoints of a read of
  // the whole file.
  for (const std::string ext : {".las", ".laz", ".ply", ".pcd"}) {
    ced::tiled_request r;
    r.input = ced_test::temp_file("rows" + ext);
    ced::io::write_cloud(r.input, rows_cloud(480, 500));
    r.tile_size = 1.0;
    r.params.radius = r.params.nms_radius = 0.03;
    r.modalities = {"xyz:0.2", "rgb:0.1"};
    const ced::tile_plan p = ced::tile_plan::from_json(ced::plan_tiles(r).to_json(), "plan");
    ASSERT_EQ(p.runs.size(), ext == ".laz" ? 5u : 4u);
    EXPECT_TRUE(p.content.empty());
    EXPECT_EQ(p.runs[1].first, p.runs[0].count);
    EXPECT_GT(p.runs[1].box[1], p.runs[0].box[4] - 0.02f);  // bands: the next run lies beyond
    ced::tile_plan whole = p;
    whole.runs.clear();  // reads the whole file instead
    std::size_t keypoints = 0;
    for (const auto& t : p.tiles) {
      const std::string what = ext + " tile " + std::to_string(t.id);
      const ced::tile_points a = ced::read_tile(p, t.id), b = ced::read_tile(whole, t.id);
      EXPECT_GE(a.runs_read, 1u) << what;
      EXPECT_LE(a.runs_read, 3u) << what;
      EXPECT_LT(a.decoded, p.file_points) << what;
      EXPECT_EQ(b.runs_read, 0u) << what;
      expect_same_points(a, b, what);
      const ced::tile_part pa = ced::detect_tile(p, a, 1), pb = ced::detect_tile(p, b, 1);
      ced_test::expect_same_part(pa, pb, what);
      keypoints += pa.index.size();
    }
    EXPECT_GT(keypoints, 0u) << ext;
  }
}

TEST(TiledPlan, ATileRefusesARunChangedSinceThePlan) {
  // One point moved in place: the tiles that read its run refuse the file,
  // naming the run; every run is read by some tile (the one that owns its
  // first point), so a run over all tiles cannot complete.
  ced::tiled_request r;
  r.input = ced_test::temp_file("moved_run.las");
  ced::point_cloud c = rows_cloud(300, 500);
  ced::io::write_cloud(r.input, c);
  r.tile_size = 1.0;
  r.params.radius = r.params.nms_radius = 0.03;
  r.modalities = {"xyz:0.2"};
  const ced::tile_plan p = ced::plan_tiles(r);
  ASSERT_EQ(p.runs.size(), 3u);
  const std::size_t moved = 70000;  // in the second run
  c.positions()[3 * moved + 2] += 0.01f;
  ced::io::write_cloud(r.input, c);
  std::size_t refused = 0;
  for (const auto& t : p.tiles) {
    try {
      const ced::tile_points pts = ced::read_tile(p, t.id);
      for (std::uint64_t i : pts.file_index) EXPECT_NE(i, moved) << t.id;
    } catch (const ced::io::io_error& e) {
      const std::string what = e.what();
      EXPECT_TRUE(what.find("changed since the plan") != std::string::npos ||
                  what.find("not the file the plan was made for") != std::string::npos)
          << what;
      ++refused;
    }
  }
  EXPECT_GE(refused, 1u);
  EXPECT_LT(refused, p.tiles.size());  // the tiles far from the run read on
}
