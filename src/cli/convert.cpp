// SPDX-License-Identifier: MIT
// `ced convert`: between formats (by extension), optionally voxel down-sampled.
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
};

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
  const auto fmt = output_format(o);
  // Refused rather than converted in place: ced never writes over what it reads.
  check_paths({{"the input", o.input}}, {{"the output", o.output}});
  ced::io::atomic_output_file out(o.output);
  ced::io::read_report report;
  ced::point_cloud c = ced::io::read_cloud(o.input, make_read_options(o.format, o.columns), &report);
  warn_float_precision(c, o.input);
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
  add_input_options(conv, o->input, "Input point cloud", o->format, o->columns)->required();
  conv->add_option("output", o->output, "Output: .ply, .pcd, .las, .laz, .copc.laz or .csv")->required();
  conv->add_option("--to", o->to,
                   "The output's format when its name does not say (e.g. /dev/stdout): ply, pcd, las, laz, copc, csv");
  conv->add_option("--voxel", o->voxel, "Voxel size for down-sampling (metres)");
  return {conv, [o] { return run_convert(*o); }};
}

}  // namespace ced_cli
