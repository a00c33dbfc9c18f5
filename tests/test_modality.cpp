// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "ced/ced.hpp"
#include "core/block_partition.hpp"
#include "core/neighbor_index.hpp"
#include "test_support.hpp"

static_assert(ced::is_modality_v<ced::xyz>);
static_assert(ced::is_modality_v<ced::rgb>);
static_assert(ced::is_modality_v<ced::lab>);
static_assert(ced::is_modality_v<ced::intensity>);
static_assert(ced::is_modality_v<ced::bands>);
static_assert(!ced::is_modality_v<int>);
static_assert(!ced::is_modality_v<ced::point_cloud>);

namespace {

// A custom modality defined inside a test: "height", the vertical offset of a
// point from its neighbours' mean height, with its own saliency measure (the
// max over neighbours of |z_j - z_i|, not a centroid distance).
struct max_height_step {
  static constexpr const char* spec_name = "max_height_step";
  double threshold_value = 0.01;
  std::string name() const { return "max_height_step"; }
  double threshold(const ced::detect_params&) const { return threshold_value; }
  auto bind(const ced::point_cloud& cloud, const ced::detect_params&) const {
    return [&cloud](const ced::neighborhood& nb) {
      float best = 0;
      for (std::uint32_t j : nb) best = std::max(best, std::abs(cloud.position(j)[2] - cloud.position(nb.point)[2]));
      return best;
    };
  }
  static max_height_step from_spec(ced::modality_spec& s) { return {s.threshold_or(0.01)}; }
};
static_assert(ced::is_modality_v<max_height_step>);

}  // namespace

TEST(Modality, CustomModalityComposesAtCompileTimeAndRuntime) {
  auto c = ced_test::make_room(3000, 4);
  ced::detect_params p;
  const auto a = ced::detect(c, p, ced::xyz{}, max_height_step{0.02});
  ced::register_modality<max_height_step>("test modality");
  const auto b = ced::detect(c, p, {ced::make_modality("xyz"), ced::make_modality("max_height_step:0.02")});
  EXPECT_EQ(a.keypoints, b.keypoints);
  EXPECT_EQ(a.saliency, b.saliency);
  // Check the custom measure against its definition on a few points.
  const auto nb = ced_test::brute_neighbors(c, p.radius);
  for (std::size_t i = 0; i < c.size(); i += 97) {
    float best = 0;
    for (auto j : nb[i]) best = std::max(best, std::abs(c.position(j)[2] - c.position(i)[2]));
    EXPECT_EQ(a.saliency[1][i], nb[i].size() < p.min_neighbors ? 0.0f : best);
  }
  const auto names = ced::registered_modalities();
  EXPECT_TRUE(std::any_of(names.begin(), names.end(), [](const auto& n) { return n.first == "max_height_step"; }));
}

TEST(ModalitySpec, Parses) {
  auto s = ced::modality_spec::parse(" bands(nir, red_edge):0.15,range=0..255,norm=l2 ");
  EXPECT_EQ(s.name(), "bands");
  EXPECT_EQ(s.args(), (std::vector<std::string>{"nir", "red_edge"}));
  EXPECT_DOUBLE_EQ(s.threshold_or(0), 0.15);
  EXPECT_EQ(s.take("range").value(), "0..255");
  EXPECT_EQ(s.take("norm").value(), "l2");
  EXPECT_FALSE(s.take("other"));
  auto t = ced::modality_spec::parse("rgb");
  EXPECT_FALSE(t.threshold());
  EXPECT_DOUBLE_EQ(t.threshold_or(0.1), 0.1);
}

TEST(ModalitySpec, BadSpecsAreClearErrors) {
  auto expect_error = [](const std::string& spec, const std::string& what) {
    try {
      ced::make_modality(spec);
      FAIL() << "no error for " << spec;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << spec << ": " << e.what();
    }
  };
  expect_error("", "empty");
  expect_error("colour:0.1", "unknown modality 'colour'");
  expect_error("rgb:abc", "not a number");
  expect_error("rgb:-0.1", "negative");
  expect_error("rgb:nan", "not a finite number");
  expect_error("rgb:0.1,gamma=2", "no option 'gamma'");
  expect_error("bands(nir", "missing ')'");
  expect_error("bands", "needs field names");
  expect_error("xyz(a)", "takes no field list");
  expect_error("rgb,norm=l3", "norm must be");
  expect_error("bands(a):0.1,range=5..1", "high end");
  expect_error("rgb:0.1,range", "key=value");
  EXPECT_THROW(ced::preset("ced9d"), std::invalid_argument);
}

TEST(Modality, Normalisation) {
  ced::point_cloud c;
  for (int i = 0; i < 6; ++i) c.push_back(i * 0.01f, 0, 0);
  c.add_field("b16", ced::scalar_type::uint16, {0, 0, 0, 60000, 60000, 60000});
  c.add_field("f", ced::scalar_type::float32, {0, 0, 0, 0.5, 0.5, 0.5});
  c.add_field("red", ced::scalar_type::uint16, {0, 0, 0, 255, 255, 255});  // 8-bit values in 16-bit fields
  c.add_field("green", ced::scalar_type::uint16, {0, 0, 0, 0, 0, 0});
  c.add_field("blue", ced::scalar_type::uint16, {0, 0, 0, 0, 0, 0});
  ced::detect_params p;
  p.radius = 0.1;  // everyone sees everyone: mean of any field = average
  p.min_neighbors = 1;
  auto sal = [&](const std::string& spec) { return ced::detect(c, p, {ced::make_modality(spec)}).saliency[0][0]; };
  EXPECT_NEAR(sal("bands(b16)"), 30000.0 / 65535.0, 1e-6);
  EXPECT_NEAR(sal("bands(b16),range=0..60000"), 0.5, 1e-6);
  EXPECT_NEAR(sal("bands(b16),range=auto"), 0.5, 1e-6);
  EXPECT_NEAR(sal("intensity(f)"), 0.25, 1e-6);
  EXPECT_NEAR(sal("bands(b16,f),norm=l2"), std::hypot(30000.0 / 65535.0, 0.25), 1e-6);
  EXPECT_NEAR(sal("bands(b16,f),norm=linf"), 30000.0 / 65535.0, 1e-6);
  EXPECT_NEAR(sal("rgb"), 0.5, 1e-6);  // 16-bit fields holding 8-bit values are read as 8-bit
  EXPECT_NEAR(sal("rgb,range=0..65535"), 127.5 / 65535.0, 1e-6);
  // lab: three black and three red points; the mean in L*a*b* is half of red (black is 0).
  const auto black = ced::srgb_to_lab(0, 0, 0), red = ced::srgb_to_lab(1, 0, 0);
  EXPECT_NEAR(black[0], 0.0, 1e-4);
  EXPECT_NEAR(red[0], 53.24, 0.01);
  EXPECT_NEAR(red[1], 80.09, 0.01);
  EXPECT_NEAR(red[2], 67.20, 0.01);
  const double de = std::sqrt(std::pow(red[0] / 2, 2) + std::pow(red[1] / 2, 2) + std::pow(red[2] / 2, 2));
  EXPECT_NEAR(sal("lab"), de / 100.0, 1e-5);
}

TEST(Lab, MatchesTheCieFormulaWithStdCbrt) {
  // linear_srgb_to_lab takes its cube roots by iteration: the result must
  // be the CIE formula's (here with std::cbrt) to a float's last bit, on a
  // grid of 8-bit colours that spans both branches of f(t).
  auto reference = [](double R, double G, double B) {
    const double X = (0.4124564 * R + 0.3575761 * G + 0.1804375 * B) / 0.95047;
    const double Y = 0.2126729 * R + 0.7151522 * G + 0.0721750 * B;
    const double Z = (0.0193339 * R + 0.1191920 * G + 0.9503041 * B) / 1.08883;
    auto f = [](double t) { return t > 216.0 / 24389.0 ? std::cbrt(t) : (24389.0 / 27.0 * t + 16.0) / 116.0; };
    return std::array<double, 3>{116.0 * f(Y) - 16.0, 500.0 * (f(X) - f(Y)), 200.0 * (f(Y) - f(Z))};
  };
  std::size_t same = 0, total = 0;
  for (int r = 0; r < 256; r += 3)
    for (int g = 0; g < 256; g += 3)
      for (int b = 0; b < 256; b += 3) {
        const double R = ced::srgb_to_linear(float(r / 255.0)), G = ced::srgb_to_linear(float(g / 255.0)),
                     B = ced::srgb_to_linear(float(b / 255.0));
        const auto got = ced::linear_srgb_to_lab(R, G, B);
        const auto want = reference(R, G, B);
        for (int k = 0; k < 3; ++k) {
          ASSERT_NEAR(got[k], want[k], 1e-5 * (1.0 + std::fabs(want[k]))) << r << "," << g << "," << b;
          same += got[k] == static_cast<float>(want[k]);
          ++total;
        }
      }
  EXPECT_GE(double(same), 0.9999 * double(total));
}

TEST(Lab, BatchConversionMatchesOneByOneBitwise) {
  // The batch form computes several colours per instruction; every value must
  // be the one-colour function's, whatever the count (tails included).
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> u(0, 255);
  for (std::size_t n : {std::size_t(1), std::size_t(7), std::size_t(8), std::size_t(9), std::size_t(1000)}) {
    std::vector<double> r(n), g(n), b(n);
    for (std::size_t i = 0; i < n; ++i) {
      r[i] = ced::srgb_to_linear(float(u(rng) / 255.0));
      g[i] = ced::srgb_to_linear(float(u(rng) / 255.0));
      b[i] = ced::srgb_to_linear(float(i % 5 == 0 ? 0 : u(rng) / 255.0));  // some dark: the linear branch
    }
    std::vector<float> lab(3 * n + 1, -1.0f);
    ced::linear_srgb_to_lab(r.data(), g.data(), b.data(), n, lab.data());
    for (std::size_t i = 0; i < n; ++i) {
      const auto one = ced::linear_srgb_to_lab(r[i], g[i], b[i]);
      for (std::size_t k = 0; k < 3; ++k) ASSERT_EQ(lab[3 * i + k], one[k]) << n << " colours, colour " << i;
    }
    EXPECT_EQ(lab[3 * n], -1.0f) << "wrote past the end";
  }
}

TEST(NeighborIndex, MatchesBruteForce) {
  const auto c = ced_test::make_room(2000, 3);
  // With the identity order and with a block order (the tree over permuted points).
  const ced::block_partition blocks(c.positions().data(), c.size(), 0.03, 1);
  for (const std::uint32_t* order : {static_cast<const std::uint32_t*>(nullptr), blocks.order().data()}) {
    const ced::neighbor_index index(c.positions().data(), c.size(), 8, 1, order);
    std::vector<std::uint32_t> got;
    for (double r : {0.0, 0.01, 0.05, 0.2}) {
      const auto nb = ced_test::brute_neighbors(c, r);
      for (std::size_t i = 0; i < c.size(); i += 7) {
        index.radius_search(c.position(i), r, got);
        std::sort(got.begin(), got.end());
        ASSERT_EQ(got, nb[i]) << "r=" << r << " i=" << i;
      }
    }
    const float lo[3] = {0.1f, 0.1f, -1}, hi[3] = {0.3f, 0.2f, 1};
    // With positions: the same points in the same order, each with its own
    // position (bitwise).
    std::vector<ced::neighbor_index::located_point> located(3);
    index.box_search(lo, hi, located);
    index.box_search(lo, hi, got);
    ASSERT_EQ(located.size(), got.size());
    for (std::size_t t = 0; t < got.size(); ++t) {
      EXPECT_EQ(located[t].index, got[t]);
      EXPECT_EQ(std::memcmp(located[t].xyz, c.position(got[t]), sizeof located[t].xyz), 0);
    }
    std::sort(got.begin(), got.end());
    std::vector<std::uint32_t> want;
    for (std::size_t i = 0; i < c.size(); ++i) {
      const float* q = c.position(i);
      if (q[0] >= lo[0] && q[0] <= hi[0] && q[1] >= lo[1] && q[1] <= hi[1] && q[2] >= lo[2] && q[2] <= hi[2])
        want.push_back(static_cast<std::uint32_t>(i));
    }
    EXPECT_EQ(got, want);
    index.radius_search(c.position(0), -1, got);
    EXPECT_TRUE(got.empty());
    float nearest = INFINITY;
    for (std::size_t j = 1; j < c.size(); ++j)
      nearest = std::min(nearest, std::sqrt(ced::squared_distance(c.position(0), c.position(j))));
    EXPECT_FLOAT_EQ(index.nearest_other_distance(0), nearest);
  }
  ced::neighbor_index none(nullptr, 0);
}

TEST(NeighborIndex, ForestOfTreesMatchesBruteForce) {
  // More than 65,536 points in a block order: the index is several trees.
  const auto c = ced_test::make_room(140000, 4);
  const ced::block_partition blocks(c.positions().data(), c.size(), 0.2, 1);
  const ced::neighbor_index index(c.positions().data(), c.size(), 256, 1, blocks.order().data());
  const ced::neighbor_index index2(c.positions().data(), c.size(), 256, 2, blocks.order().data());
  std::vector<std::uint32_t> got, got2;
  for (std::size_t i = 0; i < c.size(); i += 9973) {
    const float* p = c.position(i);
    std::vector<std::uint32_t> want;
    float nearest = INFINITY;
    for (std::size_t j = 0; j < c.size(); ++j) {
      const float d2 = ced::squared_distance(c.position(j), p);
      if (d2 < ced::squared_radius(0.05)) want.push_back(static_cast<std::uint32_t>(j));
      if (j != i) nearest = std::min(nearest, std::sqrt(d2));
    }
    index.radius_search(p, 0.05, got);
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, want) << i;
    EXPECT_FLOAT_EQ(index.nearest_other_distance(static_cast<std::uint32_t>(i)), nearest) << i;
    const float lo[3] = {p[0] - 0.3f, p[1] - 0.3f, p[2] - 0.3f}, hi[3] = {p[0] + 0.3f, p[1] + 0.3f, p[2] + 0.3f};
    index.box_search(lo, hi, got);
    index2.box_search(lo, hi, got2);
    EXPECT_EQ(got, got2) << "the same points in the same order on 1 and 2 threads";
    std::sort(got.begin(), got.end());
    want.clear();
    for (std::size_t j = 0; j < c.size(); ++j) {
      const float* q = c.position(j);
      if (q[0] >= lo[0] && q[0] <= hi[0] && q[1] >= lo[1] && q[1] <= hi[1] && q[2] >= lo[2] && q[2] <= hi[2])
        want.push_back(static_cast<std::uint32_t>(j));
    }
    EXPECT_EQ(got, want) << i;
  }
}

TEST(BlockPartition, CoversEveryPointOnce) {
  const auto c = ced_test::make_room(5000, 8);
  for (unsigned t : {1u, 2u}) {
    const ced::block_partition b(c.positions().data(), c.size(), 0.03, t);
    std::vector<int> seen(c.size(), 0);
    for (std::size_t k = 0; k < b.block_count(); ++k) {
      ASSERT_LE(b.block_size(k), 256u);
      for (std::size_t q = 0; q < b.block_size(k); ++q) {
        ++seen[b.block_points(k)[q]];
        if (q) {
          EXPECT_LT(b.block_points(k)[q - 1], b.block_points(k)[q]);
        }
      }
    }
    EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int s) { return s == 1; }));
  }
}

TEST(BlockPartition, SameBlocksForAnyThreadCount) {
  // Enough points for the sort to split its work into several chunks, and
  // cells small enough for keys of more than one radix digit.
  const auto c = ced_test::make_room(150000, 9);
  const ced::block_partition one(c.positions().data(), c.size(), 0.004, 1);
  ASSERT_GT(one.block_count(), std::size_t(1) << 11);
  for (unsigned t : {2u, 3u, 8u}) {
    const ced::block_partition b(c.positions().data(), c.size(), 0.004, t);
    EXPECT_EQ(b.order(), one.order()) << t << " threads";
    ASSERT_EQ(b.block_count(), one.block_count());
    for (std::size_t k = 0; k < b.block_count(); ++k) ASSERT_EQ(b.block_size(k), one.block_size(k));
  }
}
