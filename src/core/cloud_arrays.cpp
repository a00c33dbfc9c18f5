// SPDX-License-Identifier: MIT
// Clouds from arrays: positions from strided coordinates, channels copied
// from strided values, and the names of an N×k channel's fields. Shared by
// the Python module and the header-only Eigen and PCL adaptors.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/cloud.hpp"
#include "core/text.hpp"

namespace ced {
namespace {

template <class T>
void positions_of(point_cloud& cloud, const char* const axis[3], std::ptrdiff_t stride, std::size_t n,
                  std::string_view what) {
  const auto at = [&](int d, std::size_t i) {
    T v;
    std::memcpy(&v, axis[d] + std::ptrdiff_t(i) * stride, sizeof v);
    return double(v);
  };
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) {
      const double v = at(d, i);
      if (!std::isfinite(v))
        throw std::invalid_argument(std::string(what) + ": point " + std::to_string(i) + " has a " +
                                    (std::isnan(v) ? "NaN" : "infinite") + " coordinate");
      lo[d] = i ? std::min(lo[d], v) : v;
      hi[d] = i ? std::max(hi[d], v) : v;
    }
  std::array<double, 3> origin{0, 0, 0};
  if constexpr (std::is_same_v<T, double>) origin = choose_origin(lo, hi);
  cloud.set_origin(origin);
  cloud.resize(n);
  float* p = cloud.positions().data();
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) p[3 * i + std::size_t(d)] = static_cast<float>(at(d, i) - origin[std::size_t(d)]);
}

}  // namespace

void set_positions(point_cloud& cloud, scalar_type type, const void* x, const void* y, const void* z,
                   std::ptrdiff_t stride, std::size_t n, std::string_view what) {
  if (n >= std::size_t(UINT32_MAX)) throw std::invalid_argument(std::string(what) + ": more than 2^32 - 1 points");
  const char* axis[3] = {static_cast<const char*>(x), static_cast<const char*>(y), static_cast<const char*>(z)};
  if (type == scalar_type::float32)
    positions_of<float>(cloud, axis, stride, n, what);
  else if (type == scalar_type::float64)
    positions_of<double>(cloud, axis, stride, n, what);
  else
    throw std::invalid_argument(std::string(what) + ": coordinates must be float32 or float64, not " +
                                std::string(name_of(type)));
}

column copy_strided(scalar_type type, const void* data, std::ptrdiff_t stride, std::size_t n) {
  column c(type, n);
  const std::size_t size = size_of(type);
  unsigned char* out = c.bytes();
  const auto* in = static_cast<const unsigned char*>(data);
  if (stride == std::ptrdiff_t(size)) {
    if (n) std::memcpy(out, in, n * size);
    return c;
  }
  for (std::size_t i = 0; i < n; ++i) std::memcpy(out + i * size, in + std::ptrdiff_t(i) * stride, size);
  return c;
}

std::vector<std::string> channel_field_names(const std::string& name, std::size_t k, std::string_view what) {
  std::vector<std::string> names;
  if (name.find(',') != std::string::npos) {
    std::string cur;
    for (char c : name + ",") {
      if (c != ',') {
        cur += c;
        continue;
      }
      names.push_back(cur);
      cur.clear();
    }
    if (names.size() != k)
      throw std::invalid_argument(std::string(what) + ": the key names " + std::to_string(names.size()) +
                                  " columns but the array has " + std::to_string(k));
  } else {
    const auto is = [&](std::string_view w) { return detail::iequal(name, w); };
    if (k == 3 && (is("rgb") || is("colors") || is("colours") || is("color") || is("colour")))
      names = {"red", "green", "blue"};
    else if (k == 1)
      names = {name};
    else
      for (std::size_t j = 0; j < k; ++j) names.push_back(name + "_" + std::to_string(j));
  }
  for (std::size_t j = 0; j < names.size(); ++j) {
    if (names[j].empty()) throw std::invalid_argument(std::string(what) + ": empty field name");
    for (std::size_t i = 0; i < j; ++i)
      if (names[i] == names[j])
        throw std::invalid_argument(std::string(what) + ": the field '" + names[j] + "' is named twice");
  }
  return names;
}

std::vector<std::string> channel_field_names(const point_cloud& into, const std::string& name, std::size_t k,
                                             std::string_view what) {
  auto names = channel_field_names(name, k, what);
  for (const auto& n : names)
    if (into.find_field(n))
      throw std::invalid_argument(std::string(what) + ": the field '" + n +
                                  "' is given twice (by another channel or the cloud)");
  return names;
}

}  // namespace ced
