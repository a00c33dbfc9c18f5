// SPDX-License-Identifier: MIT
// Whole-cloud statistics in tiled runs: range=zscore, range=pLO..HI and pca=
// are computed from a sample of the whole cloud (field_sample()), which a
// plan gathers once and hands every tile (field::whole_sample). Tiled
// keypoints must equal the whole cloud's: in memory (detect_tiled), through
// run_tiled, and through a plan written as JSON and read back, as ced-mpi
// and the Dask example use it. Clouds larger than the sample (20,000
// points), so that it is a strict subset.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "ced/channels.hpp"
#include "ced/tile_geometry.hpp"
#include "ced/tiled.hpp"
#include "tiled_support.hpp"

namespace {

/// make_room(n, seed) with four bands of different scales and offsets:
/// smooth functions of position plus noise, and a few outliers in b2.
ced::point_cloud banded_room(std::size_t n, std::uint32_t seed) {
  ced::point_cloud c = ced_test::make_room(n, seed);
  std::mt19937 rng(seed + 1);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<std::vector<double>> b(4, std::vector<double>(c.size()));
  for (std::size_t i = 0; i < c.size(); ++i) {
    const float* p = c.position(i);
    b[0][i] = 1000.0 * (std::sin(20.0 * p[0]) + 0.2 * g(rng));
    b[1][i] = 5.0 + std::cos(17.0 * p[1]) + 0.2 * g(rng);
    b[2][i] = 0.01 * (std::sin(13.0 * p[2] + 3.0 * p[0]) + 0.2 * g(rng)) + (i % 997 == 0 ? 50.0 : 0.0);
    b[3][i] = 200.0 + 40.0 * std::sin(11.0 * (p[0] + p[1])) + 8.0 * g(rng);
  }
  for (std::size_t k = 0; k < 4; ++k) c.add_field("b" + std::to_string(k), ced::scalar_type::float32, b[k]);
  return c;
}

std::vector<std::uint64_t> as64(const std::vector<std::uint32_t>& v) { return {v.begin(), v.end()}; }

}  // namespace

class TiledWholeStats : public ::testing::TestWithParam<std::string> {};

// PLY (planned by passes) and LAS (run_tiled plans it from its header).
TEST_P(TiledWholeStats, TilesEqualTheWholeCloud) {
  const std::string input = ced_test::temp_file("whole_stats." + GetParam());
  ced::io::write_cloud(input, banded_room(26000, 5));
  const ced::point_cloud file = ced::io::read_cloud(input);
  ASSERT_GT(file.size(), ced::whole_sample_size);
  // Each spec, and the fields it reads (the only ones whose sample a plan carries).
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"bands(b?):0.3,range=zscore", "b0 b1 b2 b3"},
      {"bands(b0..b3):0.2,range=quantile", "b0 b1 b2 b3"},
      {"bands(b?):0.1,range=p5..95,norm=l2,pca=2", "b0 b1 b2 b3"},
      {"intensity(b3):0.15,range=zscore", "b3"},
      {"bands(b0,b1,b3):0.05,range=auto,pca=1", "b0 b1 b3"}};
  for (const auto& [spec, sampled] : cases) {
    SCOPED_TRACE(spec);
    ced::tiled_request r;
    r.input = input;
    r.tile_size = 0.3;
    r.params.radius = r.params.nms_radius = 0.03;
    r.modalities = {"xyz:0.2", spec};
    const auto mods = ced_test::specs(r.modalities);
    const auto whole = ced::detect(file, r.params, mods).keypoints;
    ASSERT_GT(whole.size(), 20u);
    // In memory.
    EXPECT_EQ(ced::detect_tiled(file, r.params, mods, r.tile_size), whole);
    // run_tiled: its plan carries the sample of the fields the spec reads, and nothing else.
    ced::tiled_run_options o;
    o.work_dir = ced_test::temp_file("whole_stats_work");
    ced::tile_plan used;
    EXPECT_EQ(ced::run_tiled(r, o, &used).index, as64(whole));
    for (const ced::plan_field& f : used.fields)
      EXPECT_EQ(bool(f.sample), (" " + sampled + " ").find(" " + f.name + " ") != std::string::npos) << f.name;
    // A plan written as JSON and read back, its tiles detected one by one.
    const ced::tile_plan plan = ced::tile_plan::from_json(ced::plan_tiles(r).to_json(), "plan.json");
    std::vector<ced::tile_part> parts;
    for (const ced::tile_entry& t : plan.tiles) parts.push_back(ced_test::detect_planned_tile(plan, t.id));
    EXPECT_EQ(ced::merge_parts(plan, std::move(parts)).index, as64(whole));
  }
}

INSTANTIATE_TEST_SUITE_P(Formats, TiledWholeStats, ::testing::Values("ply", "las"));

TEST(TiledWholeStatsSample, TheSampleIsTheWholeCloudsEvenlySpreadPoints) {
  const ced::point_cloud c = banded_room(26000, 8);
  const ced::field& f = *c.find_field("b1");
  const std::vector<double> s = ced::field_sample(f);
  ASSERT_EQ(s.size(), ced::whole_sample_size);
  for (std::size_t j = 0; j < s.size(); j += 997) {
    const std::uint64_t i = std::uint64_t(j) * c.size() / ced::whole_sample_size;
    EXPECT_EQ(ced::whole_sample_index(j, c.size()), i);
    EXPECT_EQ(s[j], f.values[i]) << j;
  }
  EXPECT_EQ(ced::whole_sample_index(ced::whole_sample_size - 1, c.size()), c.size() - 2);  // ⌊19999·26000/20000⌋
  // A small cloud: every point.
  const ced::field small("s", ced::scalar_type::float64, {3.0, 1.0, 2.0});
  EXPECT_EQ(ced::field_sample(small), (std::vector<double>{3.0, 1.0, 2.0}));
  // A tile with its whole cloud's sample decides as the whole cloud; without one it says so.
  ced::field tile("s", ced::scalar_type::float64, {1.0});
  tile.whole_range = ced::value_range{1, 3};
  EXPECT_THROW(ced::resolve_range(tile, ced::range_policy::parse("zscore")), std::invalid_argument);
  tile.whole_sample = std::make_shared<const std::vector<double>>(ced::field_sample(small));
  const auto want = ced::resolve_range(small, ced::range_policy::parse("p10..90"));
  const auto got = ced::resolve_range(tile, ced::range_policy::parse("p10..90"));
  EXPECT_EQ(got.lo, want.lo);
  EXPECT_EQ(got.hi, want.hi);
}

TEST(TiledWholeStatsSample, APlanWithAForgedSampleIsRefused) {
  const std::string input = ced_test::temp_file("whole_stats_forged.ply");
  ced::io::write_cloud(input, banded_room(4000, 6));
  ced::tiled_request r;
  r.input = input;
  r.tile_size = 0.3;
  r.params.radius = r.params.nms_radius = 0.03;
  r.modalities = {"xyz:0.2", "bands(b?):0.2,range=zscore"};
  const std::string json = ced::plan_tiles(r).to_json();
  const std::size_t key = json.find("\"sample\"");
  ASSERT_NE(key, std::string::npos);
  const std::size_t at = json.find('"', json.find(':', key)) + 1;  // the base64's first character
  // Cut short by four base64 characters (three bytes), and a character outside base64.
  std::string shorter = json, bad = json;
  shorter.erase(at, 4);
  bad[at + 2] = '#';
  for (const std::string& forged : {shorter, bad}) {
    try {
      (void)ced::tile_plan::from_json(forged, "forged.json");
      ADD_FAILURE() << "a forged sample was accepted";
    } catch (const ced::io::io_error& e) {
      EXPECT_NE(std::string(e.what()).find("has a sample that is not base64 of 4000 doubles"), std::string::npos)
          << e.what();
    }
  }
}
