// SPDX-License-Identifier: MIT
// Colour: the L1 distance from a point's colour to the mean colour of its
// neighbours, each channel scaled to [0,1] (paper threshold: 0.1, range 0..3).
//
// Reads red/green/blue (or r/g/b, any case). Integer channels are scaled by
// their type's range (uchar: /255), except 16-bit channels that hold only
// 8-bit values (common in LAS files), which are scaled by 255. Float channels
// are taken to be in [0,1] already. `range=LO..HI` or `range=auto` overrides.
#pragma once

#include "ced/channels.hpp"
#include "ced/modality.hpp"

namespace ced {

struct rgb {
  static constexpr const char* spec_name = "rgb";
  /// One line for `ced modalities` and ced.modalities().
  static constexpr const char* spec_help = "colour: L1 distance in RGB scaled to [0,1]; options norm=, range=";
  double threshold_value = 0.1;
  norm_type norm = norm_type::l1;
  std::optional<range_policy> range;

  rgb() = default;
  explicit rgb(double threshold, norm_type n = norm_type::l1) : threshold_value(threshold), norm(n) {}

  std::string name() const { return "rgb"; }
  double threshold(const detect_params&) const { return threshold_value; }
  /// The fields bind() reads.
  std::vector<std::string> fields() const { return rgb_field_names(); }
  /// range=zscore or pLO..HI: statistics of the whole cloud.
  std::vector<std::string> whole_cloud_fields() const {
    return range && range->needs_whole_cloud() ? fields() : std::vector<std::string>{};
  }
  centroid_distance<3> bind(const point_cloud& cloud, const detect_params& params) const {
    const auto f = fields(cloud);
    const auto s = scale(f, range);
    return centroid_distance<3>(interleave({f[0], f[1], f[2]}, params.threads), {s[0], s[1], s[2]}, norm);
  }

  /// The colour fields; throws naming the fields present when there are none.
  static std::array<const field*, 3> fields(const point_cloud& cloud) {
    const auto f = find_rgb_fields(cloud);
    if (!f[0]) require_fields(cloud, {"red", "green", "blue"}, "rgb");  // throws the message
    for (const field* c : f) require_finite(*c, "rgb");
    return f;
  }

  /// Per-channel scale 1/(hi-lo) under `range`, or the default rule above.
  /// (8-bit values in wider integer fields: by 255 when all three hold
  /// them; integers wider than 16 bits otherwise by 65535 where their values
  /// fit, narrow_integer_range.)
  static std::array<double, 3> scale(const std::array<const field*, 3>& f, const std::optional<range_policy>& range) {
    std::array<std::optional<value_range>, 3> narrow;
    bool eight_bit = !range;
    for (std::size_t c = 0; c < 3; ++c) {
      if (!range) narrow[c] = narrow_integer_range(*f[c]);
      eight_bit = eight_bit && (holds_8bit_in_16(*f[c]) || (narrow[c] && narrow[c]->hi == 255));
    }
    std::array<double, 3> s{};
    for (std::size_t c = 0; c < 3; ++c) {
      const value_range r = eight_bit   ? value_range{0.0, 255.0}
                            : narrow[c] ? value_range{0.0, 65535.0}
                                        : resolve_range(*f[c], range.value_or(range_policy{}));
      s[c] = 1.0 / (r.hi - r.lo);
    }
    return s;
  }

  static rgb from_spec(modality_spec& s) {
    rgb m;
    m.threshold_value = s.threshold_or(0.1);
    if (auto n = s.take("norm")) m.norm = parse_norm(*n);
    if (auto r = s.take("range")) m.range = range_policy::parse(*r);
    return m;
  }
};

}  // namespace ced
