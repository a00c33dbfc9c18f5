// SPDX-License-Identifier: MIT
// Points of fixed-size records (records.hpp): the binary PLY and PCD readers,
// whole-file and streaming.
#include "io/base/records.hpp"

#include <cmath>
#include <cstring>
#include <stdexcept>
#include <type_traits>

#include "io/base/scalar_io.hpp"

namespace ced::io::detail {

namespace {

/// The m values of type T at p (`stride` bytes apart, bytes reversed when
/// Swap) into out as T: the values a conversion through double gives, as the
/// readers have always made fields (NaNs quieted, 64-bit integers rounded).
template <class T, bool Swap>
void decode_as(const unsigned char* p, std::size_t stride, std::size_t m, unsigned char* out) noexcept {
  T* o = reinterpret_cast<T*>(out);  // a column's bytes: aligned for any type
  for (std::size_t i = 0; i < m; ++i) {
    const T v = load<T, Swap>(p + i * stride);
    if constexpr (std::is_integral_v<T> && sizeof(T) <= 4)
      o[i] = v;  // exact through double
    else if constexpr (std::is_same_v<T, float>)
      o[i] = through_double(v);
    else
      o[i] = convert<T>(static_cast<double>(v));
  }
}

/// Where the values of `v` of a chunk of records are: the first one, and
/// the bytes from one to the next.
struct value_run {
  const unsigned char* p;
  std::size_t stride;
};

/// The values of `v` of the records from i0 on, at r (`stride` bytes apart).
value_run run_of(const point_layout& layout, const value_spec& v, const unsigned char* r, std::size_t stride,
                 std::uint64_t i0) noexcept {
  if (v.stride == 0) return {r + v.offset, stride};
  return {layout.base + v.offset + i0 * v.stride, v.stride};
}

/// The m values of `v` at `at` into out (v.stored()).
void decode_values(const value_spec& v, value_run at, std::size_t m, unsigned char* out) noexcept {
  const unsigned char* p = at.p;
  const std::size_t stride = at.stride;
  if (v.shift >= 0) {
    for (std::size_t i = 0; i < m; ++i) {
      const auto bits = v.swap ? load<std::uint32_t, true>(p + i * stride) : load<std::uint32_t, false>(p + i * stride);
      out[i] = static_cast<unsigned char>((bits >> v.shift) & 0xff);
    }
    return;
  }
  visit_type(v.type, [&](auto tag) {
    using T = decltype(tag);
    if (v.swap)
      decode_as<T, true>(p, stride, m, out);
    else
      decode_as<T, false>(p, stride, m, out);
  });
}

/// A chunk of records: m of them from i0 on, at r (`stride` bytes apart).
struct chunk_at {
  const unsigned char* r;
  std::size_t stride;
  std::uint64_t i0;
  std::size_t m;
};

/// The x, y and z of the records of chunk `c`, as doubles: axes[k * m + i],
/// in a buffer of this thread's (valid until its next call).
const double* decode_axes(const point_layout& layout, const chunk_at& c) {
  thread_local std::vector<double> axes;  // one per thread: its pages are faulted in once
  axes.resize(3 * c.m);
  for (std::size_t k = 0; k < 3; ++k) {
    const value_spec& a = layout.xyz[k];
    const value_run at = run_of(layout, a, c.r, c.stride, c.i0);
    decode_column(at.p, at.stride, c.m, a.type, a.swap, axes.data() + k * c.m);
  }
  return axes.data();
}

bool finite_point(const double* axes, std::size_t m, std::size_t i) noexcept {
  return std::isfinite(axes[i]) && std::isfinite(axes[m + i]) && std::isfinite(axes[2 * m + i]);
}

/// Where decode_points() writes: the positions and each column's bytes.
struct point_sink {
  float* xyz;
  std::vector<unsigned char*> columns;
};

/// Decodes the records of chunk c into the points from `o` on, all of them.
void decode_chunk(const point_layout& layout, const chunk_at& c, const double* axes,
                  const std::array<double, 3>& origin, const point_sink& sink, std::size_t o) {
  const std::size_t m = c.m;
  float* p = sink.xyz + 3 * o;
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t k = 0; k < 3; ++k) p[3 * i + k] = static_cast<float>(axes[k * m + i] - origin[k]);
  for (std::size_t j = 0; j < layout.columns.size(); ++j) {
    const value_spec& v = layout.columns[j];
    decode_values(v, run_of(layout, v, c.r, c.stride, c.i0), m, sink.columns[j] + o * size_of(v.stored()));
  }
}

/// The same, only the points with finite positions.
void decode_finite_chunk(const point_layout& layout, const chunk_at& c, const double* axes,
                         const std::array<double, 3>& origin, const point_sink& sink, std::size_t o) {
  const std::size_t m = c.m;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < m; ++i) {
    if (!finite_point(axes, m, i)) continue;
    for (std::size_t k = 0; k < 3; ++k) sink.xyz[3 * (o + kept) + k] = static_cast<float>(axes[k * m + i] - origin[k]);
    ++kept;
  }
  thread_local std::vector<double> values;  // 8 bytes a value: room and alignment for any type
  values.resize(m);
  auto* tmp = reinterpret_cast<unsigned char*>(values.data());
  for (std::size_t j = 0; j < layout.columns.size(); ++j) {
    const value_spec& v = layout.columns[j];
    const std::size_t w = size_of(v.stored());
    decode_values(v, run_of(layout, v, c.r, c.stride, c.i0), m, tmp);
    unsigned char* out = sink.columns[j] + o * w;
    for (std::size_t i = 0; i < m; ++i) {
      if (!finite_point(axes, m, i)) continue;
      std::memcpy(out, tmp + i * w, w);
      out += w;
    }
  }
}

}  // namespace

points_scan scan_points(const record_source& src, std::uint64_t n, const point_layout& layout) {
  const std::size_t chunks = chunk_count(n, src.stride());
  std::vector<finite_box> boxes(chunks);
  points_scan scan;
  scan.finite.assign(chunks, 0);
  for_each_chunk(src, n, [&](std::size_t c, std::uint64_t i0, std::size_t m, const unsigned char* r) {
    const double* a = decode_axes(layout, {r, src.stride(), i0, m});
    for (std::size_t i = 0; i < m; ++i) boxes[c].add(a[i], a[m + i], a[2 * m + i]);
    std::size_t finite = 0;
    for (std::size_t i = 0; i < m; ++i) finite += finite_point(a, m, i);
    scan.finite[c] = finite;
  });
  for (std::size_t c = 0; c < chunks; ++c) {
    scan.box.merge(boxes[c]);
    scan.total_finite += scan.finite[c];
  }
  return scan;
}

point_cloud decode_points(const record_source& src, std::uint64_t n, const point_layout& layout,
                          const std::array<double, 3>& origin, const points_scan* finite_only) {
  const auto total = static_cast<std::size_t>(finite_only ? finite_only->total_finite : n);
  point_cloud cloud;
  cloud.set_origin(origin);
  cloud.resize(total);
  std::vector<column> cols;
  cols.reserve(layout.columns.size());  // the sink keeps pointers to their bytes
  point_sink sink{cloud.positions().data(), {}};
  for (const value_spec& v : layout.columns) sink.columns.push_back(cols.emplace_back(v.stored(), total).bytes());
  std::vector<std::size_t> start;  // with finite_only: each chunk's first point
  if (finite_only)
    for (std::size_t c = 0, o = 0; c < finite_only->finite.size(); o += finite_only->finite[c++]) start.push_back(o);
  for_each_chunk(src, n, [&](std::size_t c, std::uint64_t i0, std::size_t m, const unsigned char* r) {
    const chunk_at chunk{r, src.stride(), i0, m};
    const double* axes = decode_axes(layout, chunk);
    if (!finite_only)
      decode_chunk(layout, chunk, axes, origin, sink, static_cast<std::size_t>(i0));
    else if (finite_only->finite[c] == m)
      decode_chunk(layout, chunk, axes, origin, sink, start[c]);
    else
      decode_finite_chunk(layout, chunk, axes, origin, sink, start[c]);
  });
  for (std::size_t j = 0; j < layout.columns.size(); ++j) cloud.add_field(layout.columns[j].name, std::move(cols[j]));
  return cloud;
}

void check_point_indices(const std::vector<std::uint64_t>& at, std::uint64_t count) {
  for (std::size_t j = 0; j < at.size(); ++j)
    if (at[j] >= count || (j > 0 && at[j] <= at[j - 1]))
      throw std::logic_error("point_stream::read_points: indices not ascending within the file's points");
}

std::string gather_records(const input_file& file, std::uint64_t offset, std::size_t stride,
                           const std::vector<std::uint64_t>& at) {
  const std::uint64_t gap = std::max<std::uint64_t>(1, 4096 / stride),
                      most = std::max<std::uint64_t>(1, (1u << 20) / stride);
  std::string out(at.size() * stride, '\0'), window;
  for (std::size_t j = 0; j < at.size();) {
    std::size_t e = j + 1;
    while (e < at.size() && at[e] - at[e - 1] <= gap && at[e] - at[j] < most) ++e;
    const std::uint64_t first = at[j], span = at[e - 1] - first + 1;
    window.resize(static_cast<std::size_t>(span * stride));
    file.read_at(offset + first * stride, window.size(), window.data());
    for (; j < e; ++j)
      std::memcpy(&out[j * stride], &window[static_cast<std::size_t>((at[j] - first) * stride)], stride);
  }
  return out;
}

}  // namespace ced::io::detail
