// SPDX-License-Identifier: MIT
// Tiled runs, the plan (src/tiled/plan_file.cpp, fingerprint.cpp, detect_tile.cpp):
// a tampered plan is refused on load, a tile of a changed input when read.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "ced/io/io.hpp"
#include "ced/tiled.hpp"
#include "tiled_support.hpp"

namespace {
using ced_test::room_request;
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
}

TEST(TiledPlan, ATileOfAChangedInputIsRefused) {
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

TEST(TiledPlan, ATileOfLasReadsTheFileOnceWithThePlansFields) {
  // LAS and LAZ take their fields (the flags a whole pass finds) from the
  // plan, so a tile makes one pass over the file, not two; its points are
  // those of the whole file's read. Other formats still make two passes.
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
  ced::tiled_request ply = r;
  ply.input = ced_test::temp_file("once.ply");
  ced::io::write_cloud(ply.input, whole);
  const ced::tile_plan q = ced::plan_tiles(ply);
  EXPECT_EQ(ced::read_tile(q, q.tiles.front().id).decoded, 2 * q.file_points);
}
