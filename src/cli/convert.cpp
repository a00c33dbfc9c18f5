// SPDX-License-Identifier: MIT
// `ced convert`: between formats (by extension), optionally voxel down-sampled.
#include <cmath>
#include <memory>
#include <string>

#include "ced/ced.hpp"
#include "ced/io/io.hpp"
#include "ced/preprocess.hpp"
#include "commands.hpp"
#include "common.hpp"

namespace ced_cli {
namespace {

struct convert_options {
  std::string input, output, format = "auto", columns;
  double voxel = 0;
};

int run_convert(const convert_options& o) {
  if (o.voxel < 0 || !std::isfinite(o.voxel)) throw usage_error("--voxel must be a positive size");
  const auto fmt = ced::io::format_of(o.output);
  // Refused rather than converted in place: ced never writes over what it reads.
  check_paths({{"the input", o.input}}, {{"the output", o.output}});
  ced::io::atomic_output_file out(o.output);
  ced::point_cloud c = ced::io::read_cloud(o.input, make_read_options(o.format, o.columns));
  warn_float_precision(c, o.input);
  if (o.voxel > 0) {
    ced::remove_nonfinite(c);
    c = ced::voxel_downsample(c, o.voxel).cloud;
  }
  ced::io::write_named(out, [&](std::ostream& s) { ced::io::write_cloud(s, c, fmt); });
  out.commit();
  return exit_ok;
}

}  // namespace

command add_convert_command(CLI::App& app) {
  auto o = std::make_shared<convert_options>();
  auto* conv = app.add_subcommand("convert", "Convert between formats (by extension), optionally voxel down-sampled");
  add_input_options(conv, o->input, "Input point cloud", o->format, o->columns)->required();
  conv->add_option("output", o->output, "Output: .ply, .pcd, .las, .laz, .copc.laz or .csv")->required();
  conv->add_option("--voxel", o->voxel, "Voxel size for down-sampling (metres)");
  return {conv, [o] { return run_convert(*o); }};
}

}  // namespace ced_cli
