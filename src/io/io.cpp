// SPDX-License-Identifier: MIT
#include "ced/io/io.hpp"

#include <stdexcept>

#include "ced/io/catalogue.hpp"
#include "core/parallel.hpp"
#include "core/text.hpp"
#include "io/base/formats.hpp"
#include "io/base/scalar_io.hpp"

namespace ced::io {

namespace {
using detail::format_entry;
using detail::formats;

/// The entry whose name or other name is `name`, or nullptr.
const format_entry* named(const std::string& name) {
  for (const format_entry& e : formats()) {
    if (e.name == name) return &e;
    for (const std::string& a : e.aliases)
      if (a == name) return &e;
  }
  return nullptr;
}

/// The formats' names joined by `sep` (for messages).
std::string joined_names(const char* sep) {
  std::string out;
  for (const format_entry& e : formats()) out += (out.empty() ? "" : sep) + e.name;
  return out;
}

/// The single extensions a format takes, as format_of()'s refusal lists
/// them: ".ply, .pcd, .las, .laz, .csv/.xyz/.txt/.pts".
std::string listed_extensions() {
  std::string listed;
  for (const format_entry& e : formats()) {
    std::string mine;
    for (const std::string& x : e.extensions)
      if (x.find('.') == std::string::npos) mine += (mine.empty() ? "." : "/.") + x;
    if (!mine.empty()) listed += (listed.empty() ? "" : ", ") + mine;
  }
  return listed;
}
}  // namespace

file_format parse_format(const std::string& name) {
  if (name == "auto") return file_format::automatic;
  if (const format_entry* e = named(name)) return e->id;
  throw std::invalid_argument("unknown format '" + name + "' (known: " + joined_names(", ") + ", auto)");
}

std::string format_name(file_format f) {
  if (f == file_format::automatic) return "auto";
  for (const format_entry& e : formats())
    if (e.id == f) return e.name;
  return "?";
}

file_format format_of(const std::string& path) {
  const auto slash = path.find_last_of("/\\");
  const auto dot = path.find_last_of('.');
  const std::string ext = ced::detail::to_lower(
      dot == std::string::npos || (slash != std::string::npos && dot < slash) ? "" : path.substr(dot + 1));
  if (ext == "e57")
    throw io_error(path + ": E57 is not supported; convert it first, e.g. `pdal translate " + path +
                   " out.las` or with CloudCompare to PLY");
  if (ext.empty()) throw io_error(path + ": no file extension; say the format with --format " + joined_names("|"));
  // The longest extension that ends the path (.copc.laz before .laz).
  const std::string lower = ced::detail::to_lower(path);
  const format_entry* best = nullptr;
  std::size_t best_size = 0;
  for (const format_entry& e : formats())
    for (const std::string& x : e.extensions)
      if (x.size() + 1 > best_size && lower.size() > x.size() && lower[lower.size() - x.size() - 1] == '.' &&
          lower.compare(lower.size() - x.size(), x.size(), x) == 0) {
        best = &e;
        best_size = x.size() + 1;
      }
  if (best) return best->id;
  if (const format_entry* e = named(ext)) return e->id;
  throw io_error(path + ": unsupported file type '." + ext + "' (ced reads " + listed_extensions() + ")");
}

namespace {
point_cloud read_cloud_here(const std::string& path, const read_options& options, read_report* report) {
  const file_format f = options.format == file_format::automatic ? format_of(path) : options.format;
  read_report r;
  r.format = f;
  point_cloud c = detail::format_entry_of(f).read(path, options, r);
  c.keep_fields(options.fields);
  if (report) *report = r;
  return c;
}
}  // namespace

point_cloud read_cloud(const std::string& path, const read_options& options, read_report* report) {
  if (names_catalogue(path)) {  // a folder or @LIST: its files as one cloud
    catalogue_report files;
    point_cloud c = read_catalogue(catalogue_files({path}), options, &files);
    if (report) *report = files.summary();
    return c;
  }
  point_cloud c;
  ced::detail::with_thread_limit(options.threads, [&] {
    if (!options.origin) {
      c = read_cloud_here(path, options, report);
      return;
    }
    // On the thread that reads (the readers choose the origin there).
    const ced::detail::scoped_origin forced(*options.origin);
    c = read_cloud_here(path, options, report);
  });
  return c;
}

void write_cloud(std::ostream& out, const point_cloud& cloud, file_format format, const las_write_options& las) {
  if (format == file_format::automatic) throw std::invalid_argument("write_cloud: no format given");
  detail::format_entry_of(format).write(out, cloud, &las);
}

void write_cloud(std::ostream& out, const point_cloud& cloud, file_format format) {
  if (format == file_format::automatic) throw std::invalid_argument("write_cloud: no format given");
  detail::format_entry_of(format).write(out, cloud, nullptr);
}

void write_cloud(const std::string& path, const point_cloud& cloud, file_format format) {
  const file_format f = format == file_format::automatic ? format_of(path) : format;
  atomic_output_file out(path);
  try {
    write_cloud(out.stream(), cloud, f);
  } catch (const io_error& e) {
    throw io_error(path + ": " + e.what());
  }
  out.commit();
}

cloud_writer::cloud_writer(std::ostream& out, const point_cloud& layout, std::uint64_t points, file_format format)
    : m_out(out), m_layout(layout), m_points(points) {
  if (m_layout.size() > 0) m_layout.filter(std::vector<std::uint8_t>(m_layout.size(), 0));
  m_start = out.tellp();
  if (format == file_format::automatic) throw std::invalid_argument("cloud_writer: no format given");
  const detail::format_entry& entry = detail::format_entry_of(format);
  if (entry.pieces_seek_back && m_start == std::streampos(-1))
    throw std::invalid_argument("cloud_writer: " + ced::detail::to_upper(entry.name) +
                                " in pieces needs a seekable output (a file)");
  m_pieces = entry.pieces(out, m_layout, points);
}

cloud_writer::~cloud_writer() = default;

void cloud_writer::write(const point_cloud& chunk) {
  const auto& a = chunk.fields();
  const auto& b = m_layout.fields();
  bool same = a.size() == b.size() && chunk.origin() == m_layout.origin();
  for (std::size_t f = 0; same && f < a.size(); ++f) same = a[f].name == b[f].name && a[f].type() == b[f].type();
  if (!same) throw std::invalid_argument("cloud_writer: a chunk's fields or origin differ from the layout's");
  if (chunk.size() > m_points - m_written)
    throw std::invalid_argument("cloud_writer: more points than the " + std::to_string(m_points) + " announced");
  m_pieces->write(m_out, chunk);
  m_written += chunk.size();
  if (!m_out) throw io_error("error writing point data to the output stream");
}

void cloud_writer::finish() {
  if (m_written != m_points)
    throw io_error("cloud_writer: " + std::to_string(m_written) + " points written of the " + std::to_string(m_points) +
                   " announced");
  m_pieces->finish(m_out);
  const std::string header = m_pieces->final_header();
  if (!header.empty()) {
    const std::streampos end = m_out.tellp();
    m_out.seekp(m_start);
    m_out.write(header.data(), static_cast<std::streamsize>(header.size()));
    m_out.seekp(end);
  }
  m_out.flush();
  if (!m_out) throw io_error("error writing point data to the output stream");
}

}  // namespace ced::io
