// SPDX-License-Identifier: MIT
// Clouds read in chunks (ced/io/stream.hpp): LAS, PLY binary, PCD binary and
// CSV stream; PLY ascii, PCD ascii and binary_compressed (and anything that
// is not a regular file) are read whole and served in chunks.
#include "ced/io/stream.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <utility>

#include "ced/io/catalogue.hpp"
#include "io/base/formats.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"

namespace ced::io {

namespace detail {

input_file::input_file(const std::string& path) : m_path(path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw io_error("cannot read '" + path + "': it is a directory");
  m_file.reset(std::fopen(path.c_str(), "rb"));
  if (!m_file) throw io_error("cannot open '" + path + "': " + std::strerror(errno));
  m_size = std::filesystem::file_size(path, ec);
  if (ec) throw io_error(path, "cannot read its size: " + ec.message());
}

void input_file::read_exact(std::uint64_t offset, std::size_t n, char* out) {
  if (n == 0) return;
  if (offset > m_size || n > m_size - offset || fseeko(m_file.get(), static_cast<off_t>(offset), SEEK_SET) != 0 ||
      std::fread(out, 1, n, m_file.get()) != n)
    fail_read(offset, n);
}

void input_file::read_at(std::uint64_t offset, std::size_t n, char* out) const {
  if (offset > m_size || n > m_size - offset) fail_read(offset, n);
  const int fd = fileno(m_file.get());
  for (std::size_t done = 0; done < n;) {
    const ssize_t got = pread(fd, out + done, n - done, static_cast<off_t>(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) fail_read(offset, n);
    done += static_cast<std::size_t>(got);
  }
}

void input_file::fail_read(std::uint64_t offset, std::size_t n) const {
  throw io_error(m_path, "cannot read " + std::to_string(n) + " bytes at byte " + std::to_string(offset) +
                             " (the file is unreadable or was truncated while being read)");
}

void input_file::read_some(std::uint64_t offset, std::size_t n, std::string& buf) {
  const std::uint64_t left = offset < m_size ? m_size - offset : 0;
  buf.resize(static_cast<std::size_t>(std::min<std::uint64_t>(n, left)));
  read_exact(offset, buf.size(), buf.data());
}

bool input_file::contains(std::string_view s, std::uint64_t from) {
  constexpr std::size_t block = std::size_t(1) << 20;
  std::string buf;
  for (std::uint64_t at = from; at < m_size; at += block) {
    read_some(at, block + s.size(), buf);  // blocks overlap by s.size() bytes
    if (buf.find(s) != std::string::npos) return true;
  }
  return false;
}

std::size_t sequential_reader::fill(std::size_t n) {
  const auto want = static_cast<std::size_t>(std::min<std::uint64_t>(n, left()));
  if (available() >= want) return want;
  m_buf.erase(0, m_begin);
  m_begin = 0;
  const std::size_t have = m_buf.size();
  const auto more = static_cast<std::size_t>(
      std::max<std::uint64_t>(want - have, std::min<std::uint64_t>(std::size_t(1) << 16, left() - have)));
  m_buf.resize(have + more);
  m_file->read_exact(m_offset + have, more, m_buf.data() + have);
  return want;
}

void sequential_reader::skip(std::uint64_t n) noexcept {
  if (n <= available()) {
    m_begin += static_cast<std::size_t>(n);
  } else {
    m_buf.clear();
    m_begin = 0;
  }
  m_offset += n;
}

void sequential_reader::seek(std::uint64_t offset) noexcept {
  m_buf.clear();
  m_begin = 0;
  m_offset = offset;
}

bool sequential_reader::next_line(std::string_view& line) {
  if (left() == 0) return false;
  for (std::size_t scanned = 0;;) {
    const char* d = data();
    const std::size_t a = available();
    if (const void* nl = std::memchr(d + scanned, '\n', a - scanned)) {
      const auto len = static_cast<std::size_t>(static_cast<const char*>(nl) - d);
      line = std::string_view(d, len);
      skip(len + 1);
      return true;
    }
    if (a == left()) {  // the last line, without a '\n'
      line = std::string_view(d, a);
      skip(a);
      return true;
    }
    scanned = a;
    fill(std::max<std::size_t>(2 * a, std::size_t(1) << 16));
  }
}

void box_stream::set_positions(point_cloud& out, const double* x, const double* y, const double* z, std::size_t n,
                               const std::array<double, 3>& origin) {
  out = point_cloud();
  out.set_origin(origin);
  out.resize(n);
  float* p = out.positions().data();
  for (std::size_t i = 0; i < n; ++i) {
    if (!m_first_pass_done) m_box.add(x[i], y[i], z[i]);
    p[3 * i + 0] = static_cast<float>(x[i] - origin[0]);
    p[3 * i + 1] = static_cast<float>(y[i] - origin[1]);
    p[3 * i + 2] = static_cast<float>(z[i] - origin[2]);
  }
}

}  // namespace detail

namespace {
class whole_file_stream final : public point_stream {
 public:
  // Every point of the file, non-finite ones included, as the streaming
  // readers give them: the counts of a plan and of its tiles are the file's
  // (an ASCII PCD read without them failed every tile of its plan).
  whole_file_stream(const std::string& path, read_options options) {
    options.keep_nonfinite = true;
    read_report report;
    m_cloud = read_cloud(path, options, &report);
    m_details = report.details;
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
  std::size_t m_next = 0;
};
}  // namespace

std::vector<point_stream::index_node> point_stream::nodes_within(const std::vector<index_node>& nodes,
                                                                 const double lo[3], const double hi[3]) {
  // Points on a cube's faces may belong to either side: closed boxes, a
  // margin of a millionth of the largest node's edge.
  const double margin = index_margin(nodes);
  std::vector<index_node> out;
  for (const index_node& n : nodes) {
    bool meets = true;
    for (int k = 0; k < 3; ++k) meets = meets && n.box[k] - margin <= hi[k] && n.box[3 + k] + margin >= lo[k];
    if (meets) out.push_back(n);
  }
  std::sort(out.begin(), out.end(), [](const index_node& a, const index_node& b) { return a.run.first < b.run.first; });
  return out;
}

double point_stream::index_margin(const std::vector<index_node>& nodes) noexcept {
  double margin = 0;
  for (const index_node& n : nodes) margin = std::max(margin, 1e-6 * (n.box[3] - n.box[0]));
  return margin;
}

std::vector<point_stream::point_run> point_stream::fixed_runs(std::uint64_t n) {
  std::vector<point_run> out;
  for (std::uint64_t first = 0; first < n; first += fixed_run_points)
    out.push_back({first, std::min<std::uint64_t>(fixed_run_points, n - first)});
  return out;
}

void point_stream::check_run(const point_run& r, std::uint64_t n, bool runs) {
  if (!runs) throw std::logic_error("point_stream::read_run: this stream reads no runs");
  if (r.first > n || r.count > n - r.first)
    throw std::logic_error("point_stream::read_run: a run past the file's points");
}

std::optional<std::vector<point_stream::point_run>> point_stream::runs_within(const double lo[3], const double hi[3]) {
  const auto nodes = index_nodes();
  if (!nodes) return std::nullopt;
  // Neighbouring runs join: one read each.
  std::vector<point_run> joined;
  for (const index_node& n : nodes_within(*nodes, lo, hi)) {
    const point_run& r = n.run;
    if (!joined.empty() && joined.back().first + joined.back().count == r.first)
      joined.back().count += r.count;
    else if (joined.empty() || joined.back().first != r.first)
      joined.push_back(r);
  }
  return joined;
}

std::unique_ptr<point_stream> open_point_stream(const std::string& path, const read_options& options) {
  if (names_catalogue(path)) return open_catalogue_stream(catalogue_files({path}), options);
  const file_format f = options.format == file_format::automatic ? format_of(path) : options.format;
  const detail::format_entry& format = detail::format_entry_of(f);
  if (format.streams_any_file) return format.stream(path, options);
  read_options o = options;
  o.format = f;
  std::error_code ec;
  if (format.stream && std::filesystem::is_regular_file(path, ec)) {  // else read whole, with read_cloud()'s errors
    if (auto s = format.stream(path, options)) return s;
  }
  return std::make_unique<whole_file_stream>(path, o);
}

}  // namespace ced::io
