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

/// io_error naming two of `files` whose coordinate systems `crs` differ.
void check_one_crs(const std::vector<std::string>& crs, const std::vector<std::string>& files) {
  auto name = [](const std::string& c) {
    return c.empty() ? std::string("none (no projection records)") : "'" + coordinate_system_name(c) + "'";
  };
  for (std::size_t f = 1; f < crs.size(); ++f)
    if (crs[f] != crs[0])
      throw io_error(files[f], "is in coordinate system " + name(crs[f]) + ", " + files[0] + " in " + name(crs[0]) +
                                   ": the files of one cloud need one");
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

/// "N files: " and each distinct description, in order.
std::string catalogue_details(const std::vector<std::string>& details) {
  std::vector<std::string> kinds;
  for (const auto& d : details)
    if (std::find(kinds.begin(), kinds.end(), d) == kinds.end()) kinds.push_back(d);
  std::string out = std::to_string(details.size()) + (details.size() == 1 ? " file: " : " files: ");
  for (std::size_t k = 0; k < kinds.size(); ++k) out += (k ? "; " : "") + kinds[k];
  return out;
}

/// Grows the box [lo, hi] (none yet: `any` false) to hold [a, b].
void join_box(double lo[3], double hi[3], bool& any, const double a[3], const double b[3]) {
  for (int k = 0; k < 3; ++k) {
    lo[k] = any ? std::min(lo[k], a[k]) : a[k];
    hi[k] = any ? std::max(hi[k], b[k]) : b[k];
  }
  any = true;
}

/// The fields of files read as one cloud, file by file: each name once, in
/// one type (common_type()), every file with every field but the LAS flags
/// (those a file lacks are 0 there). io_error naming the file otherwise.
class field_layout {
 public:
  /// with_flags: the LAS flags are fields of the layout too.
  explicit field_layout(bool with_flags) : m_with_flags(with_flags) {}
  void add(const std::string& file, const point_cloud& c) {
    std::vector<std::string> here;
    for (const field& f : c.fields()) {
      const bool flag = is_las_flag(f.name);
      if (flag && !m_with_flags) continue;
      here.push_back(f.name);
      auto it = std::find_if(m_fields.begin(), m_fields.end(), [&](const auto& p) { return p.first == f.name; });
      if (it == m_fields.end()) {
        if (!flag && !m_files.empty())
          throw io_error(file, "has a field '" + f.name + "', which " + m_files.front() +
                                   " has not (a run that needs it needs it in every file)");
        m_fields.push_back({f.name, f.type()});
        continue;
      }
      if (it->second == f.type()) continue;
      const std::optional<scalar_type> both = common_type(f.name, it->second, f.type());
      if (!both) {
        std::string why;
        if (f.name == "scan_angle")
          why =
              " (LAS point formats 0-5 give whole degrees, 6-10 steps of 0.006 degrees: convert the files to one "
              "point format, or run without the field)";
        throw io_error(file, "its field '" + f.name + "' is " + std::string(name_of(f.type())) + ", in " +
                                 m_files.front() + " it is " + std::string(name_of(it->second)) +
                                 ": the files of one cloud need one type a field" + why);
      }
      it->second = *both;
    }
    for (const auto& [name, type] : m_fields) {
      (void)type;
      if (!is_las_flag(name) && std::find(here.begin(), here.end(), name) == here.end())
        throw io_error(file, "has no field '" + name + "', which " + m_files.front() +
                                 " has (a run that needs it needs it in every file)");
    }
    m_files.push_back(file);
  }
  const std::vector<std::pair<std::string, scalar_type>>& fields() const noexcept { return m_fields; }

 private:
  bool m_with_flags;
  std::vector<std::pair<std::string, scalar_type>> m_fields;
  std::vector<std::string> m_files;
};

/// `src`'s values into `dst` from row `row`, in `dst`'s type (one that
/// holds them, common_type()): 8-bit colour into 16-bit × 257.
void copy_converted(column& dst, std::size_t row, const std::string& name, const column& src) {
  if (src.type() == dst.type()) {
    const std::size_t w = size_of(src.type());
    std::memcpy(dst.bytes() + row * w, src.bytes(), src.size() * w);
    return;
  }
  const double factor = is_colour(name) && src.type() == scalar_type::uint8 ? 257.0 : 1.0;
  for (std::size_t i = 0; i < src.size(); ++i) dst.set(row + i, src[i] * factor);
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

std::pair<std::size_t, std::uint64_t> locate(const std::vector<std::uint64_t>& first, std::uint64_t i) {
  const auto f = static_cast<std::size_t>(std::upper_bound(first.begin(), first.end(), i) - first.begin()) - 1;
  return {f, i - first[f]};
}

std::pair<std::size_t, std::uint64_t> catalogue_report::locate(std::uint64_t i) const { return io::locate(first, i); }

read_report catalogue_report::summary() const {
  read_report r = reports.at(0);
  std::vector<std::string> details;
  bool same_las = true;
  r.nonfinite_removed = 0;
  for (const auto& f : reports) {
    details.push_back(f.details);
    r.nonfinite_removed += f.nonfinite_removed;
    same_las = same_las && f.las && r.las && f.las->point_format == r.las->point_format &&
               f.las->scale == r.las->scale && f.las->offset == r.las->offset;
  }
  r.details = catalogue_details(details);
  if (!same_las) r.las.reset();
  return r;
}

point_cloud read_catalogue(const std::vector<std::string>& files, const read_options& options,
                           catalogue_report* report) {
  catalogue_report rep;
  rep.files = files;
  rep.reports.resize(files.size());
  read_options o = options;
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
  // (The same rule as the catalogue's stream: the headers' bounds when
  // every file has them, else the points'.)
  bool headers = true;
  for (std::size_t f = 0; f < files.size() && headers; ++f) {
    double a[3], b[3];
    headers = las_family(files[f], o) && open_point_stream(files[f], o)->header_bounds(a, b);
    if (headers) join_box(lo, hi, any, a, b);
  }
  if (!headers) {
    any = false;
    for (std::size_t f = 0; f < files.size(); ++f) {
      double a[3], b[3];
      read[f] = read_cloud(files[f], o, &rep.reports[f]);
      if (cloud_bounds(*read[f], a, b)) join_box(lo, hi, any, a, b);
    }
  }
  const std::array<double, 3> origin = options.origin ? *options.origin
                                       : any          ? choose_origin(lo, hi)
                                                      : std::array<double, 3>{0, 0, 0};
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
  std::vector<std::string> crs, crs_files;
  for (std::size_t f = 0; f < files.size(); ++f)
    if (rep.reports[f].las) {
      crs.push_back(rep.reports[f].las->coordinate_system);
      crs_files.push_back(files[f]);
    }
  check_one_crs(crs, crs_files);

  // The same fields in every file, each in one type (field_layout).
  field_layout layout(true);
  for (std::size_t f = 0; f < files.size(); ++f) layout.add(files[f], *read[f]);

  point_cloud out;
  out.set_origin(origin);
  out.resize(static_cast<std::size_t>(total));
  std::size_t at = 0;
  for (std::size_t f = 0; f < files.size(); ++f) {
    const point_cloud& c = *read[f];
    std::copy(c.positions().begin(), c.positions().end(), out.positions().begin() + std::ptrdiff_t(3 * at));
    at += c.size();
  }
  for (const auto& [name, type] : layout.fields()) {
    column col(type, static_cast<std::size_t>(total));
    std::size_t row = 0;
    for (std::size_t f = 0; f < files.size(); ++f) {
      const point_cloud& c = *read[f];
      if (const field* fd = c.find_field(name)) copy_converted(col, row, name, fd->values);
      row += c.size();  // a flag the file does not set: zeros
    }
    out.add_field(name, std::move(col));
  }
  if (report) *report = std::move(rep);
  return out;
}

namespace {

/// Several files as one stream: their points file after file (global index
/// = the file's first point in the catalogue + its own index), every chunk
/// in one layout of fields (field_layout), positions relative to the
/// origin asked for.
class catalogue_stream final : public point_stream {
 public:
  catalogue_stream(std::vector<std::string> files, const read_options& options)
      : m_files(std::move(files)), m_options(options) {
    m_options.origin.reset();
    m_first.assign(1, 0);
    bool counted = true, headers = true;
    bool chunked = true;
    for (const std::string& f : m_files) {
      auto s = open_point_stream(f, m_options);
      m_details.push_back(s->details());
      const std::uint64_t n = s->declared_points();
      counted = counted && n > 0;
      m_first.push_back(m_first.back() + n);
      double lo[3], hi[3];
      if (headers && s->header_bounds(lo, hi))
        join_box(m_header_lo, m_header_hi, m_any_header, lo, hi);
      else
        headers = false;
      auto runs = s->chunk_runs();
      chunked = chunked && !runs.empty();
      for (auto& r : runs) m_runs.push_back({r.first + m_first[m_first.size() - 2], r.count});
      m_streaming = m_streaming && s->streaming();
      probe(*s, f);
      if (las_family(f, m_options)) {
        m_crs.push_back(read_las_info(f).coordinate_system);
        m_crs_files.push_back(f);
      }
    }
    check_one_crs(m_crs, m_crs_files);
    m_counted = counted;
    m_headers = headers;
    if (!counted || !chunked) m_runs.clear();
  }

  std::size_t read(std::size_t max, const std::array<double, 3>& origin, point_cloud& out) override {
    for (;;) {
      if (m_cur == m_files.size()) {
        out = point_cloud();
        out.set_origin(origin);
        return 0;
      }
      if (!m_stream) {
        m_stream = open_point_stream(m_files[m_cur], m_options);
        if (!m_taken.empty()) m_stream->take_fields(m_taken);
      }
      point_cloud chunk;
      const std::size_t n = m_stream->read(max, origin, chunk);
      if (n > 0) {
        m_pass_points += n;
        normalise(chunk, out);
        return n;
      }
      // The file's pass is complete: its bounds and flags count.
      if (!m_pass_done) {
        double lo[3], hi[3];
        m_stream->bounds(lo, hi);
        if (m_pass_points > m_member_start) join_box(m_lo, m_hi, m_any, lo, hi);
        for (auto& f : m_stream->flags_set())
          if (std::find(m_flags.begin(), m_flags.end(), f) == m_flags.end()) m_flags.push_back(f);
      }
      m_member_start = m_pass_points;
      m_stream.reset();
      if (++m_cur == m_files.size() && !m_pass_done) {
        m_pass_done = true;
        order_flags();
      }
    }
  }
  void rewind() override {
    m_stream.reset();
    m_cur = 0;
    m_pass_points = m_member_start = 0;
  }
  std::array<double, 3> origin() const override {
    if (m_headers && m_any_header) return choose_origin(m_header_lo, m_header_hi);
    return m_any ? choose_origin(m_lo, m_hi) : std::array<double, 3>{0, 0, 0};
  }
  void bounds(double lo[3], double hi[3]) const override {
    for (int k = 0; k < 3; ++k) {
      lo[k] = m_any ? m_lo[k] : 0;
      hi[k] = m_any ? m_hi[k] : 0;
    }
  }
  std::string details() const override { return catalogue_details(m_details); }
  bool streaming() const noexcept override { return m_streaming; }
  std::uint64_t declared_points() const noexcept override { return m_counted ? m_first.back() : 0; }

  std::optional<std::vector<index_node>> index_nodes() override {
    if (!m_counted) return std::nullopt;
    std::vector<index_node> all;
    for (std::size_t f = 0; f < m_files.size(); ++f) {
      const auto s = open_point_stream(m_files[f], m_options);
      if (const auto nodes = s->index_nodes()) {
        for (index_node n : *nodes) {
          n.run.first += m_first[f];
          all.push_back(n);
        }
        continue;
      }
      // A file without an index: its runs, each in the header's box.
      double box[6];
      const auto runs = s->chunk_runs();
      if (runs.empty() || !s->header_box(0, box)) return std::nullopt;
      for (const point_run& r : runs) {
        index_node& n = all.emplace_back();
        std::copy_n(box, 6, n.box.begin());
        n.run = {r.first + m_first[f], r.count};
        n.whole_file = true;
      }
    }
    return all;
  }
  std::vector<point_run> chunk_runs() const override { return m_runs; }
  std::vector<std::string> flags_set() const override { return m_flags; }
  bool header_bounds(double lo[3], double hi[3]) const override {
    if (!m_headers || !m_any_header) return false;
    std::copy_n(m_header_lo, 3, lo);
    std::copy_n(m_header_hi, 3, hi);
    return true;
  }
  bool header_box(double growth, double box[6]) const override {
    // Each file's box as its header vouches for it, joined.
    bool any = false;
    for (const auto& f : m_files) {
      double b[6];
      if (!open_point_stream(f, m_options)->header_box(growth, b)) return false;
      for (int k = 0; k < 3; ++k) {
        box[k] = any ? std::min(box[k], b[k]) : b[k];
        box[3 + k] = any ? std::max(box[3 + k], b[3 + k]) : b[3 + k];
      }
      any = true;
    }
    return any;
  }
  bool take_fields(const std::vector<std::string>& fields) override {
    m_taken = fields;
    m_flags.clear();
    for (const auto& f : fields)
      if (is_las_flag(f)) m_flags.push_back(f);
    order_flags();
    m_pass_done = true;
    return true;
  }
  void read_run(const point_run& r, const std::vector<std::string>& fields, const std::array<double, 3>& origin,
                point_cloud& out) override {
    if (!m_counted) throw std::logic_error("point_stream::read_run: this catalogue reads no runs");
    check_run(r, m_first.back(), true);
    use_flags(fields);
    point_cloud joined;
    joined.set_origin(origin);
    std::uint64_t at = r.first, left = r.count;
    while (left > 0) {
      const std::size_t f = file_of(at);
      const std::uint64_t take = std::min(left, m_first[f + 1] - at);
      point_cloud part, norm;
      open_point_stream(m_files[f], m_options)->read_run({at - m_first[f], take}, fields, origin, part);
      normalise(part, norm);
      append(joined, norm);
      at += take;
      left -= take;
    }
    out = std::move(joined);
  }
  bool read_points(const std::vector<std::uint64_t>& at, const std::vector<std::string>& fields,
                   const std::array<double, 3>& origin, point_cloud& out) override {
    if (!m_counted) return false;
    for (std::uint64_t i : at)
      if (i >= m_first.back()) throw std::logic_error("point_stream::read_points: a point past the catalogue's");
    use_flags(fields);
    point_cloud joined;
    joined.set_origin(origin);
    std::size_t k = 0;
    for (std::size_t f = 0; f < m_files.size() && (k < at.size() || at.empty()); ++f) {
      std::vector<std::uint64_t> local;
      while (k < at.size() && at[k] < m_first[f + 1]) local.push_back(at[k++] - m_first[f]);
      if (local.empty() && !at.empty()) continue;
      // (With `at` empty: whether points can be read, which every file answers.)
      point_cloud part, norm;
      if (!open_point_stream(m_files[f], m_options)->read_points(local, fields, origin, part)) return false;
      normalise(part, norm);
      append(joined, norm);
    }
    out = std::move(joined);
    return true;
  }

 private:
  std::size_t file_of(std::uint64_t i) const { return locate(m_first, i).first; }
  /// A file's fields from its first point (LAS: every flag too), into the
  /// catalogue's layout: each name once, in one type (as read_catalogue()).
  void probe(point_stream& s, const std::string& file) {
    point_cloud one;
    if (s.declared_points() > 0 && !s.chunk_runs().empty()) {
      s.read_run({0, 1}, las_flag_fields(), {0, 0, 0}, one);
    } else {
      s.read(1, {0, 0, 0}, one);
      s.rewind();
    }
    m_layout.add(file, one);
  }
  void order_flags() {
    std::vector<std::string> ordered;
    for (const auto& f : las_flag_fields())
      if (std::find(m_flags.begin(), m_flags.end(), f) != m_flags.end()) ordered.push_back(f);
    m_flags = std::move(ordered);
  }
  /// The flags a run read names, as the catalogue's (a plan records them).
  void use_flags(const std::vector<std::string>& fields) {
    m_flags.clear();
    for (const auto& f : fields)
      if (is_las_flag(f)) m_flags.push_back(f);
    order_flags();
  }
  /// `in` (a chunk of one file) in the catalogue's layout: its fields in
  /// order and type, then the flags (those of the catalogue's that the
  /// file does not set: 0).
  void normalise(point_cloud& in, point_cloud& out) const {
    point_cloud o;
    o.set_origin(in.origin());
    o.positions() = std::move(in.positions());
    const std::size_t n = o.size();
    for (const auto& [name, type] : m_layout.fields()) {
      field* fd = nullptr;
      for (field& x : in.fields())
        if (x.name == name) fd = &x;
      if (!fd) continue;  // a selection that reads fewer fields
      if (fd->values.type() == type) {
        o.add_field(name, std::move(fd->values));
        continue;
      }
      column c(type, n);
      copy_converted(c, 0, name, fd->values);
      o.add_field(name, std::move(c));
    }
    std::vector<std::string> flags = m_flags;
    for (const field& x : in.fields())
      if (is_las_flag(x.name) && std::find(flags.begin(), flags.end(), x.name) == flags.end()) flags.push_back(x.name);
    for (const auto& name : las_flag_fields()) {
      if (std::find(flags.begin(), flags.end(), name) == flags.end()) continue;
      field* fd = nullptr;
      for (field& x : in.fields())
        if (x.name == name) fd = &x;
      if (fd)
        o.add_field(name, std::move(fd->values));
      else
        o.add_field(name, column(scalar_type::uint8, n));
    }
    out = std::move(o);
  }
  static void append(point_cloud& into, const point_cloud& part) {
    if (into.empty() && into.fields().empty()) {
      const auto origin = into.origin();
      into = part;
      into.set_origin(origin);
      return;
    }
    const std::size_t n0 = into.size();
    into.positions().insert(into.positions().end(), part.positions().begin(), part.positions().end());
    for (field& f : into.fields()) {
      const field* g = part.find_field(f.name);
      const std::size_t w = size_of(f.values.type());
      f.values.resize(n0 + part.size());
      if (g) std::memcpy(f.values.bytes() + n0 * w, g->values.bytes(), part.size() * w);
    }
  }

  std::vector<std::string> m_files;
  read_options m_options;
  std::vector<std::string> m_details;
  std::vector<std::uint64_t> m_first;  // declared points before each file (m_counted)
  std::vector<point_run> m_runs;
  bool m_counted = false, m_headers = false, m_streaming = true;
  double m_header_lo[3] = {0, 0, 0}, m_header_hi[3] = {0, 0, 0};
  bool m_any_header = false;
  field_layout m_layout{false};
  std::vector<std::string> m_crs, m_crs_files;
  // The pass.
  std::unique_ptr<point_stream> m_stream;
  std::size_t m_cur = 0;
  std::uint64_t m_pass_points = 0, m_member_start = 0;
  bool m_pass_done = false, m_any = false;
  double m_lo[3] = {0, 0, 0}, m_hi[3] = {0, 0, 0};
  std::vector<std::string> m_flags, m_taken;
};

}  // namespace

std::unique_ptr<point_stream> open_catalogue_stream(const std::vector<std::string>& files,
                                                    const read_options& options) {
  if (files.empty()) throw std::invalid_argument("open_catalogue_stream: no files");
  return std::make_unique<catalogue_stream>(files, options);
}

std::vector<std::uint64_t> catalogue_first(const std::vector<std::string>& files, const read_options& options) {
  read_options o = options;
  o.fields = field_selection::only({});
  o.origin.reset();
  std::vector<std::uint64_t> first{0};
  for (const auto& f : files) {
    auto s = open_point_stream(f, o);
    std::uint64_t n = s->declared_points();
    if (n == 0) {
      point_cloud chunk;
      while (const std::size_t got = s->read(std::size_t(1) << 20, {0, 0, 0}, chunk)) n += got;
    }
    first.push_back(first.back() + n);
  }
  return first;
}

bool names_catalogue(const std::string& path) {
  std::error_code ec;
  return (!path.empty() && path[0] == '@') || fs::is_directory(path, ec);
}

}  // namespace ced::io
