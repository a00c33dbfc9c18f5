// SPDX-License-Identifier: MIT
// Bands: any list of named scalar channels (multispectral bands, NIR, ...)
// as one vector-valued modality; by default the L1 distance to the
// neighbours' mean with every band normalised to [0,1].
//
//   bands(nir,red,red_edge):0.1              integer bands by their type's range
//   bands(b1,b2):0.05,range=0..10000         one fixed range for all bands
//   bands(b1,b2):0.05,range=auto,norm=l2     each band by its own data range, L2
//   bands(b000..b191):0.1,range=auto         a range of names: b000, b001, ..., b191
//   bands(b*):0.1                            every field whose name matches, in the cloud's order
//   bands(b*):0.1,range=zscore,pca=8         the first 8 principal components of the standardised bands
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/channels.hpp"
#include "ced/modality.hpp"

namespace ced {

struct bands {
  static constexpr const char* spec_name = "bands";
  /// One line for `ced modalities` and ced.modalities().
  static constexpr const char* spec_help =
      "bands(F1,F2,...): named channels as one vector; F may be a range (b000..b191) or a glob (b*); options norm=, "
      "range=, pca=";
  std::vector<std::string> names;
  double threshold_value = 0.1;
  norm_type norm = norm_type::l1;
  range_policy range;
  /// > 0: the distance over the first `pca` principal components of the
  /// bands (after their range scaling) instead of the bands themselves.
  std::size_t pca = 0;

  bands() = default;
  explicit bands(std::vector<std::string> fields, double threshold = 0.1, norm_type n = norm_type::l1)
      : names(std::move(fields)), threshold_value(threshold), norm(n) {}

  std::string name() const {
    std::string s = "bands(";
    for (std::size_t i = 0; i < names.size(); ++i) s += (i ? "," : "") + names[i];
    return s + ")";
  }
  double threshold(const detect_params&) const { return threshold_value; }
  /// The fields bind() reads: ranges expanded, globs as patterns
  /// (field_selection and the tiles' field lists match them).
  std::vector<std::string> fields() const { return expand_field_ranges(names); }
  /// range=zscore or pLO..HI, or pca=: statistics of the whole cloud.
  std::vector<std::string> whole_cloud_fields() const {
    return range.needs_whole_cloud() || pca > 0 ? fields() : std::vector<std::string>{};
  }
  centroid_distance<0> bind(const point_cloud& cloud, const detect_params& params) const {
    if (names.empty()) throw std::invalid_argument("bands() needs at least one field name, e.g. bands(nir,red)");
    auto f = require_field_patterns(cloud, names, name());
    // The default scaling takes integers by their type's range and floats as
    // already in [0, 1]: float bands beside integer ones must be so.
    if (range.how == range_policy::kind::natural &&
        std::any_of(f.begin(), f.end(), [](const field* x) { return is_integer(x->type()); }))
      for (const field* b : f) {
        if (is_integer(b->type())) continue;
        const value_range r = data_range(*b);
        if (r.lo < 0 || r.hi > 1) {
          char span[64];
          std::snprintf(span, sizeof span, "%g .. %g", r.lo, r.hi);
          throw std::invalid_argument("modality '" + name() +
                                      "' mixes integer bands, scaled to [0, 1] by their type's range, with float "
                                      "band '" +
                                      b->name + "' (" + std::string(name_of(b->type())) + ", " + span +
                                      "), taken as already in [0, 1]: give them one scale with range=auto, zscore, "
                                      "quantile or LO..HI");
        }
      }
    std::vector<double> scale;
    for (const field* b : f) {
      const value_range r = resolve_range(*b, range);
      scale.push_back(1.0 / (r.hi - r.lo));
    }
    if (pca > 0) {
      if (pca > f.size())
        throw std::invalid_argument("modality '" + name() + "': pca=" + std::to_string(pca) + " but it reads " +
                                    std::to_string(f.size()) + " band(s)");
      return centroid_distance<0>(principal_components(f, scale, pca, params.threads), std::vector<double>(pca, 1.0),
                                  norm);
    }
    return centroid_distance<0>(interleave(f, params.threads), scale, norm);
  }
  static bands from_spec(modality_spec& s) {
    bands m;
    m.names = s.args();
    if (m.names.empty())
      throw std::invalid_argument("'" + s.text() + "': bands needs field names, e.g. bands(nir,red)");
    m.threshold_value = s.threshold_or(0.1);
    if (auto n = s.take("norm")) m.norm = parse_norm(*n);
    if (auto r = s.take("range")) m.range = range_policy::parse(*r);
    if (auto k = s.take("pca")) {
      const double v = parse_number(*k, "pca= in '" + s.text() + "'");
      if (!(v >= 1) || v != std::floor(v) || v > 65536)
        throw std::invalid_argument("'" + s.text() + "': pca= must be a whole number of components >= 1");
      m.pca = static_cast<std::size_t>(v);
    }
    return m;
  }
};

}  // namespace ced
