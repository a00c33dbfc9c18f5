// SPDX-License-Identifier: MIT
// The neighbourhood parameter: its text form and its checks.
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "ced/modality.hpp"  // parse_number
#include "ced/params.hpp"
#include "core/text.hpp"

namespace ced {

namespace {
constexpr std::uint32_t k_max_k = 65535;

std::uint32_t parse_k(std::string_view text, const std::string& spec) {
  const std::string what = "K in neighbourhood '" + spec + "'";
  const double v = parse_number(text, what);
  if (v != std::floor(v) || v < 1 || v > k_max_k)
    throw std::invalid_argument(what + " must be a whole number from 1 to 65535, got '" +
                                std::string(detail::trim(text)) + "'");
  return static_cast<std::uint32_t>(v);
}
}  // namespace

neighborhood_spec parse_neighborhood(const std::string& text) {
  const std::string t(detail::trim(text));
  neighborhood_spec n;
  if (t == "radius") return n;
  const auto colon = t.find(':');
  const std::string kind = t.substr(0, colon);
  if (kind != "knn" && kind != "adaptive")
    throw std::invalid_argument(
        "neighbourhood must be radius, knn:K[,nms=own][,reach=R] or "
        "adaptive:K[,scale=a][,min=r0][,max=r1][,nms=own][,reach=R], got '" +
        t + "'");
  if (colon == std::string::npos)
    throw std::invalid_argument("neighbourhood '" + t + "' needs K, e.g. '" + kind + ":16'");
  n.kind = kind == "knn" ? neighborhood_kind::knn : neighborhood_kind::adaptive;
  std::string_view rest(t);
  rest.remove_prefix(colon + 1);
  const auto comma = rest.find(',');
  n.k = parse_k(rest.substr(0, comma), t);
  if (comma == std::string_view::npos) return n;
  rest.remove_prefix(comma + 1);
  const bool knn = n.kind == neighborhood_kind::knn;
  bool seen[5] = {false, false, false, false, false};
  // Every comma is followed by an option: "knn:8," and "adaptive:8,max=1,"
  // leave one out, as "adaptive:8,,max=1" does.
  for (bool more = true; more;) {
    const auto end = rest.find(',');
    const std::string_view option = rest.substr(0, end);
    more = end != std::string_view::npos;
    rest.remove_prefix(more ? end + 1 : rest.size());
    if (detail::trim(option).empty())
      throw std::invalid_argument("neighbourhood '" + t + "': an empty option (a trailing or doubled comma)");
    const auto eq = option.find('=');
    const std::string key(detail::trim(option.substr(0, eq)));
    const int slot = key == "nms"     ? 3
                     : key == "reach" ? 4
                     : knn            ? -1
                     : key == "scale" ? 0
                     : key == "min"   ? 1
                     : key == "max"   ? 2
                                      : -1;
    if (eq == std::string_view::npos || slot < 0)
      throw std::invalid_argument("neighbourhood '" + t + "': unknown option '" + std::string(option) +
                                  (knn ? "' (knn takes nms=, reach=)" : "' (known: scale=, min=, max=, nms=, reach=)"));
    if (seen[slot]) throw std::invalid_argument("neighbourhood '" + t + "': " + key + "= given twice");
    seen[slot] = true;
    const std::string value(detail::trim(option.substr(eq + 1)));
    if (slot == 3) {
      if (value != "own" && value != "fixed")
        throw std::invalid_argument("neighbourhood '" + t + "': nms= must be own or fixed, got '" + value + "'");
      n.nms_own = value == "own";
      continue;
    }
    const double v = parse_number(value, key + "= in neighbourhood '" + t + "'");
    (slot == 0 ? n.scale : slot == 1 ? n.min_radius : slot == 2 ? n.max_radius : n.reach) = v;
  }
  validate(n);
  return n;
}

namespace {
/// The shortest text that reads back as v.
std::string shortest(double v) {
  char text[32];
  const auto r = std::to_chars(text, text + sizeof text, v);
  return std::string(text, r.ptr);
}
}  // namespace

search_kind parse_search_kind(std::string_view text) {
  if (text == "grid") return search_kind::grid;
  if (text == "cgal") return search_kind::cgal;
  throw std::invalid_argument("must be grid or cgal, got '" + std::string(text) + "'");
}

const char* to_string(search_kind s) noexcept { return s == search_kind::cgal ? "cgal" : "grid"; }

std::string to_string(const neighborhood_spec& n) {
  if (n.kind == neighborhood_kind::radius) return "radius";
  std::string s = (n.kind == neighborhood_kind::knn ? "knn:" : "adaptive:") + std::to_string(n.k);
  if (n.kind == neighborhood_kind::adaptive) {
    if (n.scale != 1.0) s += ",scale=" + shortest(n.scale);
    if (n.min_radius != 0.0) s += ",min=" + shortest(n.min_radius);
    if (std::isfinite(n.max_radius)) s += ",max=" + shortest(n.max_radius);
  }
  if (n.nms_own) s += ",nms=own";
  if (std::isfinite(n.reach)) s += ",reach=" + shortest(n.reach);
  return s;
}

void validate(const neighborhood_spec& n) {
  if (n.kind == neighborhood_kind::radius) return;
  const std::string name = n.kind == neighborhood_kind::knn ? "knn" : "adaptive";
  if (n.k < 1 || n.k > k_max_k)
    throw std::invalid_argument("neighbourhood " + name + ": K must be from 1 to 65535, got " + std::to_string(n.k));
  if (std::isnan(n.reach) || !(n.reach > 0))
    throw std::invalid_argument("neighbourhood " + name + ": reach must be a positive number, got " +
                                std::to_string(n.reach));
  if (n.kind == neighborhood_kind::knn) return;
  if (!std::isfinite(n.scale) || !(n.scale > 0))
    throw std::invalid_argument("neighbourhood adaptive: scale must be a positive finite number, got " +
                                std::to_string(n.scale));
  // (At most 1e30, as radii are: the kernels square them in float.)
  if (!std::isfinite(n.min_radius) || n.min_radius < 0 || n.min_radius > 1e30)
    throw std::invalid_argument("neighbourhood adaptive: min must be a number from 0 to 1e30, got " +
                                std::to_string(n.min_radius));
  if (std::isnan(n.max_radius) || !(n.max_radius > 0) || (std::isfinite(n.max_radius) && n.max_radius > 1e30))
    throw std::invalid_argument(
        "neighbourhood adaptive: max must be a positive number of at most 1e30 (or none), got " +
        std::to_string(n.max_radius));
  if (n.min_radius > n.max_radius)
    throw std::invalid_argument("neighbourhood adaptive: min (" + std::to_string(n.min_radius) +
                                ") is larger than max (" + std::to_string(n.max_radius) + ")");
}

}  // namespace ced
