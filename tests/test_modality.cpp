// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "test_support.hpp"

static_assert(ced::is_modality_v<ced::xyz>);
static_assert(ced::is_modality_v<ced::rgb>);
static_assert(ced::is_modality_v<ced::lab>);
static_assert(ced::is_modality_v<ced::normals>);
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

// The same measure as a block evaluator (c): one call a block, writing every
// point of it, including those the min_neighbors gate will zero.
struct max_height_step_blocks {
  double threshold_value = 0.01;
  std::string name() const { return "max_height_step_blocks"; }
  double threshold(const ced::detect_params&) const { return threshold_value; }
  struct evaluator {
    const ced::point_cloud* cloud;
    void evaluate(const ced::block_view& block, float* out) const {
      for (std::size_t k = 0; k < block.size(); ++k) {
        const ced::neighborhood nb = block[k];
        float best = 0;
        for (std::uint32_t j : nb)
          best = std::max(best, std::abs(cloud->position(j)[2] - cloud->position(nb.point)[2]));
        out[k] = best + 1.0f;  // + 1: the gate must zero points with few neighbours
      }
    }
  };
  evaluator bind(const ced::point_cloud& cloud, const ced::detect_params&) const { return {&cloud}; }
};
static_assert(ced::is_modality_v<max_height_step_blocks>);
static_assert(ced::evaluates_blocks_v<ced::evaluator_t<max_height_step_blocks>>);
static_assert(!ced::evaluates_blocks_v<ced::evaluator_t<max_height_step>>);

}  // namespace

TEST(Modality, BlockEvaluatorMatchesListEvaluatorOnBothPaths) {
  auto c = ced_test::make_room(3000, 5);
  ced::detect_params p;
  const auto nb = ced_test::brute_neighbors(c, p.radius);
  std::vector<std::size_t> sizes;
  for (const auto& n : nb) sizes.push_back(n.size());
  std::nth_element(sizes.begin(), sizes.begin() + sizes.size() / 10, sizes.end());
  p.min_neighbors = std::uint32_t(sizes[sizes.size() / 10]);  // about a tenth of the points fall below it
  const auto list = ced::detect(c, p, ced::xyz{}, max_height_step{1.02});
  const auto blocks = ced::detect(c, p, ced::xyz{}, max_height_step_blocks{1.02});
  std::size_t gated = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const bool few = nb[i].size() < p.min_neighbors;
    gated += few;
    ASSERT_EQ(blocks.saliency[1][i], few ? 0.0f : list.saliency[1][i] + 1.0f) << "point " << i;
  }
  EXPECT_GT(gated, 0u);
  for (unsigned threads : {1u, 2u, 3u}) {
    p.threads = threads;
    const auto runtime =
        ced::detect(c, p, {ced::any_modality(ced::xyz{}), ced::any_modality(max_height_step_blocks{1.02})});
    EXPECT_EQ(runtime.saliency, blocks.saliency) << threads << " threads";
    EXPECT_EQ(runtime.keypoints, blocks.keypoints) << threads << " threads";
  }
}

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

TEST(Modality, Normalisation) {
  ced::point_cloud c;
  for (int i = 0; i < 6; ++i) c.push_back(i * 0.01f, 0, 0);
  c.add_field("b16", ced::scalar_type::uint16, {0, 0, 0, 60000, 60000, 60000});
  c.add_field("f", ced::scalar_type::float32, {0, 0, 0, 0.5, 0.5, 0.5});
  c.add_field("red", ced::scalar_type::uint16, {0, 0, 0, 255, 255, 255});  // 8-bit values in 16-bit fields
  c.add_field("green", ced::scalar_type::uint16, {0, 0, 0, 0, 0, 0});
  c.add_field("blue", ced::scalar_type::uint16, {0, 0, 0, 0, 0, 0});
  // Normals as axes (n and -n the same): three along z, three along x.
  c.add_field("nx", ced::scalar_type::float32, {0, 0, 0, 1, -1, 1});
  c.add_field("ny", ced::scalar_type::float32, {0, 0, 0, 0, 0, 0});
  c.add_field("nz", ced::scalar_type::float32, {1, -1, 1, 0, 0, 0});
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
  // normals: the mean orientation tensor is diag(1/2, 0, 1/2); a point's own
  // is diag(0, 0, 1): || diag(1/2, 0, -1/2) ||_F = sqrt(1/2), the crease of two
  // perpendicular planes. Estimated normals (collinear points) are no test here.
  EXPECT_NEAR(sal("normals"), std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(sal("normals,from=fields"), std::sqrt(0.5), 1e-6);
  EXPECT_EQ(ced::normals{}.fields(), (std::vector<std::string>{"nx", "ny", "nz", "normal_x", "normal_y", "normal_z"}));
  EXPECT_TRUE(ced::normals(0.2, ced::normals::source::estimate).fields().empty());
}
