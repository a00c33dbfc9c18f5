// SPDX-License-Identifier: MIT
// LAS written whole: the columns and header a cloud needs, the records encoded in parallel chunks, and the options that
// keep a source file's layout.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <initializer_list>
#include <limits>
#include <memory>
#include <optional>
#include <ostream>
#include <sstream>
#include <type_traits>
#include <vector>

#include "ced/io/las.hpp"
#include "ced/io/stream.hpp"
#include "ced/version.hpp"
#include "io/base/records.hpp"
#include "io/base/scalar_io.hpp"
#include "io/base/stream_support.hpp"
#include "io/las/layout.hpp"
#include "io/laz/types.hpp"

namespace ced::io {

using namespace las_detail;

namespace las_detail {

std::vector<slot_spec> standard_slots(const format_layout& layout) {
  using k = slot_kind;
  std::vector<slot_spec> s;
  s.push_back({"intensity", k::u16, 12});
  if (layout.extended) {
    s.push_back({"return_number", k::bits, 14, 0, 15});
    s.push_back({"number_of_returns", k::bits, 14, 4, 15});
    s.push_back({"synthetic", k::bits, 15, 0, 1, true});
    s.push_back({"key_point", k::bits, 15, 1, 1, true});
    s.push_back({"withheld", k::bits, 15, 2, 1, true});
    s.push_back({"overlap", k::bits, 15, 3, 1, true});
    s.push_back({"scanner_channel", k::bits, 15, 4, 3});
    s.push_back({"scan_direction_flag", k::bits, 15, 6, 1, true});
    s.push_back({"edge_of_flight_line", k::bits, 15, 7, 1, true});
    s.push_back({"classification", k::u8, 16});
    s.push_back({"user_data", k::u8, 17});
    s.push_back({"scan_angle", k::i16, 18});
    s.push_back({"point_source_id", k::u16, 20});
  } else {
    s.push_back({"return_number", k::bits, 14, 0, 7});
    s.push_back({"number_of_returns", k::bits, 14, 3, 7});
    s.push_back({"scan_direction_flag", k::bits, 14, 6, 1, true});
    s.push_back({"edge_of_flight_line", k::bits, 14, 7, 1, true});
    s.push_back({"classification", k::bits, 15, 0, 31});
    s.push_back({"synthetic", k::bits, 15, 5, 1, true});
    s.push_back({"key_point", k::bits, 15, 6, 1, true});
    s.push_back({"withheld", k::bits, 15, 7, 1, true});
    s.push_back({"scan_angle", k::i8, 16});
    s.push_back({"user_data", k::u8, 17});
    s.push_back({"point_source_id", k::u16, 18});
  }
  if (layout.gps >= 0) s.push_back({"gps_time", k::f64, static_cast<std::size_t>(layout.gps)});
  if (layout.rgb >= 0) {
    const auto o = static_cast<std::size_t>(layout.rgb);
    s.push_back({"red", k::u16, o});
    s.push_back({"green", k::u16, o + 2});
    s.push_back({"blue", k::u16, o + 4});
  }
  if (layout.nir >= 0) s.push_back({"nir", k::u16, static_cast<std::size_t>(layout.nir)});
  return s;
}

void encode_column(const out_column& c, std::size_t i0, std::size_t m, unsigned char* buf, std::size_t record) {
  unsigned char* p = buf + c.offset;
  // Straight from the column when that stores the same bytes (not doubles:
  // the product by the factor quiets a signalling NaN).
  if (!c.bits && c.values && c.factor == 1 && c.type != scalar_type::float64 &&
      encode_direct(*c.values, i0, m, c.type, !host_little_endian(), p, record))
    return;
  thread_local std::vector<double> values;
  values.resize(m);
  if (c.values)
    copy_values(*c.values, i0, m, values.data());
  else
    std::fill(values.begin(), values.end(), c.constant);
  const auto value = [&](std::size_t i) { return values[i] * c.factor; };
  if (!c.bits) return encode_values(c.type, !host_little_endian(), p, record, m, value);
  for (std::size_t i = 0; i < m; ++i) {
    const double v = value(i);
    unsigned b = 0;
    if (c.flag)
      b = v != 0 && !std::isnan(v) ? 1u : 0u;
    else
      b = std::min<unsigned>(convert<std::uint8_t>(v), c.max);
    p[i * record] = static_cast<unsigned char>(p[i * record] | (b << c.shift));
  }
}

/// Throws std::invalid_argument when `cloud` cannot be written as LAS with `opt`.
void check_writable(const point_cloud& cloud, const las_write_options& opt, std::uint64_t n) {
  const int minor = opt.version_minor;
  if (minor < 2 || minor > 4)
    throw std::invalid_argument("LAS version 1." + std::to_string(minor) + " cannot be written (use 1.2, 1.3 or 1.4)");
  for (std::size_t k = 0; k < 3; ++k) {
    if (!std::isfinite(opt.scale[k]) || opt.scale[k] <= 0)
      throw std::invalid_argument("invalid LAS scale " + num(opt.scale[k]) + " (it must be finite and positive)");
    if (!std::isfinite(cloud.origin()[k])) throw std::invalid_argument("the cloud's origin is not finite");
    if (opt.offset && !std::isfinite((*opt.offset)[k]))
      throw std::invalid_argument("invalid LAS offset " + num((*opt.offset)[k]) + " (not finite)");
  }
  const int pf = opt.point_format;
  if (pf != -1 && (pf < 0 || pf > k_max_format || (pf >= 6 && minor < 4)))
    throw std::invalid_argument("LAS point format " + std::to_string(pf) + " cannot be written in LAS 1." +
                                std::to_string(minor) + " (formats 0-3, and 6-8 in LAS 1.4)");
  if (pf == 4 || pf == 5 || pf == 9 || pf == 10)
    throw std::invalid_argument("LAS point format " + std::to_string(pf) +
                                " holds waveform packets, which ced does not write (use " +
                                std::to_string(pf == 4   ? 1
                                               : pf == 5 ? 3
                                               : pf == 9 ? 6
                                                         : 8) +
                                ")");
  for (const auto& f : cloud.fields()) check_field_size(f, cloud.size());
  if (minor < 4 && n > std::numeric_limits<std::uint32_t>::max())
    throw std::invalid_argument("LAS 1." + std::to_string(minor) + " cannot hold " + std::to_string(n) +
                                " points (at most 2^32-1; write LAS 1.4)");
}

/// The factor `f` is written into standard slot `s` with, so that reading the
/// file back gives what ced read from the field: a float colour or nir is a
/// fraction of the full scale (the rgb and bands modalities take floats as
/// [0, 1]: x 65535), an 8-bit nir becomes 16 bits (x 257, which bands reads
/// back as v / 255), a scan angle changes units; other values are written as
/// they are. In the 16-bit slots (intensity, colour, nir) a value that does
/// not fit (NaN, outside 0 .. 65535, a float colour outside [0, 1]) is an
/// error naming the field, never clamped.
double slot_factor(const field& f, const slot_spec& s, bool extended) {
  const std::string_view name = s.name;
  const bool is_float = f.type() == scalar_type::float32 || f.type() == scalar_type::float64;
  const bool colour = name == "red" || name == "green" || name == "blue" || name == "nir";
  double factor = 1;
  if (colour && is_float) factor = 65535;
  if (name == "nir" && f.type() == scalar_type::uint8) factor = 257;
  if (name == "scan_angle") {
    const bool degrees = f.type() == scalar_type::int8;
    if (extended && degrees) factor = 1 / 0.006;
    if (!extended && !degrees) factor = 0.006;
  }
  // The 16-bit slots hold measurements; the others are codes and counts, which
  // an older point format clamps (return numbers to 7, classes to 31).
  if (s.kind != slot_kind::u16 || f.type() == scalar_type::uint16 || f.type() == scalar_type::uint8) return factor;
  const double lo = 0, hi = 65535;
  f.values.visit([&](const auto* v, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      const double x = std::round(static_cast<double>(v[i]) * factor);
      if (x >= lo && x <= hi) continue;
      std::ostringstream msg;
      msg << "field '" << f.name << "' cannot be written as LAS " << name << ": point " << i << " has "
          << static_cast<double>(v[i]);
      if (colour && is_float)
        msg << " (a float " << name << " must be a fraction in [0, 1], written x 65535)";
      else
        msg << " (LAS stores it as an integer in " << lo << " .. " << hi << ")";
      throw std::invalid_argument(msg.str());
    }
  });
  return factor;
}

/// The columns of the standard slots that the cloud has a field for (and
/// return_number, number_of_returns = 1 when it has none); `used` receives
/// those fields.
void plan_standard_columns(const point_cloud& cloud, const std::array<const field*, 3>& rgb, const field* nir,
                           las_plan& plan, std::vector<const field*>& used) {
  const format_layout& layout = *plan.layout;
  for (const slot_spec& s : standard_slots(layout)) {
    const std::string_view name = s.name;
    const field* f = nullptr;
    if (name == "red" || name == "green" || name == "blue")
      f = rgb[name == "red" ? 0 : name == "green" ? 1 : 2];
    else if (name == "nir")
      f = nir;
    else
      f = cloud.find_field_icase(name);  // exact name first
    out_column c;
    c.bits = s.kind == slot_kind::bits;
    if (!c.bits) c.type = k_slot_types[static_cast<int>(s.kind)];
    c.offset = s.offset;
    c.shift = s.shift;
    c.max = s.max;
    c.flag = s.flag;
    if (f) {
      c.values = &f->values;
      used.push_back(f);
      c.factor = slot_factor(*f, s, layout.extended);
      if (name == "return_number") plan.return_number = f;
    } else if (name == "return_number" || name == "number_of_returns") {
      c.constant = 1;
    } else {
      continue;
    }
    plan.cols.push_back(c);
  }
}

/// The columns of the other fields, as extra bytes after the standard fields.
void plan_extra_columns(const point_cloud& cloud, las_plan& plan, const std::vector<const field*>& used) {
  for (const auto& f : cloud.fields()) {
    if (std::find(used.begin(), used.end(), &f) != used.end()) continue;
    if (f.name.empty() || f.name.size() > 32)
      throw std::invalid_argument("field '" + f.name +
                                  "' cannot be written as LAS extra bytes (the name must have 1 to 32 characters)");
    if (iequal(f.name, "x") || iequal(f.name, "y") || iequal(f.name, "z"))
      throw std::invalid_argument("field '" + f.name + "' clashes with the LAS coordinates");
    plan.extras.push_back(&f);
  }
  plan.record = plan.layout->min_size;
  for (const field* f : plan.extras) {
    out_column c;
    c.values = &f->values;
    c.type = f->type();
    c.offset = plan.record;
    plan.record += size_of(f->type());
    plan.cols.push_back(c);
  }
  if (plan.record > std::numeric_limits<std::uint16_t>::max() ||
      plan.extras.size() * k_extra_bytes_descriptor_size > std::numeric_limits<std::uint16_t>::max())
    throw std::invalid_argument("too many fields for LAS extra bytes (" + std::to_string(plan.extras.size()) + ")");
}

/// The point format (opt.point_format, or the one for the cloud's fields:
/// colour, nir, gps_time) and its columns.
las_plan plan_records(const point_cloud& cloud, const las_write_options& opt) {
  const int minor = opt.version_minor;
  const auto rgb = find_rgb_fields(cloud);
  const bool has_rgb = rgb[0] != nullptr;
  const field* nir = cloud.find_field("nir");
  if (!nir) nir = cloud.find_field_icase("nir");
  const bool has_gps = cloud.find_field("gps_time") != nullptr;
  las_plan plan;
  if (minor >= 4)
    plan.format = has_rgb ? (nir ? 8 : 7) : 6;
  else
    plan.format = has_rgb ? (has_gps ? 3 : 2) : (has_gps ? 1 : 0);
  if (opt.point_format >= 0) plan.format = opt.point_format;
  plan.layout = &k_formats[plan.format];
  std::vector<const field*> used;
  plan_standard_columns(cloud, rgb, nir, plan, used);
  plan_extra_columns(cloud, plan, used);
  return plan;
}

/// The header's offsets: options.offset, or the cloud's origin.
std::array<double, 3> header_offset(const point_cloud& cloud, const las_write_options& opt) {
  return opt.offset ? *opt.offset : cloud.origin();
}

/// offset - origin: a position p relative to the origin is written as the
/// integer round((p - shift) / scale), which read_las() reads back as
/// float(integer * scale + shift). 0 with the default offset (the origin).
std::array<double, 3> position_shift(const point_cloud& cloud, const las_write_options& opt) {
  std::array<double, 3> d{0, 0, 0};
  if (opt.offset)
    for (std::size_t k = 0; k < 3; ++k) d[k] = (*opt.offset)[k] - cloud.origin()[k];
  return d;
}

/// Adds `cloud`'s points to `s`; std::invalid_argument when a position is
/// not finite or does not fit (points numbered from s.n; the first such
/// point). Chunks of points are checked in parallel and merged in order: the
/// same bounds and error as one pass.
void add_stats(const point_cloud& cloud, const las_write_options& opt, const las_plan& plan, las_stats& s) {
  const float* xyz = cloud.positions().data();
  const std::array<double, 3> shift = position_shift(cloud, opt);
  constexpr std::size_t chunk = 65536;
  const std::size_t chunks = (cloud.size() + chunk - 1) / chunk;
  struct chunk_stats {
    double qmin[3], qmax[3];
    std::string error;  ///< its first point's that cannot be stored
  };
  std::vector<chunk_stats> part(chunks);
  ced::detail::parallel_for(chunks, 0, 1, [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c) {
      const std::size_t b = c * chunk, e = std::min(cloud.size(), b + chunk);
      double qmin[3], qmax[3];  // here, not in part[c]: chunks side by side share cache lines
      for (std::size_t i = b; i < e; ++i)
        for (std::size_t k = 0; k < 3; ++k) {
          const float p = xyz[3 * i + k];
          if (!std::isfinite(p)) {
            part[c].error = "point " + std::to_string(s.n + i) + " has a non-finite coordinate; LAS cannot store it";
            return;
          }
          const double q = std::round((static_cast<double>(p) - shift[k]) / opt.scale[k]);
          if (q < std::numeric_limits<std::int32_t>::min() || q > std::numeric_limits<std::int32_t>::max()) {
            part[c].error = "point " + std::to_string(s.n + i) + ": coordinate " + num(p) +
                            " (relative to the origin) does not fit a 32-bit LAS integer at scale " +
                            num(opt.scale[k]) + (opt.offset ? " and offset " + num((*opt.offset)[k]) : "") +
                            " (choose a coarser scale)";
            return;
          }
          qmin[k] = i == b ? q : std::min(qmin[k], q);
          qmax[k] = i == b ? q : std::max(qmax[k], q);
        }
      std::copy_n(qmin, 3, part[c].qmin);
      std::copy_n(qmax, 3, part[c].qmax);
    }
  });
  for (std::size_t c = 0; c < chunks; ++c) {
    if (!part[c].error.empty()) throw std::invalid_argument(part[c].error);
    for (std::size_t k = 0; k < 3; ++k) {
      s.qmin[k] = s.n == 0 && c == 0 ? part[c].qmin[k] : std::min(s.qmin[k], part[c].qmin[k]);
      s.qmax[k] = s.n == 0 && c == 0 ? part[c].qmax[k] : std::max(s.qmax[k], part[c].qmax[k]);
    }
  }
  const unsigned max_return = plan.layout->extended ? 15 : 7;
  if (!plan.return_number)
    s.by_return[0] += cloud.size();
  else
    plan.return_number->values.visit([&](const auto* v, std::size_t n) {
      for (std::size_t i = 0; i < n; ++i) {
        const unsigned r = std::min<unsigned>(convert<std::uint8_t>(static_cast<double>(v[i])), max_return);
        if (r >= 1 && r <= 15) ++s.by_return[r - 1];
      }
    });
  s.n += cloud.size();
}

/// Writes the extra-bytes VLR describing `extras` at h[v...].
void put_extra_bytes_vlr(std::string& h, std::size_t v, const std::vector<const field*>& extras) {
  h.replace(v, k_vlr_header_size,
            detail::vlr_header("LASF_Spec", 4, extras.size() * k_extra_bytes_descriptor_size, "extra bytes"));
  v += k_vlr_header_size;
  for (const field* f : extras) {
    put<std::uint8_t>(h, v + 2, static_cast<std::uint8_t>(extra_type_code(f->type())));
    put_string(h, v + 4, 32, f->name);
    put_string(h, v + 160, 32, "ced field (" + std::string(name_of(f->type())) + ")");
    v += k_extra_bytes_descriptor_size;
  }
}

/// The public header, then the extra-bytes VLR when there are extra bytes.
std::string make_header(const point_cloud& cloud, const las_write_options& opt, const las_plan& plan,
                        const las_stats& s) {
  const std::uint64_t n = s.n;
  const int minor = opt.version_minor;
  const double* qmin = s.qmin;
  const double* qmax = s.qmax;
  const std::array<std::uint64_t, 15>& by_return = s.by_return;
  const std::array<double, 3> offset = header_offset(cloud, opt);
  const std::size_t header_size = header_size_for(minor);
  const std::size_t vlr_size =
      plan.extras.empty() ? 0 : k_vlr_header_size + plan.extras.size() * k_extra_bytes_descriptor_size;
  std::string h(header_size + vlr_size, '\0');
  put_string(h, 0, 4, "LASF");
  // Formats 6-10: the WKT bit must be set. Bit 0: the GPS time type.
  put<std::uint16_t>(h, 6, (plan.layout->extended ? 0x10 : 0) | (opt.adjusted_standard_gps_time ? 1 : 0));
  put<std::uint8_t>(h, 24, 1);
  put<std::uint8_t>(h, 25, static_cast<std::uint8_t>(minor));
  put_string(h, 26, 32, "OTHER");
  put_string(h, 58, 32, "ced " CED_VERSION_STRING);
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
#if defined(_WIN32)
  gmtime_s(&utc, &now);
#else
  gmtime_r(&now, &utc);
#endif
  put<std::uint16_t>(h, 90, static_cast<std::uint16_t>(utc.tm_yday + 1));
  put<std::uint16_t>(h, 92, static_cast<std::uint16_t>(utc.tm_year + 1900));
  put<std::uint16_t>(h, 94, static_cast<std::uint16_t>(header_size));
  put<std::uint32_t>(h, 96, static_cast<std::uint32_t>(header_size + vlr_size));
  put<std::uint32_t>(h, 100, plan.extras.empty() ? 0u : 1u);
  put<std::uint8_t>(h, 104, static_cast<std::uint8_t>(plan.format));
  put<std::uint16_t>(h, 105, static_cast<std::uint16_t>(plan.record));
  const bool legacy_counts = !plan.layout->extended && n <= std::numeric_limits<std::uint32_t>::max();
  if (legacy_counts) {
    put<std::uint32_t>(h, 107, static_cast<std::uint32_t>(n));
    for (std::size_t r = 0; r < 5; ++r) put<std::uint32_t>(h, 111 + 4 * r, static_cast<std::uint32_t>(by_return[r]));
  }
  for (std::size_t k = 0; k < 3; ++k) {
    put<double>(h, 131 + 8 * k, opt.scale[k]);
    put<double>(h, 155 + 8 * k, offset[k]);
    put<double>(h, 179 + 16 * k, n ? offset[k] + qmax[k] * opt.scale[k] : 0.0);
    put<double>(h, 187 + 16 * k, n ? offset[k] + qmin[k] * opt.scale[k] : 0.0);
  }
  if (minor >= 4) {
    put<std::uint64_t>(h, 247, n);
    for (std::size_t r = 0; r < 15; ++r) put<std::uint64_t>(h, 255 + 8 * r, by_return[r]);
  }
  if (!plan.extras.empty()) put_extra_bytes_vlr(h, header_size, plan.extras);
  return h;
}

/// The point records, in chunks encoded in parallel (write_chunks()).
void write_records(std::ostream& out, const point_cloud& cloud, const las_write_options& opt, const las_plan& plan) {
  const std::size_t n = cloud.size();
  const std::size_t record = plan.record;
  const float* xyz = cloud.positions().data();
  const std::array<double, 3> shift = position_shift(cloud, opt);
  constexpr std::size_t chunk = 8192;
  write_chunks(out, (n + chunk - 1) / chunk, [&](std::size_t k, std::string& bytes) {
    const std::size_t i0 = k * chunk, m = std::min(chunk, n - i0);
    bytes.assign(m * record, '\0');
    auto* buf = reinterpret_cast<unsigned char*>(bytes.data());
    for (std::size_t i = 0; i < m; ++i)
      for (std::size_t a = 0; a < 3; ++a) {
        const double q = std::round((static_cast<double>(xyz[3 * (i0 + i) + a]) - shift[a]) / opt.scale[a]);
        store_le<std::int32_t>(buf + i * record + 4 * a, static_cast<std::int32_t>(q));
      }
    for (const auto& c : plan.cols) encode_column(c, i0, m, buf, record);
  });
}

void write_las_unchecked(std::ostream& out, const point_cloud& cloud, const las_write_options& opt) {
  check_writable(cloud, opt, cloud.size());
  const las_plan plan = plan_records(cloud, opt);
  las_stats stats;
  add_stats(cloud, opt, plan, stats);
  const std::string header = make_header(cloud, opt, plan, stats);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  write_records(out, cloud, opt, plan);
}
}  // namespace las_detail

void write_las(std::ostream& out, const point_cloud& cloud, const las_write_options& options) {
  detail::write_to_stream(out, "LAS", [&](std::ostream& o) { write_las_unchecked(o, cloud, options); });
}

void write_las(const std::string& path, const point_cloud& cloud, const las_write_options& options) {
  detail::write_to_file(path, [&](std::ostream& o) { write_las_unchecked(o, cloud, options); });
}

namespace {
/// True when every position of `cloud` is exact in `scale` and `offset`: its
/// integer, read back as read_las() reads it, gives the same float.
bool positions_exact(const point_cloud& cloud, const std::array<double, 3>& scale,
                     const std::array<double, 3>& offset) {
  double shift[3];
  for (std::size_t k = 0; k < 3; ++k) {
    if (!std::isfinite(scale[k]) || scale[k] <= 0 || !std::isfinite(offset[k])) return false;
    shift[k] = offset[k] - cloud.origin()[k];
  }
  const float* xyz = cloud.positions().data();
  const std::size_t n = cloud.size();
  constexpr std::size_t chunk = 65536;
  std::vector<std::uint8_t> exact((n + chunk - 1) / chunk, 1);
  ced::detail::parallel_for(exact.size(), 0, 1, [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c)
      for (std::size_t i = c * chunk; i < std::min(n, (c + 1) * chunk) && exact[c]; ++i)
        for (std::size_t k = 0; k < 3; ++k) {
          const float p = xyz[3 * i + k];
          const double q = std::round((static_cast<double>(p) - shift[k]) / scale[k]);
          if (!(q >= std::numeric_limits<std::int32_t>::min() && q <= std::numeric_limits<std::int32_t>::max()) ||
              static_cast<float>(static_cast<std::int32_t>(q) * scale[k] + shift[k]) != p) {
            exact[c] = 0;
            break;
          }
        }
  });
  return std::all_of(exact.begin(), exact.end(), [](std::uint8_t e) { return e != 0; });
}

std::string triple(const std::array<double, 3>& v) { return num(v[0]) + ", " + num(v[1]) + ", " + num(v[2]); }
}  // namespace

las_write_options las_write_options_like(const las_read_info& source, const point_cloud& cloud, bool copc,
                                         std::vector<std::string>* changes) {
  const auto note = [&](const std::string& what) {
    if (changes) changes->push_back(what);
  };
  las_write_options o;
  const int minor = source.version_major == 1 ? std::clamp(source.version_minor, 2, 4) : 4;
  if (source.version_major != 1 || source.version_minor != minor)
    note("LAS " + std::to_string(source.version_major) + "." + std::to_string(source.version_minor) +
         " is written as LAS 1." + std::to_string(minor));
  o.version_minor = minor;
  int pf = std::clamp(source.point_format, 0, k_max_format);
  static constexpr int k_no_waveform[k_max_format + 1] = {0, 1, 2, 3, 1, 3, 6, 7, 8, 6, 8};
  if (k_no_waveform[pf] != pf) {
    note("point format " + std::to_string(pf) + " is written as " + std::to_string(k_no_waveform[pf]) +
         ": ced does not keep waveform packets");
    pf = k_no_waveform[pf];
  }
  if (copc && pf < 6) {
    const int to = k_formats[pf].rgb >= 0 ? 7 : 6;
    note("COPC holds LAS 1.4 point formats 6-8: point format " + std::to_string(pf) + " (LAS 1." +
         std::to_string(minor) + ") is written as " + std::to_string(to) +
         " (scan angles in 0.006-degree steps, not whole degrees)");
    pf = to;
  }
  if (pf >= 6 && o.version_minor < 4 && !copc) {  // (COPC said so)
    note("point format " + std::to_string(pf) + " needs LAS 1.4: written as LAS 1.4, not 1." + std::to_string(minor));
    o.version_minor = 4;
  }
  if (copc) o.version_minor = 4;
  o.point_format = pf;
  o.adjusted_standard_gps_time = (source.global_encoding & 1) != 0;
  if (positions_exact(cloud, source.scale, source.offset)) {
    o.scale = source.scale;
    o.offset = source.offset;
    // Floats as far from the origin as the farthest point step by more than
    // the scale: the file's integers were rounded on reading.
    float far[3] = {0, 0, 0};
    const std::vector<float>& xyz = cloud.positions();
    for (std::size_t i = 0; i < xyz.size(); ++i) far[i % 3] = std::max(far[i % 3], std::fabs(xyz[i]));
    for (std::size_t k = 0; k < 3; ++k) {
      const double step = static_cast<double>(std::nextafter(far[k], 2 * far[k]) - far[k]);
      if (far[k] > 0 && step >= source.scale[k])
        note(std::string(1, static_cast<char>('X' + k)) + " positions are floats relative to the origin " +
             num(cloud.origin()[k]) + ": up to " + num(far[k]) + " from it their step, " + num(step) +
             ", is coarser than the scale " + num(source.scale[k]) + ", so the source's integers can move by up to " +
             num(step / 2) + " (a second conversion gives back the first's)");
    }
  } else {
    note("the positions are not on the source's grid (scale " + triple(source.scale) + ", offset " +
         triple(source.offset) + "), as after voxel down-sampling or a transform: they are written at scale " +
         triple(o.scale) + " with the offset at the cloud's origin " + triple(cloud.origin()));
  }
  return o;
}

}  // namespace ced::io
