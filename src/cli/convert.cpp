// SPDX-License-Identifier: MIT
// `ced convert`: between formats (by extension), optionally voxel down-sampled.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/io/io.hpp"
#include "ced/preprocess.hpp"
#include "commands.hpp"
#include "common.hpp"

namespace ced_cli {
namespace {

struct convert_options {
  std::string input, output, format = "auto", columns, to;
  double voxel = 0;
  std::vector<std::string> merge_channels, merge_fields = {"intensity"};
  std::string merge_radius = "auto", merge_missing = "drop";
};

/// A channel's name in the merged fields: its file's name up to the first
/// dot, with characters other than letters, digits and '_' made '_'.
std::string channel_name(const std::string& path) {
  const auto slash = path.find_last_of('/');
  std::string name = path.substr(slash == std::string::npos ? 0 : slash + 1);
  name = name.substr(0, name.find('.'));
  for (char& ch : name)
    if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '_')) ch = '_';
  return name;
}

/// The --merge-* options, checked before anything is read.
void check_merge_options(const convert_options& o) {
  if (o.merge_channels.empty() && (o.merge_fields != std::vector<std::string>{"intensity"} ||
                                   o.merge_radius != "auto" || o.merge_missing != "drop"))
    throw usage_error("--merge-fields, --merge-radius and --merge-missing go with --merge-channels");
  if (o.merge_missing != "drop" && o.merge_missing != "nan")
    throw usage_error("--merge-missing must be drop or nan, got '" + o.merge_missing + "'");
  if (o.merge_radius != "auto") {
    double r = 0;
    try {
      r = ced::parse_number(o.merge_radius, "--merge-radius");
    } catch (const std::invalid_argument& e) {
      throw usage_error(e.what());
    }
    if (!(r > 0) || !std::isfinite(r))
      throw usage_error("--merge-radius must be a distance > 0 or auto, got " + o.merge_radius);
  }
  for (const std::string& path : o.merge_channels) check_paths({{"a channel", path}}, {{"the output", o.output}});
}

/// --merge-channels: each other channel's fields onto the input's points.
ced::point_cloud merge_into(const ced::point_cloud& c, const convert_options& o, const ced::io::read_report& input) {
  ced::channel_merge_options m;
  m.fields = o.merge_fields;
  m.when_missing =
      o.merge_missing == "nan" ? ced::channel_merge_options::missing::nan : ced::channel_merge_options::missing::drop;
  std::vector<ced::point_cloud> clouds;
  clouds.reserve(o.merge_channels.size());
  // The channels must share the input's coordinate system (LAS: its
  // projection VLRs, byte for byte); other formats carry none.
  const std::string crs = input.las ? input.las->coordinate_system : std::string();
  for (const std::string& path : o.merge_channels) {
    ced::io::read_report report;
    clouds.push_back(ced::io::read_cloud(path, make_read_options("auto", ""), &report));
    const std::string other = report.las ? report.las->coordinate_system : std::string();
    if (other != crs)
      throw std::invalid_argument("--merge-channels: " + path + " is in coordinate system '" +
                                  ced::io::coordinate_system_name(other) + "', the input " + o.input + " in '" +
                                  ced::io::coordinate_system_name(crs) +
                                  "': channels are merged by position, so reproject them into one system first");
  }
  std::vector<ced::named_channel> others;
  for (std::size_t k = 0; k < clouds.size(); ++k) others.push_back({channel_name(o.merge_channels[k]), &clouds[k]});
  if (o.merge_radius == "auto") {
    // Twice the coarsest channel's resolution: a partner is a neighbour.
    double res = ced::estimate_resolution(c);
    for (const auto& cl : clouds) res = std::max(res, ced::estimate_resolution(cl));
    if (!(res > 0)) throw usage_error("--merge-radius auto: the channels have no resolution (fewer than two points)");
    m.radius = 2 * res;
  } else {
    m.radius = ced::parse_number(o.merge_radius, "--merge-radius");  // checked by check_merge_options
  }
  ced::channel_merge_report r;
  const std::size_t before = c.size();
  ced::point_cloud out;
  try {
    out = ced::merge_channels(c, others, m, &r);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("--merge-channels: ") + e.what());
  }
  std::string line;
  for (std::size_t k = 0; k < others.size(); ++k) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "%s%s: %zu of %zu points (%.1f %%)", k ? "; " : "", others[k].name.c_str(),
                  r.partnered[k], before, before ? 100.0 * double(r.partnered[k]) / double(before) : 0.0);
    line += buf;
  }
  std::fprintf(stderr, "ced: note: %s: partners within %g m: %s", o.output.c_str(), m.radius, line.c_str());
  if (m.when_missing == ced::channel_merge_options::missing::drop)
    std::fprintf(stderr, "; %zu point(s) without a partner in every channel dropped\n", r.dropped);
  else
    std::fprintf(stderr, "; points without a partner have NaN in that channel's fields\n");
  return out;
}

/// The output's format: --to's, else its extension's (a path without one,
/// such as /dev/stdout, needs --to; --format names the input's).
ced::io::file_format output_format(const convert_options& o) {
  if (!o.to.empty()) {
    ced::io::file_format f{};
    try {
      f = ced::io::parse_format(o.to);
    } catch (const std::invalid_argument& e) {
      throw usage_error(std::string("--to: ") + e.what());
    }
    if (f == ced::io::file_format::automatic) throw usage_error("--to: name a format: ply, pcd, las, laz, copc or csv");
    return f;
  }
  const auto slash = o.output.find_last_of('/'), dot = o.output.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash) || dot + 1 == o.output.size())
    throw usage_error(o.output + ": no file extension; name the output's format with --to ply|pcd|las|laz|copc|csv");
  return ced::io::format_of(o.output);
}

int run_convert(const convert_options& o) {
  if (o.voxel < 0 || !std::isfinite(o.voxel)) throw usage_error("--voxel must be a positive size");
  check_merge_options(o);
  const auto fmt = output_format(o);
  // Refused rather than converted in place: ced never writes over what it reads.
  std::vector<ced::io::named_path> inputs{{"the input", o.input}};
  const bool several = names_catalogue({o.input});
  if (several) {
    if (!o.merge_channels.empty()) throw usage_error("--merge-channels takes one input file, not a folder or @LIST");
    inputs.clear();
    for (const auto& f : ced::io::catalogue_files({o.input})) inputs.push_back({"an input", f});
  }
  check_paths(inputs, {{"the output", o.output}});
  ced::io::atomic_output_file out(o.output);
  ced::io::read_report report;
  ced::point_cloud c = read_inputs({o.input}, make_read_options(o.format, o.columns), report);
  if (several && !report.las)
    std::fprintf(stderr, "ced: note: %s: the inputs are not LAS files of one point format, scale and offset\n",
                 o.output.c_str());
  warn_float_precision(c, o.input);
  if (!o.merge_channels.empty()) c = merge_into(c, o, report);
  if (report.las && (!report.las->other_vlrs.empty() || report.las->extended_vlrs > 0)) {
    // What no writer carries over (a coordinate system among them) is said, not lost in silence.
    std::string what;
    for (const auto& v : report.las->other_vlrs) what += (what.empty() ? "" : ", ") + v;
    if (report.las->extended_vlrs > 0)
      what += (what.empty() ? "" : ", and ") + std::to_string(report.las->extended_vlrs) + " extended VLR(s)";
    std::fprintf(stderr, "ced: note: %s: %s's VLRs %s (a coordinate system, if one is among them) are not copied\n",
                 o.output.c_str(), o.input.c_str(), what.c_str());
  }
  if (o.voxel > 0) {
    ced::remove_nonfinite(c);
    c = ced::voxel_downsample(c, o.voxel).cloud;
  }
  using ced::io::file_format;
  const bool to_las = fmt == file_format::las || fmt == file_format::laz || fmt == file_format::copc;
  if (report.las && to_las) {
    // LAS to LAS: the source's version, point format, scale and offset, so
    // that the point records come back as they were.
    std::vector<std::string> changes;
    const auto las = ced::io::las_write_options_like(*report.las, c, fmt == file_format::copc, &changes);
    if (!changes.empty()) {
      std::string line;
      for (const auto& m : changes) line += (line.empty() ? "" : "; ") + m;
      std::fprintf(stderr, "ced: note: %s: %s\n", o.output.c_str(), line.c_str());
    }
    ced::io::write_named(out, [&](std::ostream& s) { ced::io::write_cloud(s, c, fmt, las); });
  } else {
    if (to_las)
      std::fprintf(stderr,
                   "ced: note: %s: %s has no LAS scale: positions are written at scale 0.001 (rounded to 0.5 mm) "
                   "with the offset at the cloud's origin\n",
                   o.output.c_str(), o.input.c_str());
    ced::io::write_named(out, [&](std::ostream& s) { ced::io::write_cloud(s, c, fmt); });
  }
  out.commit();
  return exit_ok;
}

}  // namespace

command add_convert_command(CLI::App& app) {
  auto o = std::make_shared<convert_options>();
  auto* conv =
      app.add_subcommand("convert", "Convert between formats (by extension or --to), optionally voxel down-sampled");
  add_input_options(conv, o->input, "Input point cloud, or a folder or @LIST of files joined into one", o->format,
                    o->columns)
      ->required();
  conv->add_option("output", o->output, "Output: .ply, .pcd, .las, .laz, .copc.laz or .csv")->required();
  conv->add_option("--to", o->to,
                   "The output's format when its name does not say (e.g. /dev/stdout): ply, pcd, las, laz, copc, csv");
  conv->add_option("--voxel", o->voxel, "Voxel size for down-sampling (metres)");
  conv->add_option("--merge-channels", o->merge_channels,
                   "Multispectral LiDAR: other channels' files (comma-separated or repeated); each input point gets "
                   "the fields of its nearest point in each, as FIELD_CHANNEL (CHANNEL: the file's name)")
      ->delimiter(',');
  conv->add_option("--merge-fields", o->merge_fields, "With --merge-channels: the fields to take (default intensity)")
      ->delimiter(',');
  conv->add_option("--merge-radius", o->merge_radius,
                   "With --merge-channels: a partner lies within this distance (metres; default auto: twice the "
                   "coarsest channel's resolution)");
  conv->add_option("--merge-missing", o->merge_missing,
                   "With --merge-channels: points without a partner in some channel are dropped (drop, default) or "
                   "kept with NaN in its fields (nan)");
  return {conv, [o] { return run_convert(*o); }};
}

}  // namespace ced_cli
