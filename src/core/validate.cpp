// SPDX-License-Identifier: MIT
// Stage 0 of detection: parameters, modalities and coordinates are checked.
#include "core/validate.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/text.hpp"

namespace ced {

void validate(const detect_params& p) {
  // At most 1e30: the kernels square radii in float, whose range ends at 3.4e38 (an NMS radius of 1e39 never
  // finished).
  auto positive = [](double v, const char* what) {
    if (!std::isfinite(v) || !(v > 0) || v > 1e30)
      throw std::invalid_argument(std::string(what) + " must be a positive finite number of at most 1e30, got " +
                                  std::to_string(v));
  };
  // A normal double: of a denormal radius, a threshold's 0.2 r may be 0, which made every point a candidate
  // (r = 1e-323: all of them keypoints). Any radius from there on below the spacing finds nothing.
  auto not_tiny = [](double v, const char* what) {
    if (v < std::numeric_limits<double>::min())
      throw std::invalid_argument(std::string(what) + " must be at least 2.2e-308 (a normal number), got " +
                                  detail::number_text(v));
  };
  positive(p.radius, "radius");
  positive(p.nms_radius, "nms_radius");
  not_tiny(p.radius, "radius");
  not_tiny(p.nms_radius, "nms_radius");
  positive(p.block_scale, "block_scale");
  if (!(p.keypoint_share >= 0 && p.keypoint_share <= 1))
    throw std::invalid_argument("keypoint_share must be a share from 0 to 1 (0: no limit), got " +
                                std::to_string(p.keypoint_share));
  validate(p.neighborhood);
  if (p.search != search_kind::grid && p.search != search_kind::cgal)
    throw std::invalid_argument("search must be grid or cgal");
  if (p.threads > 4096) throw std::invalid_argument("threads must be at most 4096, got " + std::to_string(p.threads));
}

namespace detail {

void check_inputs(const point_cloud& cloud, const detect_params& params, const std::vector<std::string>& names,
                  const std::vector<double>& thresholds) {
  validate(params);
  if (names.empty()) throw std::invalid_argument("no modality given: detection needs at least one");
  for (std::size_t m = 0; m < names.size(); ++m)
    if (!std::isfinite(thresholds[m]) || thresholds[m] < 0)
      throw std::invalid_argument("threshold of modality '" + names[m] + "' must be a finite number >= 0, got " +
                                  std::to_string(thresholds[m]));
  const auto& xyz = cloud.positions();
  // In chunks without an early exit, on the bits, which vectorises; the
  // failing chunk is then searched.
  constexpr std::size_t chunk = 4096;
  for (std::size_t b = 0; b < xyz.size(); b += chunk) {
    const std::size_t e = std::min(xyz.size(), b + chunk);
    std::uint32_t bad = 0;
    for (std::size_t i = b; i < e; ++i) {
      std::uint32_t bits;
      std::memcpy(&bits, xyz.data() + i, sizeof bits);
      // The exponent field all ones (NaN or infinite) carries into bit 31.
      bad |= ((bits & 0x7f800000u) + (1u << 23)) & (1u << 31);
    }
    if (bad == 0) continue;
    for (std::size_t i = b; i < e; ++i)
      if (!std::isfinite(xyz[i]))
        throw std::invalid_argument("point " + std::to_string(i / 3) +
                                    " has a non-finite coordinate (remove NaN/Inf points first)");
  }
  // adaptive with max: fewer than K points make the K-th distance infinite,
  // and every radius max (what a tile with few points needs).
  const neighborhood_spec& nb = params.neighborhood;
  if (!nb.fixed() && nb.k > cloud.size() && (nb.kind == neighborhood_kind::knn || !std::isfinite(nb.max_radius)))
    throw std::invalid_argument("neighbourhood " + to_string(params.neighborhood) + ": K is larger than the cloud (" +
                                std::to_string(cloud.size()) + " points)");
  if (cloud.size() >= std::size_t(UINT32_MAX)) throw std::invalid_argument("too many points (at most 2^32-2)");
}
}  // namespace detail

}  // namespace ced
