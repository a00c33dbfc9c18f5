// SPDX-License-Identifier: MIT
#include "ced/io/io.hpp"

#include <stdexcept>

#include "core/parallel.hpp"
#include "core/text.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"

namespace ced::io {

file_format parse_format(const std::string& name) {
  if (name == "auto") return file_format::automatic;
  if (name == "ply") return file_format::ply;
  if (name == "pcd") return file_format::pcd;
  if (name == "las") return file_format::las;
  if (name == "laz") return file_format::laz;
  if (name == "copc") return file_format::copc;
  if (name == "csv" || name == "xyz" || name == "txt" || name == "pts") return file_format::csv;
  throw std::invalid_argument("unknown format '" + name + "' (known: ply, pcd, las, laz, copc, csv, auto)");
}

std::string format_name(file_format f) {
  switch (f) {
    case file_format::automatic:
      return "auto";
    case file_format::ply:
      return "ply";
    case file_format::pcd:
      return "pcd";
    case file_format::las:
      return "las";
    case file_format::csv:
      return "csv";
    case file_format::laz:
      return "laz";
    case file_format::copc:
      return "copc";
  }
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
  if (ext.empty()) throw io_error(path + ": no file extension; say the format with --format ply|pcd|las|csv");
  const std::string lower = ced::detail::to_lower(path);
  if (lower.size() >= 9 && lower.compare(lower.size() - 9, 9, ".copc.laz") == 0) return file_format::copc;
  try {
    return parse_format(ext);
  } catch (const std::invalid_argument&) {
    throw io_error(path + ": unsupported file type '." + ext +
                   "' (ced reads .ply, .pcd, .las, .laz, .csv/.xyz/.txt/.pts)");
  }
}

namespace {
point_cloud read_cloud_here(const std::string& path, const read_options& options, read_report* report) {
  const file_format f = options.format == file_format::automatic ? format_of(path) : options.format;
  read_report r;
  r.format = f;
  point_cloud c;
  switch (f) {
    case file_format::ply: {
      c = detail::read_ply_file(path, options.fields);
      r.details = "PLY";
      break;
    }
    case file_format::pcd: {
      pcd_read_info info;
      c = detail::read_pcd_file(path, &info, options.keep_nonfinite, options.fields);
      r.nonfinite_removed = info.nonfinite_removed;
      r.details = detail::pcd_details(info);
      break;
    }
    case file_format::las:
    case file_format::laz:
    case file_format::copc: {
      las_read_info info;
      c = read_las(path, &info, options.fields);
      r.details = detail::las_details(info);
      r.las = info;
      break;
    }
    case file_format::csv: {
      c = read_csv(path, options.csv);
      r.details = "CSV";
      break;
    }
    case file_format::automatic:
      break;
  }
  c.keep_fields(options.fields);
  if (report) *report = r;
  return c;
}
}  // namespace

point_cloud read_cloud(const std::string& path, const read_options& options, read_report* report) {
  point_cloud c;
  ced::detail::with_thread_limit(options.threads, [&] { c = read_cloud_here(path, options, report); });
  return c;
}

void write_cloud(std::ostream& out, const point_cloud& cloud, file_format format, const las_write_options& las) {
  switch (format) {
    case file_format::las:
      write_las(out, cloud, las);
      return;
    case file_format::laz:
      detail::write_laz(out, cloud, &las);
      return;
    case file_format::copc:
      detail::write_copc(out, cloud, &las);
      return;
    default:
      write_cloud(out, cloud, format);
  }
}

void write_cloud(std::ostream& out, const point_cloud& cloud, file_format format) {
  switch (format) {
    case file_format::ply:
      write_ply(out, cloud, ply_format::binary_little_endian);
      return;
    case file_format::pcd:
      write_pcd(out, cloud, pcd_format::binary);
      return;
    case file_format::las:
      write_las(out, cloud);
      return;
    case file_format::laz:
      detail::write_laz(out, cloud);
      return;
    case file_format::copc:
      detail::write_copc(out, cloud);
      return;
    case file_format::csv:
      write_csv(out, cloud);
      return;
    case file_format::automatic:
      break;
  }
  throw std::invalid_argument("write_cloud: no format given");
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
  switch (format) {
    case file_format::ply:
      m_pieces = detail::ply_pieces(out, m_layout, points);
      break;
    case file_format::pcd:
      m_pieces = detail::pcd_pieces(out, m_layout, points);
      break;
    case file_format::las:
      if (m_start == std::streampos(-1))
        throw std::invalid_argument("cloud_writer: LAS in pieces needs a seekable output (a file)");
      m_pieces = detail::las_pieces(out, m_layout, points);
      break;
    case file_format::laz:
      if (m_start == std::streampos(-1))
        throw std::invalid_argument("cloud_writer: LAZ in pieces needs a seekable output (a file)");
      m_pieces = detail::laz_pieces(out, m_layout, points);
      break;
    case file_format::copc:
      m_pieces = detail::copc_pieces(m_layout, points);
      break;
    case file_format::csv:
      m_pieces = detail::csv_pieces(out, m_layout, points);
      break;
    case file_format::automatic:
      throw std::invalid_argument("cloud_writer: no format given");
  }
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
