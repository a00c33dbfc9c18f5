// SPDX-License-Identifier: MIT
#include "ced/channels.hpp"

#include <algorithm>
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
  double lo = 0, hi = 0;
  if (f.whole_range) {
    lo = f.whole_range->lo;
    hi = f.whole_range->hi;
  } else if (f.values.size() > 0) {
    f.values.visit([&](const auto* v, std::size_t n) {
      auto mn = v[0], mx = v[0];
      for (std::size_t i = 1; i < n; ++i) {
        mn = std::min(mn, v[i]);
        mx = std::max(mx, v[i]);
      }
      lo = double(mn);
      hi = double(mx);
    });
  }
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

value_range resolve_range(const field& f, const range_policy& policy) {
  switch (policy.how) {
    case range_policy::kind::fixed:
      return policy.fixed;
    case range_policy::kind::natural: {
      const auto r = natural_range(f.type());
      return {r[0], r[1]};
    }
    case range_policy::kind::data: {
      if (f.whole_range) {
        const value_range w = *f.whole_range;
        return {w.lo, w.hi > w.lo ? w.hi : w.lo + 1.0};
      }
      if (f.values.empty()) return {0.0, 1.0};
      double lo = f.values[0], hi = f.values[0];
      f.values.visit([&](const auto* p, std::size_t n) {
        for (std::size_t i = 0; i < n; ++i) {
          const double v = static_cast<double>(p[i]);
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
      });
      if (!(hi > lo)) hi = lo + 1.0;
      return {lo, hi};
    }
    case range_policy::kind::zscore:
    case range_policy::kind::percentiles: {
      const bool z = policy.how == range_policy::kind::zscore;
      if (f.whole_range)
        throw std::invalid_argument("field '" + f.name + "': range=" + (z ? "zscore" : "pLO..HI") +
                                    " needs the whole cloud's values, which a tile does not have; in tiled runs use "
                                    "range=auto or a fixed range");
      const std::size_t n = f.values.size();
      if (n == 0) return {0.0, 1.0};
      std::vector<double> v(n);
      for (std::size_t i = 0; i < n; ++i) v[i] = f.values[i];
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
  for (const field* f : fields) {
    const std::size_t bad = first_unfit(f->values);
    if (bad != n)
      throw std::invalid_argument("field '" + f->name + "' has a value that is not finite or beyond the float range (" +
                                  shortest(f->values[bad]) + ") at point " + std::to_string(bad));
  }
  std::vector<float> out(n * d);
  // Points a few KiB of rows at a time, every field into them, so that the
  // rows being written stay in cache however many fields there are.
  const std::size_t tile = std::max<std::size_t>(16, 8192 / d);
  detail::parallel_for(n, threads, 1 << 15, [&](std::size_t b, std::size_t e) {
    for (std::size_t t0 = b; t0 < e; t0 += tile) {
      const std::size_t t1 = std::min(e, t0 + tile);
      for (std::size_t k = 0; k < d; ++k) {
        // Through double, as the values were read before fields kept their type.
        fields[k]->values.visit([&](const auto* v, std::size_t) {
          for (std::size_t i = t0; i < t1; ++i) out[i * d + k] = static_cast<float>(static_cast<double>(v[i]));
        });
      }
    }
  });
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
