// SPDX-License-Identifier: MIT
// Tiled runs, the plan (src/tiled/plan_file.cpp, fingerprint.cpp, detect_tile.cpp):
// a tampered plan is refused on load, a tile of a changed input when read.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

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
