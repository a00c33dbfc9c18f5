// SPDX-License-Identifier: MIT
// Several point files read as one cloud (ced/io/catalogue.hpp).
#include "ced/io/catalogue.hpp"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <system_error>

#include "ced/io/las.hpp"
#include "ced/io/stream.hpp"
#include "core/hash.hpp"

namespace ced::io {

namespace fs = std::filesystem;

namespace {

bool is_point_file(const fs::path& p) {
  try {
    (void)format_of(p.string());
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

/// A folder's point files, by name.
std::vector<std::string> folder_files(const std::string& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code e2;
    if (it->is_regular_file(e2) && is_point_file(it->path())) out.push_back(it->path().string());
  }
  if (ec) throw io_error(dir, "cannot list the folder: " + ec.message());
  std::sort(out.begin(), out.end());
  if (out.empty()) throw io_error(dir, "the folder holds no point files (.las, .laz, .ply, .pcd, .csv, ...)");
  return out;
}

/// The paths a list file names, relative to its folder.
std::vector<std::string> list_files(const std::string& list) {
  std::ifstream in(list);
  if (!in) throw io_error(list, "cannot open the list");
  const fs::path base = fs::path(list).parent_path();
  std::vector<std::string> out;
  std::string line;
  for (std::size_t number = 1; std::getline(in, line); ++number) {
    const auto b = line.find_first_not_of(" \t\r");
    if (b == std::string::npos || line[b] == '#') continue;
    const auto e = line.find_last_not_of(" \t\r");
    const fs::path p = line.substr(b, e - b + 1);
    out.push_back((p.is_absolute() || base.empty() ? p : base / p).string());
  }
  if (out.empty()) throw io_error(list, "the list names no files");
  return out;
}

/// A hash of the file's size and its first and last 64 KiB: two files of
/// a delivery with the same value hold the same points.
std::pair<std::uint64_t, std::uint64_t> content_key(const std::string& path) {
  std::error_code ec;
  const std::uint64_t bytes = fs::file_size(path, ec);
  if (ec) throw io_error(path, "cannot read its size: " + ec.message());
  std::ifstream in(path, std::ios::binary);
  if (!in) throw io_error(path, "cannot open");
  std::string buf;
  std::uint64_t h = ced::detail::fnv1a_offset;
  for (const std::uint64_t at : {std::uint64_t(0), bytes > 65536 ? bytes - 65536 : 0}) {
    buf.resize(static_cast<std::size_t>(std::min<std::uint64_t>(65536, bytes)));
    in.seekg(static_cast<std::streamoff>(at));
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    if (!in) throw io_error(path, "cannot read it");
    h = ced::detail::fnv1a(buf, h);
  }
  return {bytes, h};
}

bool las_family(const std::string& path, const read_options& o) {
  const file_format f = o.format == file_format::automatic ? format_of(path) : o.format;
  return f == file_format::las || f == file_format::laz || f == file_format::copc;
}

bool is_las_flag(const std::string& name) {
  const auto& flags = las_flag_fields();
  return std::find(flags.begin(), flags.end(), name) != flags.end();
}

bool is_colour(const std::string& name) { return name == "red" || name == "green" || name == "blue" || name == "nir"; }

bool is_signed(scalar_type t) {
  return t == scalar_type::int8 || t == scalar_type::int16 || t == scalar_type::int32 || t == scalar_type::int64;
}
bool is_float(scalar_type t) { return t == scalar_type::float32 || t == scalar_type::float64; }

/// Whether every value of type `a` is a value of type `b`.
bool holds(scalar_type b, scalar_type a) {
  if (a == b) return true;
  if (b == scalar_type::float64) return a == scalar_type::float32 || (!is_float(a) && size_of(a) <= 4);
  if (b == scalar_type::float32) return !is_float(a) && size_of(a) <= 2;
  if (is_float(a)) return false;
  if (is_signed(a) && !is_signed(b)) return false;
  return size_of(b) > size_of(a);  // same signedness, or unsigned into a wider signed type
}

/// The type a field of types `a` and `b` in two files takes in the
/// catalogue; none when neither holds the other's values (or for the LAS
/// scan angle, whose units differ with its type).
std::optional<scalar_type> common_type(const std::string& name, scalar_type a, scalar_type b) {
  if (name == "scan_angle") return std::nullopt;
  if (is_colour(name) &&
      ((a == scalar_type::uint8 && b == scalar_type::uint16) || (a == scalar_type::uint16 && b == scalar_type::uint8)))
    return scalar_type::uint16;
  if (is_colour(name) && (a == scalar_type::uint8 || b == scalar_type::uint8)) return std::nullopt;
  if (holds(a, b)) return a;
  if (holds(b, a)) return b;
  return std::nullopt;
}

/// The absolute bounds of a cloud's positions; false when it has none.
bool cloud_bounds(const point_cloud& c, double lo[3], double hi[3]) {
  if (c.empty()) return false;
  const float* p = c.positions().data();
  for (int k = 0; k < 3; ++k) lo[k] = hi[k] = p[k];
  for (std::size_t i = 0; i < c.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(p[3 * i + k]));
      hi[k] = std::max(hi[k], double(p[3 * i + k]));
    }
  for (int k = 0; k < 3; ++k) {
    lo[k] += c.origin()[k];
    hi[k] += c.origin()[k];
  }
  return true;
}

}  // namespace

std::vector<std::string> catalogue_files(const std::vector<std::string>& inputs) {
  std::vector<std::string> files;
  for (const std::string& in : inputs) {
    if (!in.empty() && in[0] == '@') {
      const std::string list = in.substr(1);
      for (auto& f : list_files(list)) {
        std::error_code ec;
        if (!fs::is_regular_file(f, ec)) throw io_error(list, "names " + f + ", which is not a file");
        files.push_back(std::move(f));
      }
      continue;
    }
    std::error_code ec;
    const auto st = fs::status(in, ec);
    if (ec || !fs::exists(st)) throw io_error(in, "no such file or folder");
    if (fs::is_directory(st)) {
      for (auto& f : folder_files(in)) files.push_back(std::move(f));
    } else {
      files.push_back(in);
    }
  }
  // The same file twice, by its name or its bytes, would count its points twice.
  std::map<std::string, std::string> by_path;
  std::map<std::pair<std::uint64_t, std::uint64_t>, std::string> by_content;
  for (const auto& f : files) {
    std::error_code ec;
    const fs::path canon = fs::weakly_canonical(f, ec);
    const std::string key = ec ? f : canon.string();
    if (!by_path.emplace(key, f).second) throw io_error(f, "named twice in the inputs (also as " + by_path[key] + ")");
    if (files.size() > 1) {
      const auto [it, fresh] = by_content.emplace(content_key(f), f);
      if (!fresh) throw io_error(f, "has the same bytes as " + it->second + ": a duplicate input");
    }
  }
  return files;
}

std::pair<std::size_t, std::uint64_t> catalogue_report::locate(std::uint64_t i) const {
  const auto it = std::upper_bound(first.begin(), first.end(), i);
  const auto f = static_cast<std::size_t>(it - first.begin()) - 1;
  return {f, i - first[f]};
}

point_cloud read_catalogue(const std::vector<std::string>& files, const read_options& options,
                           catalogue_report* report) {
  catalogue_report rep;
  rep.files = files;
  rep.reports.resize(files.size());
  read_options o = options;
  o.origin.reset();
  if (files.size() == 1) {
    point_cloud c = read_cloud(files[0], o, &rep.reports[0]);
    rep.first = {0, c.size() + rep.reports[0].nonfinite_removed};
    if (report) *report = std::move(rep);
    return c;
  }
  // The origin of the union of the files' bounds: a LAS file's from its
  // header (as its reader takes it), any other's from its points, read now.
  std::vector<std::optional<point_cloud>> read(files.size());
  double lo[3], hi[3];
  bool any = false;
  auto take = [&](const double a[3], const double b[3]) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = any ? std::min(lo[k], a[k]) : a[k];
      hi[k] = any ? std::max(hi[k], b[k]) : b[k];
    }
    any = true;
  };
  for (std::size_t f = 0; f < files.size(); ++f) {
    double a[3], b[3];
    if (las_family(files[f], o) && open_point_stream(files[f], o)->header_bounds(a, b)) {
      take(a, b);
      continue;
    }
    read[f] = read_cloud(files[f], o, &rep.reports[f]);
    if (cloud_bounds(*read[f], a, b)) take(a, b);
  }
  const std::array<double, 3> origin = any ? choose_origin(lo, hi) : std::array<double, 3>{0, 0, 0};
  o.origin = origin;
  std::uint64_t total = 0;
  rep.first.assign(1, 0);
  for (std::size_t f = 0; f < files.size(); ++f) {
    if (!read[f] || read[f]->origin() != origin) read[f] = read_cloud(files[f], o, &rep.reports[f]);
    total += read[f]->size();
    rep.first.push_back(rep.first.back() + read[f]->size() + rep.reports[f].nonfinite_removed);
  }

  // One coordinate system (LAS files: the projection's records, none
  // being one answer too).
  std::size_t crs_file = files.size();
  for (std::size_t f = 0; f < files.size(); ++f) {
    const auto& las = rep.reports[f].las;
    if (!las) continue;
    if (crs_file == files.size()) {
      crs_file = f;
      continue;
    }
    const std::string& first_crs = rep.reports[crs_file].las->coordinate_system;
    auto name = [](const std::string& crs) {
      return crs.empty() ? std::string("none (no projection records)") : "'" + coordinate_system_name(crs) + "'";
    };
    if (las->coordinate_system != first_crs)
      throw io_error(files[f], "is in coordinate system " + name(las->coordinate_system) + ", " + files[crs_file] +
                                   " in " + name(first_crs) + ": the files of one cloud need one");
  }

  // The same fields in every file (a LAS flag no point of a file sets is 0
  // there), each in one type: a type that holds another's values exactly
  // takes them (uint8 into uint16, float32 into float64, ...); 8-bit colour
  // beside 16-bit colour becomes 16-bit (x 257, the same fraction of full).
  std::vector<std::pair<std::string, scalar_type>> fields;
  std::map<std::string, std::size_t> seen_in;  // field -> the first file that has it
  for (std::size_t f = 0; f < files.size(); ++f)
    for (const field& fd : read[f]->fields()) {
      const auto [it, fresh] = seen_in.emplace(fd.name, f);
      if (fresh) {
        fields.push_back({fd.name, fd.values.type()});
        continue;
      }
      scalar_type& t =
          std::find_if(fields.begin(), fields.end(), [&](const auto& p) { return p.first == fd.name; })->second;
      const scalar_type u = fd.values.type();
      if (t == u) continue;
      const std::optional<scalar_type> both = common_type(fd.name, t, u);
      if (!both) {
        std::string why;
        if (fd.name == "scan_angle")
          why =
              " (LAS point formats 0-5 give whole degrees, 6-10 steps of 0.006 degrees: convert the files to one "
              "point format, or run without the field)";
        throw io_error(files[f], "its field '" + fd.name + "' is " + std::string(name_of(u)) + ", in " +
                                     files[it->second] + " it is " + std::string(name_of(t)) +
                                     ": the files of one cloud need one type a field" + why);
      }
      t = *both;
    }
  for (const auto& [name, type] : fields) {
    (void)type;
    if (is_las_flag(name)) continue;
    for (std::size_t f = 0; f < files.size(); ++f)
      if (!read[f]->find_field(name))
        throw io_error(files[f], "has no field '" + name + "', which " + files[seen_in[name]] +
                                     " has (a run that needs it needs it in every file)");
  }

  point_cloud out;
  out.set_origin(origin);
  out.resize(static_cast<std::size_t>(total));
  std::size_t at = 0;
  for (std::size_t f = 0; f < files.size(); ++f) {
    const point_cloud& c = *read[f];
    std::copy(c.positions().begin(), c.positions().end(), out.positions().begin() + std::ptrdiff_t(3 * at));
    at += c.size();
  }
  for (const auto& [name, type] : fields) {
    column col(type, static_cast<std::size_t>(total));
    const std::size_t width = size_of(type);
    std::size_t row = 0;
    for (std::size_t f = 0; f < files.size(); ++f) {
      const point_cloud& c = *read[f];
      if (const field* fd = c.find_field(name)) {
        if (fd->values.type() == type) {
          std::memcpy(col.bytes() + row * width, fd->values.bytes(), c.size() * width);
        } else {
          const double factor = is_colour(name) && fd->values.type() == scalar_type::uint8 ? 257.0 : 1.0;
          for (std::size_t i = 0; i < c.size(); ++i) col.set(row + i, fd->values[i] * factor);
        }
      }
      row += c.size();  // a flag the file does not set: zeros
    }
    out.add_field(name, std::move(col));
  }
  if (report) *report = std::move(rep);
  return out;
}

}  // namespace ced::io
