// SPDX-License-Identifier: MIT
// Spectral angle (SAM): the angle between a point's spectrum v_i (its
// bands, raw) and the mean spectrum m_i of its neighbours (the point
// itself included), in radians:
//
//     s_i = ∠(v_i, m_i) = 2 · atan( |u − w| / |u + w| ),  u = v_i/|v_i|, w = m_i/|m_i|
//
// in [0, π]. A point whose bands are all zero has no direction: bind()
// refuses it, naming the point, as it refuses bands of different types
// (different units: the angle would mix them); a mean spectrum of zero
// (bands with negative values that cancel) gives 0. The angle does not change
// when a spectrum is scaled (illumination, gain between flight lines), which
// the distance of `bands` does. Kahan's form of the angle stays accurate for
// the small angles between neighbouring spectra, where acos loses them. The
// arctangent is ced's own (arithmetic and square roots only), so the result
// is the same on every CPU.
//
//   sam(b000..b191):0.05      a range of bands, threshold in radians
//   sam(nir,red,green)        named bands (ranges and globs as in bands())
#pragma once

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/channels.hpp"
#include "ced/modality.hpp"

namespace ced {

namespace detail {
/// atan(x) for x ≥ 0 (or +inf) in double from +, −, ×, ÷ and √ alone, so the
/// same bits on every CPU: halving the angle three times (atan x =
/// 2 atan(x / (1 + √(1 + x²)))) after x > 1 is folded to 1/x, then the
/// Taylor series to x^25 (|x| ≤ 0.1 there: error below 1e-26).
inline double portable_atan(double x) noexcept {
  if (!(x >= 0)) return 0;
  if (x > 1e300) return 1.5707963267948966;
  const bool folded = x > 1;
  if (folded) x = 1 / x;
  double scale = 1;
  for (int k = 0; k < 3; ++k) {
    x = x / (1 + std::sqrt(1 + x * x));
    scale *= 2;
  }
  const double x2 = x * x;
  double term = x, sum = 0;
  for (int k = 0; k < 13; ++k) {
    sum += term / double(2 * k + 1) * (k % 2 ? -1 : 1);
    term *= x2;
  }
  const double a = scale * sum;
  return folded ? 1.5707963267948966 - a : a;
}
}  // namespace detail

struct sam {
  static constexpr const char* spec_name = "sam";
  /// One line for `ced modalities` and ced.modalities().
  static constexpr const char* spec_help =
      "sam(F1,F2,...): spectral angle (radians) to the neighbours' mean spectrum; insensitive to scale; F may be a "
      "range (b000..b191) or a glob (b*)";
  std::vector<std::string> names;
  double threshold_value = 0.05;

  sam() = default;
  explicit sam(std::vector<std::string> fields, double threshold = 0.05)
      : names(std::move(fields)), threshold_value(threshold) {}

  std::string name() const {
    std::string s = "sam(";
    for (std::size_t i = 0; i < names.size(); ++i) s += (i ? "," : "") + names[i];
    return s + ")";
  }
  double threshold(const detect_params&) const { return threshold_value; }
  /// The fields bind() reads: ranges expanded, globs as patterns.
  std::vector<std::string> fields() const { return expand_field_ranges(names); }

  struct evaluator {
    std::vector<float> values;  // N×D, raw
    std::uint32_t dims = 0;
    channel_source channels() const { return {values.data(), dims, false}; }
    float from_sums(const double* sums, std::uint32_t n, std::uint32_t point) const {
      const float* v = values.data() + std::size_t(dims) * point;
      double vv = 0, mm = 0;
      for (std::uint32_t d = 0; d < dims; ++d) {
        const double m = double(v[d]) + sums[d] / n;
        vv += double(v[d]) * double(v[d]);
        mm += m * m;
      }
      if (!(vv > 0) || !(mm > 0)) return 0.0f;
      const double iv = 1 / std::sqrt(vv), im = 1 / std::sqrt(mm);
      double diff = 0, sum = 0;
      for (std::uint32_t d = 0; d < dims; ++d) {
        const double u = double(v[d]) * iv, w = (double(v[d]) + sums[d] / n) * im;
        diff += (u - w) * (u - w);
        sum += (u + w) * (u + w);
      }
      if (!(sum > 0)) return 3.14159265358979323846f;  // opposite spectra
      return static_cast<float>(2 * detail::portable_atan(std::sqrt(diff) / std::sqrt(sum)));
    }
  };
  evaluator bind(const point_cloud& cloud, const detect_params& params) const {
    if (names.empty()) throw std::invalid_argument("sam() needs at least two bands, e.g. sam(nir,red,green)");
    const auto f = require_field_patterns(cloud, names, name());
    if (f.size() < 2)
      throw std::invalid_argument("modality '" + name() + "' reads " + std::to_string(f.size()) +
                                  " band: a spectral angle needs at least two");
    for (const field* b : f)
      if (b->type() != f[0]->type())
        throw std::invalid_argument("modality '" + name() + "' reads bands of different types ('" + f[0]->name + "' " +
                                    std::string(name_of(f[0]->type())) + ", '" + b->name + "' " +
                                    std::string(name_of(b->type())) +
                                    "): a spectral angle needs every band in one unit; convert them to one type");
    evaluator e{interleave(f, params.threads), static_cast<std::uint32_t>(f.size())};
    const std::size_t d = f.size(), n = e.values.size() / d;
    for (std::size_t i = 0; i < n; ++i) {
      const float* v = e.values.data() + i * d;
      bool zero = true;
      for (std::size_t k = 0; k < d; ++k) zero = zero && v[k] == 0.0f;
      if (zero)
        throw std::invalid_argument("modality '" + name() + "': point " + std::to_string(i) +
                                    " has every band 0, a spectrum with no direction, whose angle is undefined "
                                    "(drop such points first, or use bands())");
    }
    return e;
  }
  static sam from_spec(modality_spec& s) {
    sam m;
    m.names = s.args();
    if (m.names.empty())
      throw std::invalid_argument("'" + s.text() + "': sam needs band names, e.g. sam(nir,red,green) or sam(b*)");
    m.threshold_value = s.threshold_or(0.05);
    return m;
  }
};

}  // namespace ced
