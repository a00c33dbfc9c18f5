// SPDX-License-Identifier: MIT
#include "ced/channels.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "ced/modality.hpp"
#include "core/parallel.hpp"
#include "core/text.hpp"

namespace ced {

bool holds_8bit_in_16(const field& f) {
  if (f.type() != scalar_type::uint16 && f.type() != scalar_type::int16) return false;
  if (f.whole_range) return f.whole_range->lo >= 0 && f.whole_range->hi <= 255;
  return f.values.visit([](const auto* v, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i)
      if (v[i] > 255 || v[i] < 0) return false;
    return true;
  });
}

std::optional<value_range> narrow_integer_range(const field& f) {
  const scalar_type t = f.type();
  if (t != scalar_type::int32 && t != scalar_type::uint32 && t != scalar_type::int64 && t != scalar_type::uint64)
    return std::nullopt;
  const auto [lo, hi] = data_range(f);
  if (lo < 0) return std::nullopt;
  if (hi <= 255) return value_range{0.0, 255.0};
  if (hi <= 65535) return value_range{0.0, 65535.0};
  return std::nullopt;
}

range_policy range_policy::parse(std::string_view text, const std::string& option) {
  range_policy p;
  if (text == "auto") {
    p.how = kind::data;
    return p;
  }
  if (text == "zscore") {
    p.how = kind::zscore;
    return p;
  }
  if (text == "quantile") text = "p2..98";
  if (!text.empty() && text[0] == 'p') {
    const auto dots = text.find("..");
    if (dots == std::string_view::npos)
      throw std::invalid_argument("option '" + option + "': percentiles are pLO..HI, e.g. p2..98, got '" +
                                  std::string(text) + "'");
    p.how = kind::percentiles;
    p.fixed.lo = parse_number(text.substr(1, dots - 1), option + " (low percentile)");
    p.fixed.hi = parse_number(text.substr(dots + 2), option + " (high percentile)");
    if (!(p.fixed.lo >= 0 && p.fixed.hi <= 100 && p.fixed.hi > p.fixed.lo))
      throw std::invalid_argument("option '" + option + "': percentiles must satisfy 0 <= LO < HI <= 100, got '" +
                                  std::string(text) + "'");
    return p;
  }
  const auto dots = text.find("..");
  if (dots == std::string_view::npos)
    throw std::invalid_argument("option '" + option + "' must be LO..HI, auto, zscore, quantile or pLO..HI, got '" +
                                std::string(text) + "'");
  p.how = kind::fixed;
  p.fixed.lo = parse_number(text.substr(0, dots), option + " (low end)");
  p.fixed.hi = parse_number(text.substr(dots + 2), option + " (high end)");
  if (!(p.fixed.hi > p.fixed.lo))
    throw std::invalid_argument("option '" + option + "': the high end must exceed the low end, got '" +
                                std::string(text) + "'");
  return p;
}

std::vector<double> field_sample(const field& f) {
  if (f.whole_sample) return *f.whole_sample;
  if (f.whole_range)
    throw std::invalid_argument(
        "field '" + f.name +
        "': range=zscore, range=pLO..HI and pca= need the whole cloud's sample, which this tile "
        "was not given (plan the tiles with this ced, which gathers it)");
  const std::size_t n = f.values.size(), m = whole_sample_count(n);
  std::vector<double> out(m);
  f.values.visit([&](const auto* p, std::size_t) {
    for (std::size_t j = 0; j < m; ++j) out[j] = static_cast<double>(p[whole_sample_index(j, n)]);
  });
  return out;
}

value_range data_range(const field& f) {
  if (f.whole_range) return *f.whole_range;
  if (f.values.empty()) return {0.0, 0.0};
  value_range r{f.values[0], f.values[0]};
  f.values.visit([&](const auto* p, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      const double v = static_cast<double>(p[i]);
      r.lo = std::min(r.lo, v);
      r.hi = std::max(r.hi, v);
    }
  });
  return r;
}

value_range resolve_range(const field& f, const range_policy& policy) {
  switch (policy.how) {
    case range_policy::kind::fixed:
      return policy.fixed;
    case range_policy::kind::natural: {
      const auto r = natural_range(f.type());
      return {r[0], r[1]};
    }
    case range_policy::kind::data: {
      value_range r = data_range(f);
      if (!(r.hi > r.lo)) r.hi = r.lo + 1.0;
      return r;
    }
    case range_policy::kind::zscore:
    case range_policy::kind::percentiles: {
      const bool z = policy.how == range_policy::kind::zscore;
      std::vector<double> v = field_sample(f);
      const std::size_t n = v.size();
      if (n == 0) return {0.0, 1.0};
      double lo = 0, hi = 0;
      if (z) {
        // Two passes in double, in index order: the same on any machine.
        double sum = 0;
        for (double x : v) sum += x;
        const double mean = sum / double(n);
        double ss = 0;
        for (double x : v) ss += (x - mean) * (x - mean);
        lo = mean;
        hi = mean + std::sqrt(ss / double(n));
      } else {
        // Percentile q: linear between the sorted values at rank q/100·(n − 1).
        std::sort(v.begin(), v.end());
        const auto at = [&](double q) {
          const double rank = q / 100.0 * double(n - 1);
          const auto k = static_cast<std::size_t>(rank);
          const double t = rank - double(k);
          return k + 1 < n ? v[k] + t * (v[k + 1] - v[k]) : v[n - 1];
        };
        lo = at(policy.fixed.lo);
        hi = at(policy.fixed.hi);
      }
      if (!(hi > lo)) hi = lo + 1.0;
      return {lo, hi};
    }
  }
  return {0.0, 1.0};
}

namespace {
/// The index of the first value of v[0, n) that is NaN, infinite or beyond
/// the float range (a channel is computed in float), or n; T is float or
/// double. Tested in chunks without an early exit, on the bits, which the
/// compiler vectorises; the failing chunk is then searched.
template <class T>
std::size_t first_unfit(const T* v, std::size_t n) noexcept {
  static_assert(std::is_floating_point_v<T>);
  using bits_type = std::conditional_t<sizeof(T) == 8, std::uint64_t, std::uint32_t>;
  constexpr int sign = 8 * sizeof(T) - 1;
  const T max = std::numeric_limits<float>::max();
  bits_type limit;
  std::memcpy(&limit, &max, sizeof limit);
  constexpr std::size_t chunk = 4096;
  for (std::size_t b = 0; b < n; b += chunk) {
    const std::size_t e = std::min(n, b + chunk);
    bits_type bad = 0;
    for (std::size_t i = b; i < e; ++i) {
      bits_type bits;
      std::memcpy(&bits, v + i, sizeof bits);
      // |v| > FLT_MAX (NaN and infinities included) makes the difference
      // negative: its sign bit is set.
      bad |= (limit - (bits & ~(bits_type(1) << sign))) >> sign;
    }
    if (bad == 0) continue;
    for (std::size_t i = b; i < e; ++i)
      if (!(std::fabs(v[i]) <= max)) return i;
  }
  return n;
}

/// The same for any column: integers always fit (even 2^64 is a finite float).
std::size_t first_unfit(const column& c) noexcept {
  switch (c.type()) {
    case scalar_type::float64:
      return first_unfit(c.data<double>(), c.size());
    case scalar_type::float32:
      return first_unfit(c.data<float>(), c.size());
    default:
      return c.size();
  }
}

std::string shortest(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}
}  // namespace

std::vector<float> interleave(const std::vector<const field*>& fields) { return interleave(fields, 1); }

std::vector<float> interleave(const std::vector<const field*>& fields, unsigned threads) {
  const std::size_t d = fields.size();
  if (d == 0) return {};
  const std::size_t n = fields[0]->values.size();
  std::vector<float> out(n * d);
  // Points a few KiB of rows at a time, every field into them, so that the
  // rows being written stay in cache however many fields there are. A value
  // that is NaN, infinite or beyond the float range is a float whose
  // exponent bits are all set, or ±FLT_MAX: each tile's rows are tested while
  // in cache, and only a failed test searches the fields (which also finds
  // whether a FLT_MAX was a value beyond it) for the message.
  const std::size_t tile = std::max<std::size_t>(16, 8192 / d);
  std::atomic<bool> unfit{false};
  detail::parallel_for(n, threads, 1 << 15, [&](std::size_t b, std::size_t e) {
    std::uint32_t bad = 0;
    for (std::size_t t0 = b; t0 < e; t0 += tile) {
      const std::size_t t1 = std::min(e, t0 + tile);
      for (std::size_t k = 0; k < d; ++k) {
        // Through double, as the values were read before fields kept their type.
        fields[k]->values.visit([&](const auto* v, std::size_t) {
          for (std::size_t i = t0; i < t1; ++i) out[i * d + k] = static_cast<float>(static_cast<double>(v[i]));
        });
      }
      const float* rows = out.data() + t0 * d;
      for (std::size_t j = 0; j < (t1 - t0) * d; ++j) {
        std::uint32_t bits;
        std::memcpy(&bits, rows + j, sizeof bits);
        // Also ±FLT_MAX, which a double just beyond the range rounds to:
        // the search below tells the two apart.
        bad |= static_cast<std::uint32_t>((bits & 0x7f800000u) == 0x7f800000u) |
               static_cast<std::uint32_t>((bits & 0x7fffffffu) == 0x7f7fffffu);
      }
    }
    if (bad) unfit = true;
  });
  if (unfit)
    for (const field* f : fields) {
      const std::size_t at = first_unfit(f->values);
      if (at != n)
        throw std::invalid_argument("field '" + f->name +
                                    "' has a value that is not finite or beyond the float range (" +
                                    shortest(f->values[at]) + ") at point " + std::to_string(at));
    }
  return out;
}

std::string missing_field_hint(const std::vector<std::string>& present, const std::string& field,
                               const std::string& modality) {
  for (const auto& name : present) {
    // A prefix, then '_' and the field's own name in any case.
    if (name.size() <= field.size() + 1) continue;
    const std::string_view tail = std::string_view(name).substr(name.size() - field.size() - 1);
    if (tail[0] != '_' || !detail::iequal(tail.substr(1), field)) continue;
    std::string hint = "; did you mean '" + name + "'?";
    if (modality == field) hint += " Name it in the spec: " + field + "(" + name + "):THRESHOLD";
    return hint;
  }
  return {};
}

std::vector<const field*> require_fields(const point_cloud& cloud, const std::vector<std::string>& names,
                                         const std::string& modality) {
  std::vector<const field*> out;
  for (const auto& name : names) {
    const field* f = cloud.find_field_icase(name);
    if (!f) {
      std::string present;
      std::vector<std::string> names_present;
      for (const auto& g : cloud.fields()) {
        present += (present.empty() ? "" : ", ") + g.name;
        names_present.push_back(g.name);
      }
      throw missing_field_error(
          modality, name,
          "modality '" + modality + "' needs field '" + name + "', which the cloud does not have (fields present: " +
              (present.empty() ? "none" : present) + ")" + missing_field_hint(names_present, name, modality));
    }
    require_finite(*f, modality);
    out.push_back(f);
  }
  return out;
}

namespace {
bool is_digit(char c) noexcept { return c >= '0' && c <= '9'; }
bool is_glob(std::string_view s) noexcept { return s.find_first_of("*?") != std::string_view::npos; }
}  // namespace

std::vector<std::string> expand_field_ranges(const std::vector<std::string>& names) {
  constexpr std::uint64_t most = 65536;
  std::vector<std::string> out;
  for (const std::string& name : names) {
    const std::size_t dots = name.find("..");
    if (dots == std::string::npos) {
      out.push_back(name);
      continue;
    }
    const std::string lo = name.substr(0, dots), hi = name.substr(dots + 2);
    const auto split = [&](const std::string& end, std::string& text, std::string& digits) {
      std::size_t d = end.size();
      while (d > 0 && is_digit(end[d - 1])) --d;
      text = end.substr(0, d);
      digits = end.substr(d);
      if (digits.empty() || digits.size() > 9)
        throw std::invalid_argument("field range '" + name +
                                    "': both ends must end in a number of 1 to 9 digits, e.g. b000..b191");
    };
    std::string lo_text, lo_digits, hi_text, hi_digits;
    split(lo, lo_text, lo_digits);
    split(hi, hi_text, hi_digits);
    if (!detail::iequal(lo_text, hi_text))
      throw std::invalid_argument("field range '" + name + "': the ends must share the text before their numbers ('" +
                                  lo_text + "' against '" + hi_text + "')");
    const std::uint64_t a = std::stoull(lo_digits), b = std::stoull(hi_digits);
    if (b < a) throw std::invalid_argument("field range '" + name + "' runs backwards");
    if (b - a + 1 > most)
      throw std::invalid_argument("field range '" + name + "' names " + std::to_string(b - a + 1) +
                                  " fields, more than " + std::to_string(most));
    const bool padded = (lo_digits.size() > 1 && lo_digits[0] == '0') || lo_digits.size() == hi_digits.size();
    for (std::uint64_t v = a; v <= b; ++v) {
      std::string number = std::to_string(v);
      if (padded && number.size() < lo_digits.size()) number.insert(0, lo_digits.size() - number.size(), '0');
      out.push_back(lo_text + number);
    }
  }
  return out;
}

bool field_name_matches(std::string_view pattern, std::string_view name) noexcept {
  if (!is_glob(pattern)) return detail::iequal(pattern, name);
  // Greedy with one backtrack point: the last '*' seen.
  std::size_t p = 0, n = 0, star = std::string_view::npos, from = 0;
  while (n < name.size()) {
    if (p < pattern.size() &&
        (pattern[p] == '?' || (pattern[p] != '*' && detail::ascii_lower(pattern[p]) == detail::ascii_lower(name[n])))) {
      ++p, ++n;
    } else if (p < pattern.size() && pattern[p] == '*') {
      star = p++;
      from = n;
    } else if (star != std::string_view::npos) {
      p = star + 1;
      n = ++from;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
}

std::vector<const field*> require_field_patterns(const point_cloud& cloud, const std::vector<std::string>& names,
                                                 const std::string& modality) {
  std::vector<const field*> out;
  const auto add = [&](const field* f, const std::string& named_as) {
    for (const field* g : out)
      if (g == f)
        throw std::invalid_argument("modality '" + modality + "' names field '" + f->name + "' twice (again as '" +
                                    named_as + "')");
    out.push_back(f);
  };
  for (const std::string& name : expand_field_ranges(names)) {
    if (!is_glob(name)) {
      add(require_fields(cloud, {name}, modality).front(), name);
      continue;
    }
    std::size_t matched = 0;
    std::string present;
    for (const field& f : cloud.fields()) {
      present += (present.empty() ? "" : ", ") + f.name;
      if (!field_name_matches(name, f.name)) continue;
      require_finite(f, modality);
      add(&f, name);
      ++matched;
    }
    if (matched == 0)
      throw missing_field_error(
          modality, name,
          "modality '" + modality + "': '" + name +
              "' matches no field of the cloud (fields present: " + (present.empty() ? "none" : present) + ")");
  }
  return out;
}

void require_finite(const field& f, const std::string& modality) {
  const std::size_t n = f.values.size();
  const std::size_t i = first_unfit(f.values);
  if (i == n) return;
  const double v = f.values[i];
  const std::string where = "modality '" + modality + "': field '" + f.name + "' has ";
  if (!std::isfinite(v))
    throw std::invalid_argument(where + "a non-finite value (" + std::to_string(v) + ") at point " + std::to_string(i));
  throw std::invalid_argument(where + "a value beyond the float range (" + shortest(v) + ") at point " +
                              std::to_string(i) + ": channels are computed in float; rescale the field");
}

}  // namespace ced

namespace ced {

namespace {
/// Symmetric k×k matrix a (row-major) diagonalised by cyclic Jacobi
/// rotations; v receives the eigenvectors as columns (row-major k×k).
void jacobi_eigen(std::vector<double>& a, std::vector<double>& v, std::size_t k) {
  v.assign(k * k, 0.0);
  for (std::size_t i = 0; i < k; ++i) v[i * k + i] = 1;
  for (int sweep = 0; sweep < 100; ++sweep) {
    double off = 0, diag = 0;
    for (std::size_t i = 0; i < k; ++i)
      for (std::size_t j = 0; j < k; ++j) (i == j ? diag : off) += std::abs(a[i * k + j]);
    if (off <= 1e-15 * diag || off == 0) break;
    for (std::size_t p = 0; p + 1 < k; ++p)
      for (std::size_t q = p + 1; q < k; ++q) {
        const double apq = a[p * k + q];
        if (apq == 0) continue;
        const double theta = (a[q * k + q] - a[p * k + p]) / (2 * apq);
        const double t = (theta >= 0 ? 1.0 : -1.0) / (std::abs(theta) + std::sqrt(theta * theta + 1));
        const double c = 1 / std::sqrt(t * t + 1), s = t * c;
        for (std::size_t r = 0; r < k; ++r) {  // a ← a·J
          const double arp = a[r * k + p], arq = a[r * k + q];
          a[r * k + p] = c * arp - s * arq;
          a[r * k + q] = s * arp + c * arq;
        }
        for (std::size_t r = 0; r < k; ++r) {  // a ← Jᵀ·a
          const double apr = a[p * k + r], aqr = a[q * k + r];
          a[p * k + r] = c * apr - s * aqr;
          a[q * k + r] = s * apr + c * aqr;
        }
        for (std::size_t r = 0; r < k; ++r) {  // v ← v·J
          const double vrp = v[r * k + p], vrq = v[r * k + q];
          v[r * k + p] = c * vrp - s * vrq;
          v[r * k + q] = s * vrp + c * vrq;
        }
      }
  }
}
}  // namespace

std::vector<float> principal_components(const std::vector<const field*>& fields, const std::vector<double>& scale,
                                        std::size_t k, unsigned threads, std::vector<double>* eigenvalues) {
  const std::size_t d = fields.size();
  if (k < 1 || k > d)
    throw std::invalid_argument("principal components: k must be from 1 to the number of fields (" + std::to_string(d) +
                                "), got " + std::to_string(k));
  if (scale.size() != d) throw std::invalid_argument("principal components: one scale per field");
  const std::size_t n = fields[0]->values.size();
  std::vector<float> out(n * k, 0.0f);
  if (n == 0) return out;
  // The sample (field_sample(): the whole cloud's, also in a tile), held
  // band by band (each band's values contiguous).
  std::vector<double> x;  // fields × sample, scaled
  std::size_t m = 0;
  for (std::size_t b = 0; b < d; ++b) {
    std::vector<double> v = field_sample(*fields[b]);
    if (b == 0) {
      m = v.size();
      x.resize(d * m);
    } else if (v.size() != m) {
      throw std::invalid_argument("principal components: field '" + fields[b]->name + "' has a sample of " +
                                  std::to_string(v.size()) + " values, field '" + fields[0]->name + "' one of " +
                                  std::to_string(m));
    }
    for (std::size_t j = 0; j < m; ++j) x[b * m + j] = v[j] * scale[b];
  }
  if (m == 0) return out;
  std::vector<double> mean(d, 0.0);
  for (std::size_t b = 0; b < d; ++b) {
    double s = 0;
    for (std::size_t j = 0; j < m; ++j) s += x[b * m + j];
    mean[b] = s / double(m);
    for (std::size_t j = 0; j < m; ++j) x[b * m + j] -= mean[b];
  }
  // Covariance (upper triangle, then mirrored), each entry a sum in sample order.
  std::vector<double> cov(d * d, 0.0);
  detail::parallel_for(d, threads, 1, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t a = b0; a < b1; ++a)
      for (std::size_t b = a; b < d; ++b) {
        const double* xa = x.data() + a * m;
        const double* xb = x.data() + b * m;
        // Four running sums (sample j into sum j mod 4), added in a fixed
        // order: independent chains for the CPU, the same bits every time.
        double s[4] = {0, 0, 0, 0};
        std::size_t j = 0;
        for (; j + 4 <= m; j += 4)
          for (std::size_t l = 0; l < 4; ++l) s[l] += xa[j + l] * xb[j + l];
        for (; j < m; ++j) s[j % 4] += xa[j] * xb[j];
        cov[a * d + b] = ((s[0] + s[1]) + (s[2] + s[3])) / double(m);
      }
  });
  for (std::size_t a = 0; a < d; ++a)
    for (std::size_t b = 0; b < a; ++b) cov[a * d + b] = cov[b * d + a];
  // Orthogonal iteration for the k leading eigenvectors (columns of q, d×k),
  // from a fixed start, then a Jacobi step on qᵀ C q to order them.
  std::vector<double> q(d * k), z(d * k);
  std::uint64_t lcg = 0x9E3779B97F4A7C15ull;
  for (double& v : q) {
    lcg = lcg * 6364136223846793005ull + 1442695040888963407ull;
    v = double(lcg >> 11) / double(1ull << 53) - 0.5;
  }
  auto orthonormalise = [&](std::vector<double>& w) {
    for (std::size_t c = 0; c < k; ++c) {
      for (std::size_t e = 0; e < c; ++e) {
        double dot = 0;
        for (std::size_t b = 0; b < d; ++b) dot += w[b * k + c] * w[b * k + e];
        for (std::size_t b = 0; b < d; ++b) w[b * k + c] -= dot * w[b * k + e];
      }
      double norm = 0;
      for (std::size_t b = 0; b < d; ++b) norm += w[b * k + c] * w[b * k + c];
      norm = std::sqrt(norm);
      for (std::size_t b = 0; b < d; ++b) w[b * k + c] = norm > 0 ? w[b * k + c] / norm : (b == c ? 1.0 : 0.0);
    }
  };
  orthonormalise(q);
  for (int it = 0; it < 300; ++it) {
    for (std::size_t a = 0; a < d; ++a)
      for (std::size_t c = 0; c < k; ++c) {
        double s = 0;
        for (std::size_t b = 0; b < d; ++b) s += cov[a * d + b] * q[b * k + c];
        z[a * k + c] = s;
      }
    orthonormalise(z);
    double change = 0;
    for (std::size_t t = 0; t < d * k; ++t) change = std::max(change, std::abs(std::abs(z[t]) - std::abs(q[t])));
    q.swap(z);
    if (change < 1e-13) break;
  }
  std::vector<double> h(k * k, 0.0), rot;
  for (std::size_t c = 0; c < k; ++c)
    for (std::size_t e = 0; e < k; ++e) {
      double s = 0;
      for (std::size_t a = 0; a < d; ++a) {
        double ca = 0;
        for (std::size_t b = 0; b < d; ++b) ca += cov[a * d + b] * q[b * k + e];
        s += q[a * k + c] * ca;
      }
      h[c * k + e] = s;
    }
  jacobi_eigen(h, rot, k);
  std::vector<std::size_t> order(k);
  for (std::size_t c = 0; c < k; ++c) order[c] = c;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return h[a * k + a] > h[b * k + b]; });
  std::vector<double> axes(d * k);  // d×k, the eigenvectors largest first
  for (std::size_t c = 0; c < k; ++c) {
    const std::size_t src = order[c];
    for (std::size_t b = 0; b < d; ++b) {
      double s = 0;
      for (std::size_t e = 0; e < k; ++e) s += q[b * k + e] * rot[e * k + src];
      axes[b * k + c] = s;
    }
    std::size_t big = 0;
    for (std::size_t b = 1; b < d; ++b)
      if (std::abs(axes[b * k + c]) > std::abs(axes[big * k + c])) big = b;
    if (axes[big * k + c] < 0)
      for (std::size_t b = 0; b < d; ++b) axes[b * k + c] = -axes[b * k + c];
  }
  if (eigenvalues) {
    eigenvalues->clear();
    for (std::size_t c = 0; c < k; ++c) eigenvalues->push_back(h[order[c] * k + order[c]]);
  }
  // Every point's components, in double from its own values (read as
  // floats, as interleave() gives them): the same for any split into threads.
  const std::vector<float> rows = interleave(fields, threads);
  detail::parallel_for(n, threads, 1 << 12, [&](std::size_t i0, std::size_t i1) {
    std::vector<double> v(d), acc(k);
    for (std::size_t i = i0; i < i1; ++i) {
      for (std::size_t b = 0; b < d; ++b) v[b] = double(rows[i * d + b]) * scale[b] - mean[b];
      std::fill(acc.begin(), acc.end(), 0.0);
      for (std::size_t b = 0; b < d; ++b)
        for (std::size_t c = 0; c < k; ++c) acc[c] += v[b] * axes[b * k + c];
      for (std::size_t c = 0; c < k; ++c) out[i * k + c] = static_cast<float>(acc[c]);
    }
  });
  return out;
}

}  // namespace ced
