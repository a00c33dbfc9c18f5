// SPDX-License-Identifier: MIT
// Neighbourhoods beyond the fixed ball in tiles: the reach tiles take for knn:K and
// adaptive:K, and tiled runs that find it themselves, exact against the whole cloud.

#include "neighborhoods_test_support.hpp"

using namespace neighborhoods_test;

TEST(Neighborhoods, TilesStayExactForNeighbourhoodsOfBoundedReach) {
  // Far points of the scan have k-distances of several cm: adaptive radii
  // up to max reach well past radius + block side, so a halo sized from
  // the radius alone would cut their neighbourhoods.
  const auto c = scanned_room(5000, 8);
  const std::vector<ced::any_modality> mods = {ced::make_modality("xyz"), ced::make_modality("rgb"),
                                               ced::make_modality("normals")};
  for (const char* spec : {"adaptive:12,scale=1.5,max=0.3", "adaptive:64,scale=0.3,max=0.3",
                           "adaptive:10,min=0.03,max=0.2", "adaptive:16,max=0.25,nms=own", "radius"}) {
    SCOPED_TRACE(spec);
    ced::detect_params p;
    p.radius = 0.02;
    p.neighborhood = ced::parse_neighborhood(spec);
    p.nms_radius = p.neighborhood.nms_own ? 0.1 : 0.03;  // own NMS balls up to 0.1 / 0.02 × max
    p.search = ced::search_kind::cgal;
    const auto whole = ced::detect(c, p, mods);
    ASSERT_GT(whole.keypoints.size(), 20u);
    for (double tile : {0.35, 0.7}) EXPECT_EQ(ced::detect_tiled(c, p, mods, tile), whole.keypoints) << tile;
    p.refine = true;
    EXPECT_EQ(ced::detect_tiled(c, p, mods, 0.5), ced::detect(c, p, mods).keypoints) << "refined";
  }
}

/// The farthest any point of `r` reaches under `spec` (what reach= must bound).
double farthest_reach(const ced::detection_result& r, const ced::neighborhood_spec& spec) {
  double far = 0;
  for (float ri : r.point_radius)
    far = std::max(far, spec.kind == ced::neighborhood_kind::knn ? double(ri) : std::max(double(ri), ri / spec.scale));
  return far;
}

TEST(Neighborhoods, TilesWithOrWithoutAReachAreExactOrStopClearly) {
  // A falloff scan: k-distances from a few mm to several cm. Without
  // reach=, the tiles take one of their own, which a guess from the mean
  // density makes short for some neighbourhoods: they grow it, and every
  // tiling equals the whole run. With reach= just above the farthest, so do
  // they; with half of it, a tile stops with an error that names the
  // distance it needs.
  const auto c = scanned_room(5000, 12);
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k) lo[k] = hi[k] = c.position(0)[k];
  for (std::size_t i = 0; i < c.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(c.position(i)[k]));
      hi[k] = std::max(hi[k], double(c.position(i)[k]));
    }
  // Normals under knn: each neighbour's own K nearest, one hop farther.
  const std::vector<ced::any_modality> mods = {ced::make_modality("xyz"), ced::make_modality("rgb"),
                                               ced::make_modality("normals")};
  int grown = 0;
  for (const char* spec :
       {"knn:12", "knn:32", "adaptive:10,scale=1.5", "adaptive:8,min=0.03", "knn:16,nms=own", "adaptive:12,nms=own"}) {
    SCOPED_TRACE(spec);
    ced::detect_params p;
    p.radius = 0.02;
    p.neighborhood = ced::parse_neighborhood(spec);
    p.nms_radius = p.neighborhood.nms_own ? 0.05 : 0.03;
    const auto whole = ced::detect(c, p, mods);
    ASSERT_GT(whole.keypoints.size(), 20u);
    const double far = farthest_reach(whole, p.neighborhood);
    for (double tile : {0.35, 0.7}) {
      double used = 0;
      EXPECT_EQ(ced::detect_tiled(c, p, mods, tile, &used), whole.keypoints) << "no reach=, " << tile;
      EXPECT_GE(used, far) << tile;  // every point is some tile's core
      grown += used > ced::estimated_reach(p, lo, hi, c.size());
    }
    p.neighborhood.reach = far * 1.01;
    for (double tile : {0.35, 0.7}) EXPECT_EQ(ced::detect_tiled(c, p, mods, tile), whole.keypoints) << tile;
    p.refine = true;
    EXPECT_EQ(ced::detect_tiled(c, p, mods, 0.5), ced::detect(c, p, mods).keypoints) << "refined";
    p.neighborhood.reach = far / 2;
    try {
      ced::detect_tiled(c, p, mods, 0.5);
      ADD_FAILURE() << "a reach of half the farthest was accepted";
    } catch (const ced::tile_reach_error& e) {
      EXPECT_NE(std::string(e.what()).find("beyond the neighbourhood's reach"), std::string::npos) << e.what();
    }
  }
  // A reach well past the blocks' part of the halo (a small radius): the
  // normals' second hop must come from the reach itself.
  for (const char* spec : {"knn:16", "adaptive:12,max=0.15"}) {
    SCOPED_TRACE(std::string("small radius ") + spec);
    ced::detect_params p;
    p.radius = 0.003;
    p.nms_radius = 0.005;
    p.neighborhood = ced::parse_neighborhood(spec);
    const std::vector<ced::any_modality> normals = {ced::make_modality("normals:0.05")};
    const auto whole = ced::detect(c, p, normals);
    ASSERT_GT(whole.keypoints.size(), 20u);
    if (p.neighborhood.kind == ced::neighborhood_kind::knn)
      p.neighborhood.reach = farthest_reach(whole, p.neighborhood) * 1.01;
    for (double tile : {0.2, 0.45}) EXPECT_EQ(ced::detect_tiled(c, p, normals, tile), whole.keypoints) << tile;
  }
  EXPECT_GT(grown, 0) << "no neighbourhood needed a second try: the test misses the growth";
  // A tile of fewer than K points: its points reach farther than any bound.
  // Without reach= it measures nothing, and the reach grows fourfold until
  // the tiles hold enough.
  ced::point_cloud sparse;
  for (int i = 0; i < 40; ++i) sparse.push_back(float(i) * 0.2f, 0.0f, 0.0f);
  ced::detect_params p;
  const std::vector<ced::any_modality> xyz = {ced::make_modality("xyz")};
  p.neighborhood = ced::parse_neighborhood("knn:16,reach=0.5");
  EXPECT_THROW(ced::detect_tiled(sparse, p, xyz, 1.0), ced::tile_reach_error);
  p.neighborhood = ced::parse_neighborhood("knn:16");
  double used = 0;
  EXPECT_EQ(ced::detect_tiled(sparse, p, xyz, 1.0, &used), ced::detect(sparse, p, xyz).keypoints);
  EXPECT_GE(used, 3.0 - 1e-6);  // the ends' 16th nearest is 15 steps of 0.2 away
  p.neighborhood = ced::parse_neighborhood("knn:41");
  EXPECT_THROW(ced::detect_tiled(sparse, p, xyz, 1.0), std::invalid_argument);
}

TEST(Neighborhoods, TheReachTilesTakeIsRoundedUpAndGrown) {
  // Two significant digits, never below what was measured.
  EXPECT_EQ(ced::grown_reach(1.3, 5.026), 5.1);
  EXPECT_EQ(ced::grown_reach(0.1, 0.43), 0.43);
  EXPECT_EQ(ced::grown_reach(0.1, 0.4300001), 0.44);
  EXPECT_EQ(ced::grown_reach(10, 123.4), 130);
  EXPECT_EQ(ced::grown_reach(0.001, 0.0123), 0.013);
  EXPECT_EQ(ced::grown_reach(0.5, std::numeric_limits<double>::infinity()), 2.0);  // a tile of < K points
  EXPECT_EQ(ced::grown_reach(0.5, 0.4), 2.0);                                      // measured no farther
  EXPECT_EQ(ced::grown_reach(0.5, 3.01, true), 3.1);  // a tile unmeasured, another measured farther
  EXPECT_EQ(ced::grown_reach(0.5, 0.61, true), 2.0);  // a tile unmeasured: at least four times
  // A first guess from the density: N points on a 1 m × 2 m face lie
  // sqrt(2 / N) apart; K of them fill a disc of sqrt(K · 2 / (π N)).
  ced::detect_params p;
  p.neighborhood = ced::parse_neighborhood("knn:16");
  const double lo[3] = {0, 0, 0}, hi[3] = {1, 2, 0.1};
  const double d = std::sqrt(16 * 2.0 / (3.141592653589793 * 20000));
  EXPECT_EQ(ced::estimated_reach(p, lo, hi, 20000), ced::grown_reach(0, 3 * d));
  p.neighborhood = ced::parse_neighborhood("adaptive:16,scale=0.5");  // reaches 3d, radius 1.5d
  EXPECT_EQ(ced::estimated_reach(p, lo, hi, 20000), ced::grown_reach(0, 3 * d));
  p.neighborhood = ced::parse_neighborhood("adaptive:16,min=0.5");
  EXPECT_EQ(ced::estimated_reach(p, lo, hi, 20000), 0.5);
  const double line[3] = {0, 0, 0}, one[3] = {0, 0, 0}, far[3] = {4, 0, 0};
  p.neighborhood = ced::parse_neighborhood("knn:8");
  EXPECT_EQ(ced::estimated_reach(p, line, far, 100), ced::grown_reach(0, 3 * 8 * 4.0 / 200));
  EXPECT_GT(ced::estimated_reach(p, one, one, 100), 0.0);  // all at one place: still a reach
  EXPECT_TRUE(ced::unbounded_reach(ced::parse_neighborhood("knn:8")));
  EXPECT_TRUE(ced::unbounded_reach(ced::parse_neighborhood("adaptive:8,min=0.1")));
  EXPECT_FALSE(ced::unbounded_reach(ced::parse_neighborhood("adaptive:8,max=0.1")));
  EXPECT_FALSE(ced::unbounded_reach(ced::parse_neighborhood("knn:8,reach=0.1")));
  EXPECT_FALSE(ced::unbounded_reach(ced::parse_neighborhood("radius")));
}

TEST(Neighborhoods, TilesWithoutAReachPlanOneAndPlansKeepTheSpec) {
  ced::tiled_request q;
  q.input = CED_TEST_DATA_DIR "/apartment_mesh_214.ply";
  q.tile_size = 1;
  q.modalities = {"xyz"};
  for (const char* spec : {"knn:8", "adaptive:8", "adaptive:8,scale=2"}) {
    SCOPED_TRACE(spec);
    q.params.neighborhood = ced::parse_neighborhood(spec);
    const ced::tile_plan plan = ced::plan_tiles(q);
    const ced::tile_plan back = ced::tile_plan::from_json(plan.to_json(), "plan.json");
    EXPECT_TRUE(back.request.reach_estimated);
    const ced::neighborhood_spec& n = back.request.params.neighborhood;
    ASSERT_TRUE(std::isfinite(n.reach));
    EXPECT_EQ(ced::to_string(n).rfind(std::string(spec) + ",reach=", 0), 0u) << ced::to_string(n);
    EXPECT_EQ(back.digest(), plan.digest());
    EXPECT_GE(back.grid.halo, n.reach * 1.001);
  }
  // "reach_estimated" without a reach is not a plan ced writes.
  std::string text = ced::plan_tiles(q).to_json();
  const std::size_t at = text.find(",reach=");
  ASSERT_NE(at, std::string::npos);
  text.erase(at, text.find('"', at) - at);
  EXPECT_THROW(ced::tile_plan::from_json(text, "plan.json"), ced::io::io_error);
  // A bounded one plans, and its plan file keeps the neighbourhood and search.
  q.params.neighborhood = ced::parse_neighborhood("adaptive:8,scale=1.5,max=0.1");
  q.params.search = ced::search_kind::cgal;
  const ced::tile_plan plan = ced::plan_tiles(q);
  const ced::tile_plan back = ced::tile_plan::from_json(plan.to_json(), "plan.json");
  EXPECT_EQ(ced::to_string(back.request.params.neighborhood), "adaptive:8,scale=1.5,max=0.1");
  EXPECT_FALSE(back.request.reach_estimated);
  EXPECT_EQ(back.request.params.search, ced::search_kind::cgal);
  EXPECT_GE(back.grid.halo, 0.1 * 1.001);
  // knn with reach= plans too, its halo covering the reach.
  q.params.neighborhood = ced::parse_neighborhood("knn:12,reach=0.2");
  const ced::tile_plan with_reach = ced::tile_plan::from_json(ced::plan_tiles(q).to_json(), "plan.json");
  EXPECT_EQ(ced::to_string(with_reach.request.params.neighborhood), "knn:12,reach=0.2");
  EXPECT_FALSE(with_reach.request.reach_estimated);
  EXPECT_GE(with_reach.grid.halo, 0.2 * 1.001);
}

TEST(Neighborhoods, TiledRunsGrowTheirOwnReachAndResumeWithIt) {
  // A file of the falloff scan, run in a work directory: the first reach is
  // short, every tile runs again with the one they measured, and the
  // result is the whole run's. A run stopped after planning resumes
  // without reach=, taking the plan's.
  const auto c = scanned_room(5000, 12);
  ced::tiled_request r;
  r.input = ced_test::temp_file("falloff_room.ply");
  ced::io::write_cloud(r.input, c);
  r.tile_size = 0.35;
  r.modalities = {"xyz:0.1", "rgb:0.1"};
  r.params.radius = 0.02;
  r.params.nms_radius = 0.03;
  r.params.neighborhood = ced::parse_neighborhood("knn:32");
  const auto whole = ced::detect(ced::io::read_cloud(r.input), r.params, ced_test::specs(r.modalities)).keypoints;
  ASSERT_GT(whole.size(), 20u);
  ced::tiled_run_options o;
  o.work_dir = ced_test::temp_file("falloff_work");
  std::vector<double> tried;
  std::size_t short_tiles = 0;
  o.reach_grown = [&](double t, double needed, double next, std::size_t tiles) {
    tried.push_back(t);
    short_tiles = tiles;
    EXPECT_GT(needed, t);  // +infinity: a tile of fewer than K points
    EXPECT_GE(next, std::isfinite(needed) ? needed : 4 * t);
  };
  ced::tile_plan plan;
  const ced::tile_part merged = ced::run_tiled(r, o, &plan);
  // The tiles that passed the first try kept their parts (the second
  // detects only the short ones), and the merge is still the whole run's.
  EXPECT_EQ(merged.index, std::vector<std::uint64_t>(whole.begin(), whole.end()));
  ASSERT_EQ(tried.size(), 1u) << "the first reach was not short: the test misses the growth";
  EXPECT_GE(short_tiles, 1u);
  EXPECT_LT(short_tiles, plan.tiles.size()) << "every tile was short: the test misses the kept parts";
  EXPECT_TRUE(plan.request.reach_estimated);
  EXPECT_GT(plan.request.params.neighborhood.reach, tried.front());
  EXPECT_FALSE(std::filesystem::exists(o.work_dir));
  // Stopped after the plan and cache (prepare_tiled), then resumed with the request as asked.
  const ced::tile_plan first = ced::prepare_tiled(r, o);
  EXPECT_TRUE(first.request.reach_estimated);
  o.resume = true;
  tried.clear();
  EXPECT_EQ(ced::run_tiled(r, o).index, std::vector<std::uint64_t>(whole.begin(), whole.end()));
  EXPECT_EQ(tried.size(), 1u);
  EXPECT_FALSE(std::filesystem::exists(o.work_dir));
  // A reach the caller gives is a promise: short, the run stops and says so.
  r.params.neighborhood = ced::parse_neighborhood("knn:32,reach=0.01");
  o.resume = false;
  EXPECT_THROW(ced::run_tiled(r, o), ced::tile_reach_error);
  EXPECT_FALSE(std::filesystem::exists(o.work_dir));
}

/// A modality whose channel (here the point's own radius, as a stand-in)
/// comes from each point's neighbourhood, and says so.
struct neighbourhood_channel {
  std::string name() const { return "neighbourhood_channel"; }
  double threshold(const ced::detect_params&) const { return 0.1; }
  std::vector<std::string> fields() const { return {}; }
  bool channels_from_neighborhoods() const { return true; }
  ced::centroid_distance<1> bind(const ced::point_cloud& c, const ced::detect_params&) const {
    return ced::centroid_distance<1>(std::vector<float>(c.size(), 0.0f), {1.0}, ced::norm_type::l1);
  }
};

// A modality that reads its neighbours' neighbourhoods (normals under knn)
// makes a tile depend on points one reach beyond its NMS term: the tile
// checks those too (tile_check_extra), so that a tile detected on its own
// (ced detect --plan --tile, one MPI rank) stops clearly instead of giving a
// wrong part. Here a lone point X, far from its K nearest, lies beyond the
// NMS term of tile 0's core but within one reach of it.
TEST(Neighborhoods, TilesCheckOneReachFartherForNeighbourhoodChannels) {
  ced::point_cloud c;
  for (int i = 0; i <= 200; ++i)  // a strip x in [0, 1], 5 mm spacing
    for (int j = 0; j < 5; ++j) c.push_back(0.005f * float(i), 0.005f * float(j), 0.0f);
  const float x[3] = {0.535f, 0.01f, 0.2f};  // in tile 1's core; 0.035 from tile 0's; 0.2 from the strip
  c.push_back(x[0], x[1], x[2]);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.01;
  p.min_neighbors = 1;
  p.neighborhood = ced::parse_neighborhood("knn:4,reach=0.05");
  const std::vector<ced::any_modality> mods = {ced::make_modality("xyz"), ced::make_modality("normals")};
  const double extra = ced::tile_check_extra(p, mods);
  EXPECT_EQ(extra, 0.05);  // one reach
  EXPECT_EQ(ced::tile_check_extra(p, {ced::make_modality("xyz")}), 0.0);
  // Read normals depend on the point alone; any modality that says its
  // channel comes from each point's neighbourhood reaches farther, scaled too.
  EXPECT_EQ(ced::tile_check_extra(p, {ced::make_modality("normals:0.2,from=fields")}), 0.0);
  EXPECT_EQ(ced::tile_check_extra(p, {ced::make_modality("normals:0.2,from=estimate")}), 0.05);
  EXPECT_EQ(ced::tile_check_extra(p, {neighbourhood_channel{}}), 0.05);
  EXPECT_EQ(ced::tile_check_extra(p, {ced::scaled<neighbourhood_channel>{{}, 2.0}}), 0.1);
  EXPECT_EQ(ced::tile_check_extra(p, {ced::scaled_modality(neighbourhood_channel{}, 2.0)}), 0.1);
  EXPECT_EQ(ced::tile_halo_params(p, {neighbourhood_channel{}}).neighborhood.reach, 0.1);  // twice the reach
  ced::detect_params fixed = p;
  fixed.neighborhood = ced::neighborhood_spec{};
  EXPECT_EQ(ced::tile_check_extra(fixed, {neighbourhood_channel{}}), 0.0);  // within the radius: the usual halo

  const double lo[3] = {0, 0, 0}, hi[3] = {1.0, 0.02, 0.2};
  const ced::tile_grid grid = ced::make_tile_grid(lo, hi, 0.5, ced::tile_halo_params(p, mods));
  ASSERT_EQ(grid.tile_of(x), 1u);
  ced::point_cloud tile0;  // tile 0's core and halo
  std::vector<std::uint64_t> near;
  for (std::size_t i = 0; i < c.size(); ++i) {
    grid.tiles_near(c.position(i), near);
    if (near.front() == 0) tile0.push_back(c.position(i)[0], c.position(i)[1], c.position(i)[2]);
  }
  ASSERT_EQ(tile0.position(tile0.size() - 1)[2], x[2]);  // X is in tile 0's halo
  const auto r = ced::detect(tile0, p, mods);
  ASSERT_GT(r.point_radius.back(), 0.05f);  // X reaches farther than reach=
  EXPECT_THROW(ced::check_tile_reach(grid, 0, tile0, &r, p, extra), ced::tile_reach_error);
  EXPECT_NO_THROW(ced::check_tile_reach(grid, 0, tile0, &r, p, 0.0));  // the NMS term alone misses X
  // The whole run stops too (tile 0 first), and names the distance X needs.
  try {
    ced::detect_tiled(c, p, mods, 0.5);
    ADD_FAILURE() << "no error";
  } catch (const ced::tile_reach_error& e) {
    EXPECT_NE(std::string(e.what()).find("tile 0"), std::string::npos) << e.what();
  }
}
