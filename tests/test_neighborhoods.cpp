// SPDX-License-Identifier: MIT
// Neighbourhoods beyond the fixed ball: knn:K and adaptive:K (CGAL's
// k-nearest search), and the CGAL reference path for the fixed radius,
// each against an O(N²) brute-force oracle.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/io/io.hpp"
#include "ced/tiled.hpp"
#include "core/kernel/dispatch.hpp"
#include "core/neighbor_block.hpp"
#include "core/neighbor_index.hpp"
#include "test_support.hpp"
#include "tiled_support.hpp"

namespace {

using lists = std::vector<std::vector<std::uint32_t>>;

/// A room scanned from one corner: floor, two walls and a box, each point
/// kept with a probability that falls with the square of its range, so the
/// spacing grows from about 5 mm near the sensor to several cm far away.
/// Coloured patches; a few exact duplicates (ties at distance 0).
ced::point_cloud scanned_room(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  ced::point_cloud c;
  std::vector<double> red, green, blue;
  while (c.size() < n) {
    float p[3] = {u(rng) * 2.0f, u(rng) * 2.0f, u(rng) * 2.0f};
    const int surface = int(u(rng) * 4);
    if (surface == 0) p[2] = 0;
    if (surface == 1) p[0] = 0;
    if (surface == 2) p[1] = 0;
    if (surface == 3) {  // a box face at z = 0.3 over [0.8, 1.2]²
      p[0] = 0.8f + 0.4f * u(rng), p[1] = 0.8f + 0.4f * u(rng), p[2] = 0.3f;
    }
    const float range2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    if (u(rng) > std::min(1.0f, 0.15f / range2)) continue;
    const bool patch = p[0] > 0.5f && p[0] < 1.0f && p[1] < 0.6f;
    const int copies = c.size() % 97 == 0 ? 2 : 1;
    for (int k = 0; k < copies && c.size() < n; ++k) {
      c.push_back(p[0], p[1], p[2]);
      red.push_back(patch ? 200 : 60);
      green.push_back(patch ? 40 : 60 + (surface * 30));
      blue.push_back(50);
    }
  }
  c.add_field("red", ced::scalar_type::uint8, red);
  c.add_field("green", ced::scalar_type::uint8, green);
  c.add_field("blue", ced::scalar_type::uint8, blue);
  return c;
}

float d2(const ced::point_cloud& c, std::size_t i, std::size_t j) {
  const float* a = c.position(i);
  const float* b = c.position(j);
  const float dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
  return dx * dx + dy * dy + dz * dz;
}

/// Every point's k nearest (itself first, then by squared distance in
/// float, ties to the smaller index), by sorting all points.
lists brute_knn(const ced::point_cloud& c, std::size_t k) {
  lists out(c.size());
  std::vector<std::uint32_t> all(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    for (std::size_t j = 0; j < c.size(); ++j) all[j] = std::uint32_t(j);
    std::sort(all.begin(), all.end(), [&](std::uint32_t a, std::uint32_t b) {
      if ((a == i) != (b == i)) return a == i;
      const float da = d2(c, i, a), db = d2(c, i, b);
      return da < db || (da == db && a < b);
    });
    out[i].assign(all.begin(), all.begin() + std::ptrdiff_t(k));
  }
  return out;
}

/// The neighbourhoods the spec defines, and each point's own radius.
lists brute_neighborhoods(const ced::point_cloud& c, const ced::neighborhood_spec& n, std::vector<double>& radius) {
  const lists knn = brute_knn(c, n.k);
  lists out(c.size());
  radius.assign(c.size(), 0);
  for (std::size_t i = 0; i < c.size(); ++i) {
    const double dk = std::sqrt(double(d2(c, i, knn[i].back())));
    if (n.kind == ced::neighborhood_kind::knn) {
      out[i] = knn[i];
      std::sort(out[i].begin(), out[i].end());
      radius[i] = dk;
      continue;
    }
    radius[i] = std::min(std::max(n.scale * dk, n.min_radius), n.max_radius);
    const float r2 = static_cast<float>(radius[i] * radius[i]);
    for (std::size_t j = 0; j < c.size(); ++j)
      if (d2(c, i, j) < r2 || j == i) out[i].push_back(std::uint32_t(j));
  }
  return out;
}

/// A list-reading modality that checks every list it is given against the
/// expected one (ascending indices) and counts the mismatches.
struct list_check {
  const lists* expected;
  std::atomic<int>* wrong;
  std::string name() const { return "list_check"; }
  double threshold(const ced::detect_params&) const { return 1e30; }
  struct evaluator {
    const lists* expected;
    std::atomic<int>* wrong;
    float operator()(const ced::neighborhood& nb) const {
      const auto& e = (*expected)[nb.point];
      if (!std::equal(nb.begin(), nb.end(), e.begin(), e.end())) ++*wrong;
      return 0.0f;
    }
  };
  evaluator bind(const ced::point_cloud&, const ced::detect_params&) const { return {expected, wrong}; }
};

/// Each point's own NMS radius under nms=own, as the detector rounds it.
std::vector<float> own_nms(const ced::detection_result& r, const ced::detect_params& p) {
  std::vector<float> out;
  for (float ri : r.point_radius) out.push_back(static_cast<float>(p.nms_radius / p.radius * double(ri)));
  return out;
}

std::vector<ced::neighborhood_spec> kinds() {
  std::vector<ced::neighborhood_spec> out;
  for (const char* text :
       {"knn:1", "knn:12", "knn:30", "adaptive:12", "adaptive:8,scale=0.7", "adaptive:10,scale=1.6",
        "adaptive:12,min=0.06", "adaptive:16,scale=2,max=0.05", "knn:16,nms=own", "adaptive:12,scale=1.5,nms=own"})
    out.push_back(ced::parse_neighborhood(text));
  return out;
}

}  // namespace

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
