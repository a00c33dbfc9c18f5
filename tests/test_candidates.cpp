// SPDX-License-Identifier: MIT
// The candidate rule and the NMS score (core/candidates.hpp) against a
// scalar loop of their definition.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "core/candidates.hpp"

namespace {

using ced::detail::candidates_and_scores;
using ced::detail::is_candidate;
using ced::detail::reaches;

struct scored {
  std::vector<std::uint8_t> candidate;
  std::vector<float> score;
};

/// The definition, one point at a time: a candidate when some modality's
/// saliency reaches its threshold (in double), the score the float product of
/// the saliencies in modality order.
scored scalar_loop(const std::vector<std::vector<float>>& sal, const std::vector<double>& thresholds, std::size_t n) {
  scored r{std::vector<std::uint8_t>(n, 0), std::vector<float>(n, 0.0f)};
  for (std::size_t i = 0; i < n; ++i) {
    float product = sal[0][i];
    for (std::size_t m = 1; m < sal.size(); ++m) product *= sal[m][i];
    r.score[i] = product;
    for (std::size_t m = 0; m < sal.size(); ++m)
      if (static_cast<double>(sal[m][i]) >= thresholds[m]) r.candidate[i] = 1;
  }
  return r;
}

scored run(const std::vector<std::vector<float>>& sal, const std::vector<double>& thresholds, std::size_t n,
           unsigned threads) {
  std::vector<const float*> columns;
  for (const auto& s : sal) columns.push_back(s.data());
  scored r{std::vector<std::uint8_t>(n, 0), std::vector<float>(n, -1.0f)};
  candidates_and_scores(columns, thresholds, n, threads, r.candidate.data(), r.score.data());
  return r;
}

/// `m` columns of n saliencies: random, with some exactly at the threshold's
/// float, some one float below it, and some zeros.
std::vector<std::vector<float>> random_saliencies(std::size_t m, std::size_t n, std::uint32_t seed,
                                                  std::vector<double>& thresholds) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<std::vector<float>> sal(m, std::vector<float>(n));
  thresholds.clear();
  for (std::size_t k = 0; k < m; ++k) {
    const float t = 0.6f + 0.1f * static_cast<float>(k);
    // Every other modality's threshold lies just above a float: compared in
    // float, saliencies equal to t would reach it.
    thresholds.push_back(k % 2 == 0 ? static_cast<double>(t) : std::nextafter(static_cast<double>(t), 1.0));
    for (std::size_t i = 0; i < n; ++i) {
      switch (rng() % 8) {
        case 0:
          sal[k][i] = t;
          break;
        case 1:
          sal[k][i] = std::nextafter(t, 0.0f);
          break;
        case 2:
          sal[k][i] = 0.0f;
          break;
        default:
          sal[k][i] = u(rng) * 1.3f;
      }
    }
  }
  return sal;
}

}  // namespace

TEST(Candidates, ReachesComparesInDoubleAndIncludesTheThreshold) {
  const float s = 0.1f;  // not 0.1: the float nearest it
  EXPECT_TRUE(reaches(s, static_cast<double>(s)));
  EXPECT_TRUE(reaches(s, static_cast<double>(std::nextafter(s, 0.0f))));
  EXPECT_FALSE(reaches(std::nextafter(s, 0.0f), static_cast<double>(s)));
  // A threshold between two floats: compared in float, it would round to s.
  EXPECT_FALSE(reaches(s, std::nextafter(static_cast<double>(s), 1.0)));
  EXPECT_FALSE(reaches(0.7f, 0.7));  // 0.7f < 0.7 in double, though float(0.7) == 0.7f
  EXPECT_TRUE(reaches(0.3f, 0.3));   // 0.3f > 0.3
  EXPECT_TRUE(reaches(0.0f, 0.0));
  EXPECT_TRUE(reaches(0.0f, -0.0));
  EXPECT_FALSE(reaches(std::numeric_limits<float>::max(), std::numeric_limits<double>::infinity()));
  EXPECT_FALSE(reaches(std::nanf(""), 0.0));
}

TEST(Candidates, IsCandidateIsAnOrOverModalities) {
  const std::vector<float> a = {0.5f, 0.1f, 0.1f, 0.5f}, b = {0.1f, 0.5f, 0.1f, 0.5f};
  const float* columns[] = {a.data(), b.data()};
  const std::vector<double> thresholds = {0.5, 0.5};
  EXPECT_TRUE(is_candidate(columns, thresholds, 0));   // only the first
  EXPECT_TRUE(is_candidate(columns, thresholds, 1));   // only the second
  EXPECT_FALSE(is_candidate(columns, thresholds, 2));  // neither
  EXPECT_TRUE(is_candidate(columns, thresholds, 3));   // both
  EXPECT_FALSE(is_candidate(columns, {}, 0));          // no modality, no candidate
}

TEST(Candidates, MatchScalarLoopForAnyModalityAndThreadCount) {
  // More points than one chunk of the parallel loop (2^14), and not a
  // multiple of it, so that two threads split the work.
  const std::size_t n = 70001;
  for (const std::size_t m : {std::size_t(1), std::size_t(2), std::size_t(3), std::size_t(5)}) {
    std::vector<double> thresholds;
    const auto sal = random_saliencies(m, n, static_cast<std::uint32_t>(m), thresholds);
    const auto want = scalar_loop(sal, thresholds, n);
    std::size_t candidates = 0;
    for (auto c : want.candidate) candidates += c;
    ASSERT_GT(candidates, 0u);
    ASSERT_LT(candidates, n);
    for (const unsigned threads : {1u, 2u, 3u}) {
      SCOPED_TRACE(testing::Message() << m << " modalities, " << threads << " threads");
      const auto got = run(sal, thresholds, n, threads);
      EXPECT_EQ(got.candidate, want.candidate);
      EXPECT_EQ(got.score, want.score);  // bitwise: the same products in the same order
    }
  }
}

TEST(Candidates, ScoreIsTheProductInModalityOrder) {
  // Saliencies whose float product depends on the order: the score is
  // (a·b)·c, modality after modality, not a·(b·c) nor (c·b)·a.
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(0.5f, 2.0f);
  float a = 1, b = 1, c = 1;
  for (int tries = 0; tries < 1000 && ((a * b) * c == a * (b * c) || (a * b) * c == (c * b) * a); ++tries) {
    a = u(rng);
    b = u(rng);
    c = u(rng);
  }
  ASSERT_NE((a * b) * c, a * (b * c));
  ASSERT_NE((a * b) * c, (c * b) * a);
  const std::vector<std::vector<float>> sal = {{a, 0.0f}, {b, 2.0f}, {c, 4.0f}};
  const auto got = run(sal, {10.0, 10.0, 10.0}, 2, 1);
  EXPECT_EQ(got.score[0], (a * b) * c);
  EXPECT_EQ(got.score[1], 0.0f);
  EXPECT_EQ(got.candidate, (std::vector<std::uint8_t>{0, 0}));
  // One modality: the score is the saliency itself.
  const auto one = run({{0.25f, 3.0f}}, {1.0}, 2, 1);
  EXPECT_EQ(one.score, (std::vector<float>{0.25f, 3.0f}));
  EXPECT_EQ(one.candidate, (std::vector<std::uint8_t>{0, 1}));
}

TEST(Candidates, FlagsAreOredIntoTheGivenArray) {
  // `candidate` comes zeroed in detection; flags already set stay set.
  const std::vector<float> s = {0.1f, 0.9f, 0.1f};
  std::vector<std::uint8_t> candidate = {1, 0, 0};
  std::vector<float> score(3);
  candidates_and_scores({s.data()}, {0.5}, 3, 1, candidate.data(), score.data());
  EXPECT_EQ(candidate, (std::vector<std::uint8_t>{1, 1, 0}));
  // n = 0 writes nothing.
  std::uint8_t untouched = 7;
  float untouched_score = -1.0f;
  candidates_and_scores({s.data()}, {0.5}, 0, 2, &untouched, &untouched_score);
  EXPECT_EQ(untouched, 7);
  EXPECT_EQ(untouched_score, -1.0f);
}
