// SPDX-License-Identifier: MIT
#include "ced/cloud.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <new>
#include <ostream>
#include <type_traits>

#include "ced/channels.hpp"
#include "core/text.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace ced {

std::size_t size_of(scalar_type t) noexcept {
  switch (t) {
    case scalar_type::int8:
    case scalar_type::uint8:
      return 1;
    case scalar_type::int16:
    case scalar_type::uint16:
      return 2;
    case scalar_type::int32:
    case scalar_type::uint32:
    case scalar_type::float32:
      return 4;
    case scalar_type::int64:
    case scalar_type::uint64:
    case scalar_type::float64:
      return 8;
  }
  return 0;
}

std::string_view name_of(scalar_type t) noexcept {
  switch (t) {
    case scalar_type::int8:
      return "int8";
    case scalar_type::uint8:
      return "uint8";
    case scalar_type::int16:
      return "int16";
    case scalar_type::uint16:
      return "uint16";
    case scalar_type::int32:
      return "int32";
    case scalar_type::uint32:
      return "uint32";
    case scalar_type::int64:
      return "int64";
    case scalar_type::uint64:
      return "uint64";
    case scalar_type::float32:
      return "float32";
    case scalar_type::float64:
      return "float64";
  }
  return "?";
}

bool is_integer(scalar_type t) noexcept { return t != scalar_type::float32 && t != scalar_type::float64; }

std::array<double, 2> natural_range(scalar_type t) noexcept {
  switch (t) {
    case scalar_type::int8:
      return {-128.0, 127.0};
    case scalar_type::uint8:
      return {0.0, 255.0};
    case scalar_type::int16:
      return {-32768.0, 32767.0};
    case scalar_type::uint16:
      return {0.0, 65535.0};
    case scalar_type::int32:
      return {double(std::numeric_limits<std::int32_t>::min()), double(std::numeric_limits<std::int32_t>::max())};
    case scalar_type::uint32:
      return {0.0, double(std::numeric_limits<std::uint32_t>::max())};
    case scalar_type::int64:
      return {double(std::numeric_limits<std::int64_t>::min()), double(std::numeric_limits<std::int64_t>::max())};
    case scalar_type::uint64:
      return {0.0, double(std::numeric_limits<std::uint64_t>::max())};
    case scalar_type::float32:
    case scalar_type::float64:
      return {0.0, 1.0};
  }
  return {0.0, 1.0};
}

bool field_selection::wants(std::string_view name) const noexcept {
  if (all) return true;
  for (const auto& n : names)
    if (field_name_matches(n, name)) return true;
  return false;
}

void point_cloud::keep_fields(const field_selection& selection) {
  if (selection.all) return;
  m_fields.erase(
      std::remove_if(m_fields.begin(), m_fields.end(), [&](const field& f) { return !selection.wants(f.name); }),
      m_fields.end());
  m_index_stale = true;
}

const field* point_cloud::find_field(std::string_view name) const noexcept {
  for (const auto& f : m_fields)
    if (f.name == name) return &f;
  return nullptr;
}

const field* point_cloud::find_field_icase(std::string_view name) const noexcept {
  if (const field* f = find_field(name)) return f;
  for (const auto& f : m_fields)
    if (detail::iequal(f.name, name)) return &f;
  return nullptr;
}

const field& point_cloud::get_field(std::string_view name) const {
  if (const field* f = find_field(name)) return *f;
  std::string present;
  for (const auto& f : m_fields) present += (present.empty() ? "" : ", ") + f.name;
  throw std::invalid_argument("the cloud has no field '" + std::string(name) +
                              "' (fields present: " + (present.empty() ? "none" : present) + ")");
}

column::column(scalar_type type, const std::vector<double>& values) : m_type(type) {
  resize(values.size());
  visit([&](auto* p, std::size_t n) {
    using T = std::remove_cv_t<std::remove_pointer_t<decltype(p)>>;
    for (std::size_t i = 0; i < n; ++i) p[i] = convert_value<T>(values[i]);
  });
}

namespace {
constexpr std::size_t k_huge_page = std::size_t(1) << 21;
constexpr std::size_t k_large_column = std::size_t(1) << 20;
}  // namespace

void detail::advise_huge_pages(void* p, std::size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  // Whole 2 MiB pages inside the block: the hint must not reach memory that
  // the allocator keeps for other blocks.
  constexpr std::uintptr_t huge = k_huge_page;
  const auto begin = (reinterpret_cast<std::uintptr_t>(p) + huge - 1) & ~(huge - 1);
  const auto end = (reinterpret_cast<std::uintptr_t>(p) + bytes) & ~(huge - 1);
  if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
  (void)p;
  (void)bytes;
#endif
}

void* detail::allocate_huge_pages(std::size_t bytes) noexcept {
  const std::size_t size = (bytes + k_huge_page - 1) / k_huge_page * k_huge_page;
  void* p = std::aligned_alloc(k_huge_page, size);
  if (p) advise_huge_pages(p, size);
  return p;
}

void* detail::allocate_column(std::size_t bytes) {
  if (bytes < k_large_column) return ::operator new(bytes);
  // Whole huge pages: at most 1 MiB (and under half) more than asked for.
  void* p = allocate_huge_pages(bytes);
  if (!p) throw std::bad_alloc();
  return p;
}

void detail::deallocate_column(void* p, std::size_t bytes) noexcept {
  if (bytes < k_large_column)
    ::operator delete(p);
  else
    std::free(p);
}

std::vector<double> column::to_doubles() const {
  std::vector<double> out(m_size);
  visit([&](const auto* p, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<double>(p[i]);
  });
  return out;
}

std::ostream& operator<<(std::ostream& out, const column& c) {
  out << name_of(c.type()) << "{";
  for (std::size_t i = 0; i < c.size(); ++i) out << (i ? ", " : "") << c[i];
  return out << "}";
}

field& point_cloud::add_field(std::string name, scalar_type type, const std::vector<double>& values) {
  return add_field(std::move(name), column(type, values));  // which checks the size
}

field& point_cloud::add_field(std::string name, column values) {
  if (values.size() != size())
    throw std::invalid_argument("field '" + name + "' has " + std::to_string(values.size()) + " values for " +
                                std::to_string(size()) + " points");
  if (m_index_stale || m_index.size() != m_fields.size()) {
    m_index.clear();
    for (std::size_t k = 0; k < m_fields.size(); ++k) m_index.emplace(m_fields[k].name, k);
    m_index_stale = false;
  }
  const auto it = m_index.find(name);
  if (it != m_index.end() && it->second < m_fields.size() && m_fields[it->second].name == name) {
    m_fields[it->second].values = std::move(values);
    return m_fields[it->second];
  }
  m_fields.emplace_back(std::move(name), std::move(values));
  m_index.emplace(m_fields.back().name, m_fields.size() - 1);
  return m_fields.back();
}

void point_cloud::add_rgb(const std::vector<std::array<std::uint8_t, 3>>& rgb) {
  const auto& names = rgb_field_names();
  for (int c = 0; c < 3; ++c) {
    column v(scalar_type::uint8, rgb.size());
    std::uint8_t* p = v.data<std::uint8_t>();
    for (std::size_t i = 0; i < rgb.size(); ++i) p[i] = rgb[i][static_cast<std::size_t>(c)];
    add_field(names[c], std::move(v));
  }
}

namespace {
thread_local const std::array<double, 3>* forced_origin = nullptr;
}

namespace detail {
scoped_origin::scoped_origin(const std::array<double, 3>& origin) noexcept : m_before(forced_origin), m_origin(origin) {
  forced_origin = &m_origin;
}
scoped_origin::~scoped_origin() { forced_origin = m_before; }
}  // namespace detail

std::array<double, 3> choose_origin(const double lo[3], const double hi[3]) noexcept {
  if (forced_origin) return *forced_origin;
  std::array<double, 3> o{0.0, 0.0, 0.0};
  for (std::size_t k = 0; k < 3; ++k) {
    const double c = 0.5 * lo[k] + 0.5 * hi[k];
    if (std::fabs(c) > 1e4 && std::fabs(c) > hi[k] - lo[k]) o[k] = std::round(c);
  }
  return o;
}

std::array<double, 3> choose_origin(const double* x, const double* y, const double* z, std::size_t n) noexcept {
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  bool any = false;
  const double* a[3] = {x, y, z};
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i]) || !std::isfinite(z[i])) continue;
    for (int k = 0; k < 3; ++k) {
      lo[k] = any ? std::min(lo[k], a[k][i]) : a[k][i];
      hi[k] = any ? std::max(hi[k], a[k][i]) : a[k][i];
    }
    any = true;
  }
  return choose_origin(lo, hi);
}

const std::vector<std::string>& rgb_field_names() {
  static const std::vector<std::string> names = {"red", "green", "blue", "r", "g", "b"};
  return names;
}

std::array<const field*, 3> find_rgb_fields(const point_cloud& cloud) noexcept {
  const auto& names = rgb_field_names();
  for (std::size_t first : {0, 3}) {  // red/green/blue, then r/g/b
    const std::array<const field*, 3> f{cloud.find_field_icase(names[first]), cloud.find_field_icase(names[first + 1]),
                                        cloud.find_field_icase(names[first + 2])};
    if (f[0] && f[1] && f[2]) return f;
  }
  return {nullptr, nullptr, nullptr};
}

bool point_cloud::has_rgb() const noexcept { return find_rgb_fields(*this)[0] != nullptr; }

void point_cloud::filter(const std::vector<std::uint8_t>& keep) {
  if (keep.size() != size()) throw std::invalid_argument("filter mask size differs from the cloud size");
  std::size_t out = 0;
  for (std::size_t i = 0; i < keep.size(); ++i) {
    if (!keep[i]) continue;
    if (out != i) {
      for (int k = 0; k < 3; ++k)
        m_xyz[3 * out + static_cast<std::size_t>(k)] = m_xyz[3 * i + static_cast<std::size_t>(k)];
      for (auto& f : m_fields) {
        const std::size_t w = size_of(f.type());
        std::copy_n(f.values.bytes() + w * i, w, f.values.bytes() + w * out);
      }
    }
    ++out;
  }
  m_xyz.resize(3 * out);
  for (auto& f : m_fields) f.values.resize(out);
}

}  // namespace ced
