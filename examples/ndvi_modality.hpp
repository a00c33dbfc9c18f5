// SPDX-License-Identifier: MIT
// A modality on the fast path: NDVI, summed by the detector's own pass.
//
// NDVI = (NIR − red) / (NIR + red) is the vegetation index of remote sensing,
// in [−1, 1]. Its saliency here is the distance from a point's NDVI to the
// mean NDVI of its neighbours, divided by 2 so that it lies in [0, 1]:
// a point on the edge of a field, a tree among grass, a plant's stem.
//
// bind() computes one float per point; the evaluator it returns tells the
// detector which values to sum (channels()) and turns the sums into a
// saliency (from_sums()). The detector sums Σ (v_j − v_i) over every point's
// neighbours for all such modalities at once, in its vectorised neighbour
// pass, so this costs about as much as any built-in modality.
//
//   ndvi                     fields nir and red
//   ndvi(B8,B4):0.05         other field names (Sentinel-2 bands 8 and 4)
#pragma once

#include <ced/core.hpp>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace example {

struct ndvi {
  static constexpr const char* spec_name = "ndvi";
  double threshold_value = 0.1;
  std::string nir = "nir", red = "red";

  std::string name() const { return nir == "nir" && red == "red" ? "ndvi" : "ndvi(" + nir + "," + red + ")"; }
  double threshold(const ced::detect_params&) const { return threshold_value; }
  /// The fields bind() reads, so that the CLI reads only those from a file.
  std::vector<std::string> fields() const { return {nir, red}; }

  /// The fast-path evaluator: channels() + from_sums().
  struct evaluator {
    std::vector<float> values;  // one NDVI per point; lives as long as the detection
    ced::channel_source channels() const { return {values.data(), 1, false}; }
    /// sums[0] = Σ_{j ∈ N(i)} (v_j − v_i); n = |N(i)| ≥ min_neighbors.
    float from_sums(const double* sums, std::uint32_t n) const { return static_cast<float>(std::abs(sums[0] / n) / 2); }
  };

  evaluator bind(const ced::point_cloud& cloud, const ced::detect_params&) const {
    // Throws, naming the modality and the fields present, when one is missing
    // or holds NaN/Inf.
    const auto f = ced::require_fields(cloud, {nir, red}, name());
    evaluator e;
    e.values.resize(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const double n = f[0]->values[i], r = f[1]->values[i];
      e.values[i] = n + r > 0 ? static_cast<float>((n - r) / (n + r)) : 0.0f;
    }
    return e;
  }

  static ndvi from_spec(ced::modality_spec& s) {
    ndvi m;
    m.threshold_value = s.threshold_or(0.1);
    const auto& fields = s.args();
    if (fields.size() == 2) {
      m.nir = fields[0];
      m.red = fields[1];
    } else if (!fields.empty()) {
      throw std::invalid_argument("'" + s.text() + "': ndvi takes two fields, ndvi(NIR,RED)");
    }
    return m;
  }
};

}  // namespace example
