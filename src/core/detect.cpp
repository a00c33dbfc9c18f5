// SPDX-License-Identifier: MIT
// Detection, stage by stage: validate.cpp → block_partition.cpp and
// (here: the grid) → saliency.cpp (neighbourhoods and
// saliencies) → candidates.cpp → nms.cpp → the result (here).
#include "ced/detect.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/candidates.hpp"
#include "core/detection.hpp"
#include "core/parallel.hpp"
#include "core/ranking.hpp"
#include "core/raw_vector.hpp"
#include "core/validate.hpp"

namespace ced {

namespace detail {

detection_context::detection_context(const point_cloud& cloud, const detect_params& params,
                                     std::vector<std::string> names, std::vector<double> thresholds) {
  check_inputs(cloud, params, names, thresholds);
  const auto t0 = clock_type::now();
  const unsigned threads = resolve_threads(params.threads);
  const float* xyz = cloud.positions().data();
  // The block grid is also the search structure: a block's neighbours are
  // gathered from its cell and the cells around it, cell by cell and by
  // index within a cell. That order depends on nothing but those cells, so a
  // tile of the cloud that holds them gets bitwise the same sums (tile_geometry.cpp).
  block_partition blocks(xyz, cloud.size(), params.radius * params.block_scale, threads);
  m_impl = std::make_unique<impl>(cloud, params, std::move(blocks));
  m_impl->result.names = std::move(names);
  m_impl->result.thresholds = std::move(thresholds);
  m_impl->result.times.index_ms = ms_since(t0);
}

detection_context::~detection_context() = default;

void detection_context::without_neighbor_lists() { m_impl->keep_lists = false; }

void detection_context::with_position_moments() {
  const auto& p = m_impl->params;
  if (!(p.neighborhood.fixed() && p.search == search_kind::grid))
    throw std::logic_error("with_position_moments: only on the grid's pass");
  m_impl->moments = true;
}

void detection_context::scale_with_radius(const std::vector<double>& thresholds_at_twice) {
  const auto& t = m_impl->result.thresholds;
  if (thresholds_at_twice.size() != t.size())
    throw std::invalid_argument("scale_with_radius: one threshold per modality expected");
  m_impl->per_radius.assign(t.size(), 0);
  for (std::size_t m = 0; m < t.size(); ++m)
    m_impl->per_radius[m] = thresholds_at_twice[m] == 2 * t[m] && thresholds_at_twice[m] != t[m];
}

void detection_context::add_bind_ms(double ms) { m_impl->result.times.saliency_ms += ms; }

detection_result detection_context::finish() {
  const auto t0 = clock_type::now();
  auto& r = m_impl->result;
  const auto& params = m_impl->params;
  const std::size_t n = m_impl->cloud.size();
  const unsigned threads = resolve_threads(params.threads);
  r.candidate.assign(n, 0);
  std::vector<const float*> columns;
  for (const auto& s : r.saliency) columns.push_back(s.data());
  raw_vector<float> product(n);  // written in full below
  candidates_and_scores(columns, r.thresholds, n, threads, r.candidate.data(), product.data());
  // nms=own: each point's NMS radius is the same ratio of its own radius.
  std::vector<float> own_nms;
  if (params.neighborhood.nms_own && !r.point_radius.empty()) {
    own_nms.resize(n);
    const double ratio = params.nms_radius / params.radius;
    for (std::size_t i = 0; i < n; ++i) own_nms[i] = static_cast<float>(ratio * double(r.point_radius[i]));
  }
  r.keypoints = non_maximum_suppression(m_impl->blocks, m_impl->cloud.positions().data(), product.data(),
                                        r.candidate.data(), params.nms_radius, params.radius, m_impl->hits, threads,
                                        own_nms.empty() ? nullptr : own_nms.data());
  if (params.refine) {
    r.keypoints = refine_keypoints(m_impl->blocks, m_impl->cloud.positions().data(), product.data(), r.keypoints,
                                   params.nms_radius, threads, r.rank_score);
  } else {
    r.rank_score.resize(r.keypoints.size());
    for (std::size_t q = 0; q < r.keypoints.size(); ++q) r.rank_score[q] = product[r.keypoints[q]];
  }
  m_impl->hits.clear();
  m_impl->hits.shrink_to_fit();
  const std::size_t limit = keypoint_limit(params, params.keypoint_share > 0 ? candidate_count(r) : 0);
  if (limit != 0 && r.keypoints.size() > limit) keep_strongest(r, limit);
  r.times.nms_ms = ms_since(t0);
  return std::move(r);
}

detection_result detect_bound(const point_cloud& cloud, const detect_params& params, std::vector<std::string> names,
                              std::vector<double> thresholds, std::vector<double> thresholds_at_twice,
                              const std::function<void(const saliency_pass&)>& bind) {
  detection_context ctx(cloud, params, std::move(names), std::move(thresholds));
  if (!params.neighborhood.fixed()) ctx.scale_with_radius(thresholds_at_twice);
  const auto t_bind = clock_type::now();
  bind([&](const std::vector<channel_source>& sources, const std::function<void(const block_view&, float* const*)>& f) {
    ctx.add_bind_ms(ms_since(t_bind));
    ctx.compute_saliency(sources, f);
  });
  return ctx.finish();
}

}  // namespace detail

std::size_t candidate_count(const detection_result& result) noexcept {
  std::size_t n = 0;
  for (auto c : result.candidate) n += c != 0;
  return n;
}

std::size_t keypoint_limit(const detect_params& params, std::uint64_t candidates) noexcept {
  std::size_t limit = params.max_keypoints;
  if (params.keypoint_share > 0) {
    // The product rounded to a double (exactly, on any IEEE machine), then up.
    const double share = std::ceil(params.keypoint_share * static_cast<double>(candidates));
    const std::size_t n = share >= 1.8e19 ? SIZE_MAX : static_cast<std::size_t>(share);
    // A share of no candidates keeps none: 0 would mean no limit, so keep one
    // (there is no keypoint without a candidate anyway).
    const std::size_t by_share = std::max<std::size_t>(1, n);
    limit = limit ? std::min(limit, by_share) : by_share;
  }
  return limit;
}

float keypoint_score(const detection_result& result, std::uint32_t i) noexcept {
  return detail::score_of(result.saliency.size(), [&](std::size_t m) { return result.saliency[m][i]; });
}

std::vector<std::uint32_t> strongest(const std::vector<std::uint32_t>& keypoints, const std::vector<float>& scores,
                                     std::size_t n) {
  if (scores.size() != keypoints.size())
    throw std::invalid_argument("strongest: one score per keypoint expected (" + std::to_string(scores.size()) +
                                " scores, " + std::to_string(keypoints.size()) + " keypoints)");
  std::vector<std::uint32_t> kept = keypoints;
  if (n != 0 && n < keypoints.size()) {
    std::vector<detail::rank_key> keys(keypoints.size());
    for (std::size_t q = 0; q < keys.size(); ++q) keys[q] = {scores[q], keypoints[q]};
    // Keys that tie are the same index twice: either copy gives the same list.
    std::nth_element(keys.begin(), keys.begin() + std::ptrdiff_t(n), keys.end(), detail::stronger);
    kept.resize(n);
    for (std::size_t q = 0; q < n; ++q) kept[q] = static_cast<std::uint32_t>(keys[q].index);
  }
  std::sort(kept.begin(), kept.end());
  return kept;
}

void keep_strongest(detection_result& result, std::size_t n) {
  std::vector<std::uint32_t> kept = strongest(result.keypoints, result.rank_score, n);
  result.rank_score = detail::ranks_of(result.keypoints, result.rank_score, kept);
  result.keypoints = std::move(kept);
}

void release_cached_memory() noexcept { detail::chunk_arena::release_cache(); }

detection_result detect(const point_cloud& cloud, const detect_params& params,
                        const std::vector<any_modality>& modalities) {
  std::vector<std::string> names;
  std::vector<double> thresholds;
  for (const auto& m : modalities) {
    if (!m) throw std::invalid_argument("empty modality in the list");
    names.push_back(m.name());
    thresholds.push_back(m.threshold(params));
  }
  detail::detection_context ctx(cloud, params, std::move(names), std::move(thresholds));
  if (!params.neighborhood.fixed()) {
    const detect_params twice = detail::twice_the_radius(params);
    std::vector<double> at_twice;
    for (const auto& m : modalities) at_twice.push_back(m.threshold(twice));
    ctx.scale_with_radius(at_twice);
  }
  std::vector<std::unique_ptr<bound_modality>> bound;
  std::vector<channel_source> sources;
  const auto t_bind = detail::clock_type::now();
  for (const auto& m : modalities) {
    bound.push_back(m.bind(cloud, params));
    sources.push_back(bound.back()->channels());
  }
  ctx.add_bind_ms(detail::ms_since(t_bind));
  ctx.compute_saliency(sources, [&](const block_view& block, float* const* columns) {
    for (std::size_t k = 0; k < bound.size(); ++k) bound[k]->evaluate(block, k, params.min_neighbors, columns[k]);
  });
  bound.clear();  // the modalities' channels are not needed by the NMS: less peak memory
  return ctx.finish();
}

}  // namespace ced
