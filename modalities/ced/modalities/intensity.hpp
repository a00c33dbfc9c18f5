// SPDX-License-Identifier: MIT
// Intensity (LiDAR return strength, grey level...): the absolute difference
// between a point's normalised intensity and its neighbours' mean.
//
// Reads the field `intensity` (any case), or another named in parentheses,
// intensity(NAME), or by `field=NAME` (one or the other).
// Normalisation as for bands: integer types by their range, floats as they
// are, or `range=LO..HI` / `range=auto`; like rgb, a 16-bit field holding
// only values in 0..255 is scaled by 255.
#pragma once

#include "ced/channels.hpp"
#include "ced/modality.hpp"

namespace ced {

struct intensity {
  static constexpr const char* spec_name = "intensity";
  /// One line for `ced modalities` and ced.modalities().
  static constexpr const char* spec_help = "a scalar field (default 'intensity'); intensity(FIELD); options range=";
  double threshold_value = 0.05;
  std::string field_name = "intensity";
  range_policy range;

  intensity() = default;
  explicit intensity(double threshold, std::string field = "intensity")
      : threshold_value(threshold), field_name(std::move(field)) {}

  std::string name() const { return field_name == "intensity" ? "intensity" : "intensity(" + field_name + ")"; }
  double threshold(const detect_params&) const { return threshold_value; }
  /// The fields bind() reads.
  std::vector<std::string> fields() const { return {field_name}; }
  /// range=zscore or pLO..HI: statistics of the whole cloud.
  std::vector<std::string> whole_cloud_fields() const {
    return range.needs_whole_cloud() ? fields() : std::vector<std::string>{};
  }
  centroid_distance<1> bind(const point_cloud& cloud, const detect_params& params) const {
    auto f = require_fields(cloud, {field_name}, name());
    // 8-bit intensities in a 16-bit field (LAS files from 8-bit sensors):
    // by 255, as rgb does, unless a range is given.
    // The same for integers wider than 16 bits (narrow_integer_range).
    const bool natural = range.how == range_policy::kind::natural;
    const std::optional<value_range> narrow = natural ? narrow_integer_range(*f[0]) : std::nullopt;
    const value_range r = natural && holds_8bit_in_16(*f[0]) ? value_range{0.0, 255.0}
                          : narrow                           ? *narrow
                                                             : resolve_range(*f[0], range);
    return centroid_distance<1>(interleave(f, params.threads), {1.0 / (r.hi - r.lo)}, norm_type::l1);
  }
  static intensity from_spec(modality_spec& s) {
    intensity m;
    m.threshold_value = s.threshold_or(0.05);
    if (s.args().size() > 1) throw std::invalid_argument("intensity takes at most one field name: " + s.text());
    if (s.args().size() == 1) m.field_name = s.args()[0];
    if (auto f = s.take("field")) {
      if (s.args().size() == 1)
        throw std::invalid_argument("intensity: field given twice, in parentheses and as field= (in '" + s.text() +
                                    "')");
      m.field_name = *f;
    }
    if (auto r = s.take("range")) m.range = range_policy::parse(*r);
    return m;
  }
};

}  // namespace ced
