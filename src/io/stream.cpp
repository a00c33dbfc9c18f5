// SPDX-License-Identifier: MIT
// Clouds read in chunks (ced/io/stream.hpp): LAS streams; the other formats
// are read whole and served in chunks until they have streaming readers.
#include "ced/io/stream.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace ced::io {

namespace {
class whole_file_stream final : public point_stream {
 public:
  whole_file_stream(const std::string& path, const read_options& options) {
    read_report report;
    m_cloud = read_cloud(path, options, &report);
    m_details = report.details;
    m_dropped = report.nonfinite_removed;
  }
  std::size_t read(std::size_t max, const std::array<double, 3>& origin, point_cloud& out) override {
    const std::size_t n = std::min(max, m_cloud.size() - m_next);
    out = point_cloud();
    out.set_origin(origin);
    out.resize(n);
    const std::array<double, 3>& o = m_cloud.origin();
    const bool same = o == origin;
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t k = 0; k < 3; ++k) {
        const float v = m_cloud.position(m_next + i)[k];
        out.positions()[3 * i + k] = same ? v : static_cast<float>(double(v) + (o[k] - origin[k]));
      }
    for (const field& f : m_cloud.fields()) {
      const std::size_t w = size_of(f.type());
      column c(f.type(), n);
      std::copy_n(f.values.bytes() + w * m_next, w * n, c.bytes());
      out.add_field(f.name, std::move(c));
    }
    m_next += n;
    return n;
  }
  void rewind() override { m_next = 0; }
  std::array<double, 3> origin() const override { return m_cloud.origin(); }
  void bounds(double lo[3], double hi[3]) const override {
    bool any = false;
    for (std::size_t i = 0; i < m_cloud.size(); ++i) {
      const float* p = m_cloud.position(i);
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
      for (std::size_t k = 0; k < 3; ++k) {
        const double v = double(p[k]) + m_cloud.origin()[k];
        lo[k] = any ? std::min(lo[k], v) : v;
        hi[k] = any ? std::max(hi[k], v) : v;
      }
      any = true;
    }
    if (!any)
      for (std::size_t k = 0; k < 3; ++k) lo[k] = hi[k] = 0;
  }
  std::string details() const override { return m_details; }
  bool streaming() const noexcept override { return false; }

 private:
  point_cloud m_cloud;
  std::string m_details;
  std::size_t m_next = 0, m_dropped = 0;
};
}  // namespace

std::unique_ptr<point_stream> open_point_stream(const std::string& path, const read_options& options) {
  const file_format f = options.format == file_format::automatic ? format_of(path) : options.format;
  if (f == file_format::las) return open_las_stream(path, options.fields);
  read_options o = options;
  o.format = f;
  return std::make_unique<whole_file_stream>(path, o);
}

}  // namespace ced::io
