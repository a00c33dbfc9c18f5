// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/core.hpp"
#include "core/kernel/dispatch.hpp"
#include "core/neighbor_block.hpp"
#include "test_support.hpp"

using ced_test::make_room;

// The neighbour pass is built for the baseline instruction set, AVX2 and
// AVX-512 (chosen at run time); every build this CPU runs must give bitwise
// the generic build's results, through the register-accumulator paths
// (≤ 16 channels) and the any-count path.
TEST(Detect, EveryNeighbourPassBuildAgreesBitwise) {
  auto c = make_room(6000, 13);
  std::vector<std::string> many;
  std::mt19937 rng(3);
  for (int b = 0; b < 20; ++b) {
    std::vector<double> v(c.size());
    for (double& x : v) x = double(rng() % 256);
    many.push_back("b" + std::to_string(b));
    c.add_field(many.back(), ced::scalar_type::uint8, std::move(v));
  }
  ced::detect_params p;
  p.threads = 2;
  const std::vector<ced::any_modality> mods = {ced::xyz{}, ced::rgb{}, ced::lab{}, ced::bands(many, 0.3)};
  const auto isas = ced::detail::kernel_isas();
  ASSERT_EQ(isas.back(), "generic");
  ced::detail::force_kernel_isa("generic");
  EXPECT_STREQ(ced::detail::kernel_isa(), "generic");
  const auto b = ced::detect(c, p, mods);
  const auto b6 = ced::detect(c, p, ced::xyz{}, ced::rgb{});
  ASSERT_GT(b.keypoints.size(), 10u);
  for (const std::string& isa : isas) {
    SCOPED_TRACE(isa);
    ced::detail::force_kernel_isa(isa);
    const auto a = ced::detect(c, p, mods);
    const auto a6 = ced::detect(c, p, ced::xyz{}, ced::rgb{});
    EXPECT_EQ(a.saliency, b.saliency);  // bitwise
    EXPECT_EQ(a.keypoints, b.keypoints);
    EXPECT_EQ(a.neighbor_count, b.neighbor_count);
    EXPECT_EQ(a6.saliency, b6.saliency);
    EXPECT_EQ(a6.keypoints, b6.keypoints);
  }
  ced::detail::force_generic_kernel(false);
  if (isas.size() == 1) std::printf("note: this CPU has no AVX2; only the generic pass ran\n");
  EXPECT_THROW(ced::detail::force_kernel_isa("sse9"), std::invalid_argument);
}

// The set-up before the sweep (box query, sub-cell keys, each point's nine
// runs) has its own AVX2 and AVX-512 builds: they must lay the block out
// exactly as the generic one does, since the runs fix which lane sums which
// point.
TEST(Detect, EveryBuildLaysBlocksOutTheSame) {
  const auto c = make_room(20000, 17);
  const float* xyz = c.positions().data();
  for (const std::string& isa : ced::detail::kernel_isas())
    for (const double r : {0.02, 0.05, 0.11}) {
      const ced::block_partition grid(xyz, c.size(), 6 * r, 1);
      ced::neighbor_block fast, generic;
      fast.set_channels({ced::channel_source{xyz, 3, true}});
      generic.set_channels({ced::channel_source{xyz, 3, true}});
      for (std::size_t b = 0; b < grid.block_count(); ++b) {
        ced::detail::force_kernel_isa(isa);
        fast.fill(grid, xyz, grid.block_points(b), grid.block_size(b), r);
        ced::detail::force_kernel_isa("generic");
        generic.fill(grid, xyz, grid.block_points(b), grid.block_size(b), r);
        ced::detail::force_generic_kernel(false);
        const std::string at = isa + ", r " + std::to_string(r) + ", block " + std::to_string(b);
        ASSERT_EQ(fast.gathered_count(), generic.gathered_count());
        for (std::size_t t = 0; t < fast.gathered_count(); ++t)
          ASSERT_EQ(fast.gathered()[t], generic.gathered()[t]) << at << ", point " << t;
        for (std::size_t k = 0; k < fast.size(); ++k) {
          const auto f = fast.sweep(k), g = generic.sweep(k);
          ASSERT_EQ(f.bytes, g.bytes) << at << ", point " << k;
          for (std::size_t q = 0; q < 2 * ced::neighbor_block::sweep_ranges; ++q)
            ASSERT_EQ(f.ranges[q], g.ranges[q]) << at << ", point " << k << ", run " << q / 2;
        }
      }
    }
}

// The positions' second moments (normals' pass, neighbor_block::set_moments):
// every build sums the same bits, and they are Σ d dᵀ of the brute-force
// neighbourhood within float rounding.
TEST(Detect, EveryBuildSumsTheSameMoments) {
  const auto c = make_room(8000, 19);
  const float* xyz = c.positions().data();
  const double r = 0.05;
  const auto nb = ced_test::brute_neighbors(c, r);
  const ced::block_partition grid(xyz, c.size(), 6 * r, 1);
  std::vector<double> want_bits;  // the generic build's sums, block after block
  std::size_t checked = 0;
  for (const std::string& isa : ced::detail::kernel_isas()) {
    SCOPED_TRACE(isa);
    ced::detail::force_kernel_isa(isa);
    ced::neighbor_block block;
    block.set_channels({ced::channel_source{xyz, 3, true}});
    block.set_moments(true);
    block.set_keep_lists(false);
    std::vector<double> got;
    for (std::size_t b = 0; b < grid.block_count(); ++b) {
      block.fill(grid, xyz, grid.block_points(b), grid.block_size(b), r);
      const ced::block_view v = block.view();
      for (std::size_t k = 0; k < v.size(); ++k) {
        const std::uint32_t i = v.point(k);
        ASSERT_EQ(v.count(k), nb[i].size()) << "point " << i;
        const double* s = v.position_sums(k);
        got.insert(got.end(), s, s + 9);
        if (isa != "generic") continue;
        double want[9] = {};
        for (auto j : nb[i]) {
          double d[3];
          for (int a = 0; a < 3; ++a) d[a] = double(c.position(j)[a]) - double(c.position(i)[a]);
          const double m[9] = {d[0],        d[1],        d[2],        d[0] * d[0], d[1] * d[1],
                               d[2] * d[2], d[0] * d[1], d[0] * d[2], d[1] * d[2]};
          for (int q = 0; q < 9; ++q) want[q] += m[q];
        }
        for (int q = 0; q < 9; ++q)
          ASSERT_NEAR(s[q], want[q], 1e-6 * double(nb[i].size()) * (q < 3 ? r : r * r)) << "point " << i << ", " << q;
        ++checked;
      }
    }
    if (want_bits.empty())
      want_bits = got;
    else
      EXPECT_EQ(got, want_bits);  // bitwise
  }
  ced::detail::force_generic_kernel(false);
  EXPECT_EQ(checked, c.size());
  // Moments are for positions alone.
  ced::neighbor_block with_channels;
  with_channels.set_channels({ced::channel_source{xyz, 3, false}});
  EXPECT_THROW(with_channels.set_moments(true), std::logic_error);
}

// A modality whose evaluator reads neighbour lists (not sums) gets exactly
// the neighbourhoods of the definition: a checksum of each point's neighbour
// indices matches brute force, for several block sizes.
namespace {
struct neighbour_checksum {
  std::string name() const { return "checksum"; }
  double threshold(const ced::detect_params&) const { return 1e30; }
  struct evaluator {
    float operator()(const ced::neighborhood& nb) const {
      std::uint32_t sum = 0;
      for (std::uint32_t j : nb) sum += (j * 2654435761u) % 1000u;
      return static_cast<float>(sum);
    }
  };
  evaluator bind(const ced::point_cloud&, const ced::detect_params&) const { return {}; }
};
}  // namespace

TEST(Detect, ListEvaluatorsSeeExactNeighbourhoods) {
  static_assert(!ced::sums_neighbors_v<neighbour_checksum::evaluator>);
  const auto c = make_room(3000, 23);
  ced::detect_params p;
  p.min_neighbors = 0;
  const auto nb = ced_test::brute_neighbors(c, p.radius);
  for (double scale : {1.0, 4.0}) {
    p.block_scale = scale;
    const auto r = ced::detect(c, p, neighbour_checksum{}, ced::xyz{});
    for (std::size_t i = 0; i < c.size(); ++i) {
      std::uint32_t sum = 0;
      for (auto j : nb[i]) sum += (static_cast<std::uint32_t>(j) * 2654435761u) % 1000u;
      ASSERT_EQ(r.saliency[0][i], static_cast<float>(sum)) << "point " << i << ", block scale " << scale;
      ASSERT_EQ(r.neighbor_count[i], nb[i].size());
    }
  }
}
