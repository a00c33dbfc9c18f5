// SPDX-License-Identifier: MIT
// Neighbourhoods beyond the fixed ball: knn:K and adaptive:K (CGAL's
// k-nearest search), and the CGAL reference path for the fixed radius,
// each against an O(N²) brute-force oracle.

#include "neighborhoods_test_support.hpp"

using namespace neighborhoods_test;

TEST(Neighborhoods, ParseReadsEveryFormAndRoundTrips) {
  EXPECT_TRUE(ced::parse_neighborhood("radius").fixed());
  const auto k = ced::parse_neighborhood("knn:16");
  EXPECT_EQ(k.kind, ced::neighborhood_kind::knn);
  EXPECT_EQ(k.k, 16u);
  const auto a = ced::parse_neighborhood("adaptive:8,scale=1.5,min=0.01,max=0.2");
  EXPECT_EQ(a.kind, ced::neighborhood_kind::adaptive);
  EXPECT_EQ(a.k, 8u);
  EXPECT_EQ(a.scale, 1.5);
  EXPECT_EQ(a.min_radius, 0.01);
  EXPECT_EQ(a.max_radius, 0.2);
  EXPECT_EQ(ced::parse_neighborhood("adaptive:8").max_radius, std::numeric_limits<double>::infinity());
  for (const char* text : {"radius", "knn:16", "adaptive:8", "adaptive:8,scale=1.5,min=0.01,max=0.2", "knn:4,nms=own",
                           "adaptive:8,max=0.2,nms=own", "knn:16,reach=0.35", "adaptive:8,scale=2,nms=own,reach=1.5"}) {
    const auto parsed = ced::parse_neighborhood(text);
    EXPECT_EQ(ced::to_string(parsed), text);
    const auto again = ced::parse_neighborhood(ced::to_string(parsed));
    EXPECT_EQ(again.k, parsed.k);
    EXPECT_EQ(again.scale, parsed.scale);
    EXPECT_EQ(again.min_radius, parsed.min_radius);
    EXPECT_EQ(again.max_radius, parsed.max_radius);
    EXPECT_EQ(again.nms_own, parsed.nms_own);
    EXPECT_EQ(again.reach, parsed.reach);
  }
  EXPECT_EQ(ced::parse_neighborhood("knn:16,reach=0.35").reach, 0.35);
  EXPECT_TRUE(ced::parse_neighborhood("knn:4,nms=own").nms_own);
  EXPECT_FALSE(ced::parse_neighborhood("knn:4,nms=fixed").nms_own);
}

TEST(Neighborhoods, BadSpecsNameTheParameter) {
  const std::pair<const char*, const char*> bad[] = {
      {"knn", "needs K"},
      {"knn:0", "K in"},
      {"knn:65536", "K in"},
      {"knn:2.5", "K in"},
      {"knn:nan", "K in"},
      {"knn:-3", "K in"},
      {"knn:16,scale=2", "knn takes nms=, reach="},
      {"knn:16,reach=0", "reach must be"},
      {"knn:16,reach=-1", "reach must be"},
      {"adaptive:8,reach=nan", "reach="},
      {"knn:8,reach=1,reach=2", "given twice"},
      {"knn:16,nms=big", "nms= must be own or fixed"},
      {"adaptive:8,nms=own,nms=own", "given twice"},
      {"adaptive:8,scale=0", "scale must be"},
      {"adaptive:8,scale=-1", "scale must be"},
      {"adaptive:8,scale=nan", "scale="},
      {"adaptive:8,min=0.2,max=0.1", "is larger than max"},
      {"adaptive:8,min=-1", "min must be"},
      {"adaptive:8,max=0", "max must be"},
      {"adaptive:8,foo=1", "unknown option"},
      {"knn:8,", "an empty option"},  // (#57: accepted, while "adaptive:8,,max=1" was refused)
      {"adaptive:8,", "an empty option"},
      {"adaptive:8,max=1,", "an empty option"},
      {"knn:8,nms=own, ", "an empty option"},
      {"adaptive:8,,max=1", "an empty option"},
      {"adaptive:8,scale=1,scale=2", "given twice"},
      {"sphere", "must be radius, knn:K"},
  };
  for (const auto& [text, what] : bad) {
    try {
      ced::parse_neighborhood(text);
      ADD_FAILURE() << text << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << text << ": " << e.what();
    }
  }
  // Set directly, the same checks run in validate().
  ced::detect_params p;
  p.neighborhood.kind = ced::neighborhood_kind::adaptive;
  p.neighborhood.k = 8;
  p.neighborhood.max_radius = std::nan("");
  EXPECT_THROW(ced::validate(p), std::invalid_argument);
  p.neighborhood = ced::parse_neighborhood("knn:40");
  const auto c = scanned_room(30, 1);
  try {
    ced::detect(c, p, ced::xyz{});
    ADD_FAILURE() << "K > points accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("larger than the cloud"), std::string::npos) << e.what();
  }
}

TEST(Neighborhoods, KNearestIsExactWithTiesOnOneTreeAndOnAForest) {
  // A lattice (many equal distances) with duplicates, in a shuffled order.
  std::vector<float> xyz;
  for (int x = 0; x < 12; ++x)
    for (int y = 0; y < 12; ++y)
      for (int z = 0; z < 3; ++z)
        for (int copy = 0; copy < ((x + y + z) % 11 == 0 ? 3 : 1); ++copy)
          xyz.insert(xyz.end(), {x * 0.01f, y * 0.01f, z * 0.01f});
  const std::size_t n = xyz.size() / 3;
  std::vector<std::uint32_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = std::uint32_t((i * 7919) % n);
  ced::point_cloud c;
  for (std::size_t i = 0; i < n; ++i) c.push_back(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  const ced::neighbor_index one(xyz.data(), n);
  std::vector<ced::neighbor_index::ranked_point> got;
  for (std::size_t k : {1u, 2u, 7u, 19u, 27u, 64u}) {
    const lists expected = brute_knn(c, k);
    for (std::size_t i = 0; i < n; ++i) {
      one.k_nearest(&xyz[3 * i], k, std::uint32_t(i), got);
      ASSERT_EQ(got.size(), k);
      for (std::size_t q = 0; q < k; ++q) ASSERT_EQ(got[q].index, expected[i][q]) << "k " << k << " point " << i;
    }
  }
  // A forest: trees over runs of an order (what ball queries use).
  std::vector<float> big;
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> cell(0, 40);
  for (int i = 0; i < 40000; ++i) big.insert(big.end(), {cell(rng) * 0.01f, cell(rng) * 0.01f, cell(rng) * 0.01f});
  const std::size_t m = big.size() / 3;
  std::vector<std::uint32_t> runs(m);
  for (std::size_t i = 0; i < m; ++i) runs[i] = std::uint32_t(i);
  std::sort(runs.begin(), runs.end(), [&](std::uint32_t a, std::uint32_t b) { return big[3 * a] < big[3 * b]; });
  const ced::neighbor_index forest(big.data(), m, 32, 2, runs.data());
  const ced::neighbor_index tree(big.data(), m);
  std::vector<ced::neighbor_index::ranked_point> a, b;
  for (std::size_t q = 0; q < m; q += 37) {
    const std::uint32_t i = runs[q];
    forest.k_nearest(&big[3 * i], 20, i, a, q);
    tree.k_nearest(&big[3 * i], 20, i, b);
    ASSERT_EQ(a.size(), 20u);
    for (std::size_t t = 0; t < 20; ++t) ASSERT_EQ(a[t].index, b[t].index) << "point " << i;
    ASSERT_EQ(a[0].index, i);
    for (std::size_t t = 1; t + 1 < 20; ++t)
      ASSERT_TRUE(a[t].d2 < a[t + 1].d2 || (a[t].d2 == a[t + 1].d2 && a[t].index < a[t + 1].index));
  }
}

TEST(Neighborhoods, EveryKindMatchesTheBruteForceOracle) {
  const auto c = scanned_room(1800, 11);
  for (const auto& spec : kinds()) {
    SCOPED_TRACE(ced::to_string(spec));
    std::vector<double> radius;
    const lists nb = brute_neighborhoods(c, spec, radius);
    ced::detect_params p;
    p.neighborhood = spec;
    // nms=own: NMS balls of nms_radius / radius × r_i, far from nms_radius
    // where r_i is far from the radius.
    p.radius = spec.nms_own ? 0.05 : 0.04;
    p.nms_radius = 0.12;  // several points apart even where the scan is sparse
    std::atomic<int> wrong{0};
    ced::detect(c, p, list_check{&nb, &wrong});  // (its saliency 0 would zero every NMS score)
    EXPECT_EQ(wrong.load(), 0) << "neighbour lists differ";
    const auto r = ced::detect(c, p, ced::xyz{0.2}, ced::rgb{0.1});
    std::vector<double> per_unit(c.size());
    for (std::size_t i = 0; i < c.size(); ++i) per_unit[i] = radius[i] > 0 ? p.radius / radius[i] : 0.0;
    const auto o = ced_test::oracle_of_lists(
        c, {ced_test::xyz_channel(c, 0.2, p.radius), ced_test::field_channel(c, {"red", "green", "blue"}, 255, 0.1)},
        nb, p.nms_radius, p.min_neighbors, per_unit, spec.nms_own ? own_nms(r, p) : std::vector<float>{});
    ASSERT_EQ(r.point_radius.size(), c.size());
    for (std::size_t i = 0; i < c.size(); ++i) {
      ASSERT_EQ(r.neighbor_count[i], nb[i].size()) << "point " << i;
      ASSERT_EQ(r.point_radius[i], static_cast<float>(radius[i])) << "point " << i;
      for (std::size_t m = 0; m < 2; ++m)
        ASSERT_NEAR(r.saliency[m][i], o.saliency[m][i], 1e-5 * std::max(1.0, o.saliency[m][i]))
            << "modality " << m << " point " << i;
    }
    EXPECT_EQ(std::vector<std::uint8_t>(r.candidate.begin(), r.candidate.end()), o.candidate);
    EXPECT_EQ(r.keypoints, o.keypoints);
    if (spec.k > 1) {
      EXPECT_GT(o.keypoints.size(), 3u) << "fixture too easy";
    }
  }
}

TEST(Neighborhoods, AdaptiveRadiiFollowTheDensity) {
  // Far points get larger radii, and every point keeps enough neighbours:
  // the point of an adaptive neighbourhood on a scan.
  const auto c = scanned_room(3000, 5);
  ced::detect_params p;
  p.radius = 0.03;
  const auto fixed = ced::detect(c, p, ced::xyz{0.2});
  p.neighborhood = ced::parse_neighborhood("adaptive:10");
  const auto adaptive = ced::detect(c, p, ced::xyz{0.2});
  double near_r = 0, far_r = 0;
  std::size_t near_n = 0, far_n = 0, starved_fixed = 0, starved_adaptive = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const float* q = c.position(i);
    const double range = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
    if (range < 0.5) near_r += adaptive.point_radius[i], ++near_n;
    if (range > 1.5) far_r += adaptive.point_radius[i], ++far_n;
    starved_fixed += fixed.neighbor_count[i] < p.min_neighbors;
    starved_adaptive += adaptive.neighbor_count[i] < p.min_neighbors;
  }
  ASSERT_GT(near_n, 10u);
  ASSERT_GT(far_n, 10u);
  EXPECT_GT(far_r / double(far_n), 3 * near_r / double(near_n));
  EXPECT_GT(starved_fixed, c.size() / 10);
  EXPECT_EQ(starved_adaptive, 0u);
}

TEST(Neighborhoods, AnyThreadCountGivesBitwiseTheSameResult) {
  const auto c = scanned_room(6000, 2);
  std::vector<ced::neighborhood_spec> specs = kinds();
  specs.push_back({});  // the fixed radius on CGAL
  for (const auto& spec : specs) {
    SCOPED_TRACE(ced::to_string(spec));
    ced::detect_params p;
    p.neighborhood = spec;
    p.search = ced::search_kind::cgal;
    p.threads = 1;
    const auto one = ced::detect(c, p, {ced::make_modality("xyz"), ced::make_modality("rgb")});
    for (unsigned t : {2u, 3u, 8u}) {
      p.threads = t;
      const auto many = ced::detect(c, p, ced::xyz{0.2}, ced::rgb{0.1});
      EXPECT_EQ(many.saliency, one.saliency) << t << " threads";
      EXPECT_EQ(many.keypoints, one.keypoints) << t << " threads";
      EXPECT_EQ(many.point_radius, one.point_radius) << t << " threads";
    }
  }
}

TEST(Neighborhoods, CgalSearchGivesTheGridsKeypoints) {
  std::vector<ced::point_cloud> clouds;
  for (std::uint32_t seed : {1u, 2u, 3u}) clouds.push_back(ced_test::make_room(4000, seed));
  clouds.push_back(scanned_room(4000, 9));
  clouds.push_back(ced::io::read_cloud(CED_TEST_DATA_DIR "/apartment_mesh_214.ply"));
  for (std::size_t k = 0; k < clouds.size(); ++k) {
    for (const char* preset : {"ced6d", "ced3d", "robust6d"}) {
      SCOPED_TRACE(std::to_string(k) + " " + preset);
      ced::detect_params p;
      p.refine = ced::preset_refines(preset);
      const auto grid = ced::detect(clouds[k], p, ced::preset(preset));
      p.search = ced::search_kind::cgal;
      const auto tree = ced::detect(clouds[k], p, ced::preset(preset));
      EXPECT_EQ(tree.keypoints, grid.keypoints);
      EXPECT_EQ(tree.neighbor_count, grid.neighbor_count);
      EXPECT_TRUE(tree.point_radius.empty());
      for (std::size_t m = 0; m < grid.saliency.size(); ++m)
        for (std::size_t i = 0; i < clouds[k].size(); ++i)
          ASSERT_NEAR(tree.saliency[m][i], grid.saliency[m][i], 1e-5 * std::max(1.0f, grid.saliency[m][i]));
    }
  }
}

TEST(Neighborhoods, NearestOnTheGridAreCgalsOnEveryDensity) {
  // The grid's k nearest (balls of a bound sampled with CGAL, asked again
  // when short, then CGAL's own search) against CGAL's search for every
  // point: a sensor-like falloff, a lattice of exact ties and duplicates,
  // and a dense cluster among sparse points (every block's bound too small
  // for some of its points). The grid's selection runs on every build the
  // CPU has (AVX-512, AVX2, generic), alike.
  std::vector<ced::point_cloud> clouds{scanned_room(6000, 21)};
  ced::point_cloud lattice;
  for (int x = 0; x < 30; ++x)
    for (int y = 0; y < 30; ++y)
      for (int copy = 0; copy < ((x + y) % 7 == 0 ? 2 : 1); ++copy) lattice.push_back(x * 0.01f, y * 0.01f, 0.0f);
  clouds.push_back(lattice);
  ced::point_cloud mixed;
  std::mt19937 rng(5);
  std::normal_distribution<float> tight(0.0f, 0.01f);
  std::uniform_real_distribution<float> wide(-1.0f, 1.0f);
  for (int i = 0; i < 3000; ++i)
    if (i % 10 == 0)
      mixed.push_back(wide(rng), wide(rng), wide(rng));
    else
      mixed.push_back(tight(rng), tight(rng), tight(rng));
  clouds.push_back(mixed);
  for (std::size_t c = 0; c < clouds.size(); ++c)
    for (const char* spec :
         {"knn:1", "knn:2", "knn:9", "knn:24", "knn:40", "adaptive:16,min=0.02", "adaptive:5,scale=2"}) {
      SCOPED_TRACE(std::to_string(c) + " " + spec);
      ced::detect_params p;
      p.neighborhood = ced::parse_neighborhood(spec);
      p.min_neighbors = 1;
      std::vector<ced::detection_result> builds;  // the grid search, on every build this CPU runs
      for (const std::string& isa : ced::detail::kernel_isas()) {
        ced::detail::force_kernel_isa(isa);
        builds.push_back(ced::detect(clouds[c], p, {ced::make_modality("xyz")}));
      }
      ced::detail::force_generic_kernel(false);
      p.search = ced::search_kind::cgal;
      const auto tree = ced::detect(clouds[c], p, {ced::make_modality("xyz")});
      for (const auto* r = builds.data(); r != builds.data() + builds.size(); ++r) {
        EXPECT_EQ(r->point_radius, tree.point_radius);
        EXPECT_EQ(r->neighbor_count, tree.neighbor_count);
        EXPECT_EQ(r->saliency, tree.saliency);  // the same lists, summed alike
        EXPECT_EQ(r->keypoints, tree.keypoints);
      }
    }
}

TEST(Neighborhoods, NormalsAreEstimatedOverTheNeighbourhood) {
  // Under knn:K the K nearest, under adaptive the ball of factor × r_i:
  // bitwise the normals of the brute-force lists (sorted by index).
  const auto c = scanned_room(2500, 14);
  const float* xyz = c.positions().data();
  for (const auto& [spec, factor] : std::vector<std::pair<const char*, double>>{
           {"knn:12", 1.0}, {"adaptive:10,scale=1.5", 1.0}, {"knn:16", 0.6}, {"adaptive:8,min=0.03", 0.5}}) {
    SCOPED_TRACE(std::string(spec) + " factor " + std::to_string(factor));
    ced::detect_params p;
    p.radius = 0.02;
    p.neighborhood = ced::parse_neighborhood(spec);
    const auto got = ced::estimate_normals(c, p, factor);
    const auto scaled = factor == 1 ? p : ced::scaled_params(p, factor);
    std::vector<double> radius;
    const lists nb = brute_neighborhoods(c, scaled.neighborhood, radius);
    int wrong = 0;
    for (std::size_t i = 0; i < c.size(); ++i) {
      float want[3];
      ced::normal_from_neighbors(xyz, std::uint32_t(i), nb[i].data(), std::uint32_t(nb[i].size()), want);
      wrong += std::memcmp(want, &got[3 * i], sizeof want) != 0;
    }
    EXPECT_EQ(wrong, 0);
  }
  // The fixed radius: as before. Far, sparse points: none within r, but
  // their K nearest give them a normal.
  ced::detect_params p;
  p.radius = 0.02;
  EXPECT_EQ(ced::estimate_normals(c, p, 0.5), ced::estimate_normals(c, 0.01));
  const auto fixed = ced::estimate_normals(c, 0.02);
  p.neighborhood = ced::parse_neighborhood("knn:12");
  const auto knn = ced::estimate_normals(c, p);
  std::size_t none_fixed = 0, none_knn = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    none_fixed += fixed[3 * i] == 0 && fixed[3 * i + 1] == 0 && fixed[3 * i + 2] == 0;
    none_knn += knn[3 * i] == 0 && knn[3 * i + 1] == 0 && knn[3 * i + 2] == 0;
  }
  EXPECT_GT(none_fixed, 100u);
  EXPECT_LT(none_knn, none_fixed / 10);
}

TEST(Neighborhoods, DistancesArePerUnitOfTheOwnRadiusOnly) {
  // Under knn, xyz (threshold ∝ radius) is scaled by radius / r_i; rgb
  // (threshold independent of it) is not; a scaled xyz is, at its own scale.
  const auto c = scanned_room(2000, 4);
  ced::detect_params p;
  p.neighborhood = ced::parse_neighborhood("knn:12");
  const auto r = ced::detect(c, p, {ced::make_modality("xyz"), ced::make_modality("rgb")});
  std::atomic<int> wrong{0};
  std::vector<double> radius;
  const lists nb = brute_neighborhoods(c, p.neighborhood, radius);
  const auto raw = ced::detect(c, p, ced::rgb{0.1}, list_check{&nb, &wrong});
  EXPECT_EQ(wrong.load(), 0);
  EXPECT_EQ(r.saliency[1], raw.saliency[0]);  // rgb untouched
  std::size_t scaled = 0;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (r.saliency[0][i] > 0 && std::abs(radius[i] - p.radius) > 1e-3) ++scaled;
  EXPECT_GT(scaled, c.size() / 2);
  // A modality spec with scale= measures over 2·r_i: its threshold doubles.
  const auto s = ced::detect(c, p, {ced::make_modality("xyz:0.2,scale=2")});
  EXPECT_DOUBLE_EQ(s.thresholds[0], 0.2 * 2 * p.radius);
}
