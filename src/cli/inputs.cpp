// SPDX-License-Identifier: MIT
// What the subcommands read: the input options, read options, files and RGB-D frames.
#include "common.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <system_error>
#include <unordered_set>
#include <vector>

#include "ced/ced.hpp"
#include "ced/eval.hpp"
#include "ced/io/catalogue.hpp"
#include "ced/io/io.hpp"
#include "ced/io/rgbd.hpp"
#include "ced/io/stream.hpp"
#include "ced/plugin.hpp"
#include "ced/preprocess.hpp"

namespace ced_cli {

CLI::Option* add_input_options(CLI::App* cmd, std::string& input, const std::string& what, std::string& format,
                               std::string& columns) {
  CLI::Option* in = cmd->add_option("input", input, what);
  cmd->add_option("--format", format, "Input format when the extension does not say: ply, pcd, las, laz, csv, auto");
  cmd->add_option("--columns", columns, "CSV column names, e.g. x,y,z,intensity (the file then has no header)");
  return in;
}

CLI::Option* add_input_options(CLI::App* cmd, std::vector<std::string>& inputs, const std::string& what,
                               std::string& format, std::string& columns) {
  CLI::Option* in = cmd->add_option("input", inputs, what);
  cmd->add_option("--format", format, "Input format when the extension does not say: ply, pcd, las, laz, csv, auto");
  cmd->add_option("--columns", columns, "CSV column names, e.g. x,y,z,intensity (the file then has no header)");
  return in;
}

ced::io::read_options make_read_options(const std::string& format, const std::string& columns) {
  ced::io::read_options r;
  try {
    r.format = ced::io::parse_format(format);
  } catch (const std::invalid_argument& e) {
    throw usage_error(std::string("--format: ") + e.what());
  }
  if (!columns.empty()) {
    std::stringstream ss(columns);
    for (std::string c; std::getline(ss, c, ',');) r.csv.columns.push_back(c);
  }
  return r;
}

ced::missing_field_error with_file_fields(const ced::missing_field_error& e, const std::string& path,
                                          ced::io::read_options read_opts) {
  if (read_opts.fields.all) return e;
  read_opts.fields = {};
  std::vector<std::string> names;  // in the order found; a LAS flag may appear only in later chunks
  try {
    const auto stream = ced::io::open_point_stream(path, read_opts);
    std::unordered_set<std::string> seen;
    ced::point_cloud chunk;
    while (stream->read(std::size_t{1} << 16, {0.0, 0.0, 0.0}, chunk) > 0)
      for (const auto& f : chunk.fields())
        if (seen.insert(f.name).second) names.push_back(f.name);
  } catch (const std::exception&) {
    return e;
  }
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  const std::string fields = "(its fields: " + (list.empty() ? std::string("none besides x, y, z") : list) + ")";
  if (e.field_name.find_first_of("*?") != std::string::npos)  // a glob (bands(b*))
    return {e.modality_name, e.field_name,
            "modality '" + e.modality_name + "': '" + e.field_name + "' matches no field of " + path + " " + fields};
  return {e.modality_name, e.field_name,
          "modality '" + e.modality_name + "' needs field '" + e.field_name + "', which " + path + " does not have " +
              fields + ced::missing_field_hint(names, e.field_name, e.modality_name)};
}

bool names_catalogue(const std::vector<std::string>& inputs) {
  return inputs.size() > 1 || (inputs.size() == 1 && ced::io::names_catalogue(inputs[0]));
}

ced::point_cloud read_inputs(const std::vector<std::string>& inputs, const ced::io::read_options& options,
                             ced::io::read_report& report, ced::io::catalogue_report* catalogue) {
  if (!names_catalogue(inputs)) return ced::io::read_cloud(inputs.at(0), options, &report);
  ced::io::catalogue_report c;
  ced::point_cloud cloud = ced::io::read_catalogue(ced::io::catalogue_files(inputs), options, &c);
  report = c.summary();
  if (catalogue) *catalogue = std::move(c);
  return cloud;
}

ced::point_cloud read_finite(const std::string& path, const std::string& format, const std::string& columns,
                             double voxel) {
  ced::point_cloud c = ced::io::read_cloud(path, make_read_options(format, columns));
  ced::remove_nonfinite(c);
  if (c.empty()) throw ced::io::io_error(path + ": the cloud has no (finite) points");
  if (voxel > 0) c = ced::voxel_downsample(c, voxel).cloud;
  return c;
}

ced::eval::rigid_transform rgbd_frames::source_to_target(std::size_t i, std::size_t j) const {
  return ced::eval::compose(ced::eval::inverse(poses.at(j)), poses.at(i));  // camera i -> world -> camera j
}

namespace {
/// --intrinsics, or the camera file of the --rgbd folder.
std::string intrinsics_path(const std::string& dir, const std::string& intrinsics) {
  return intrinsics.empty() ? dir + "/camera_primesense.json" : intrinsics;
}

std::vector<ced::io::named_path> rgbd_input_paths(const std::string& dir, const std::string& intrinsics) {
  std::vector<ced::io::named_path> in{{"--rgbd's odometry.log", dir + "/odometry.log"},
                                      {"--intrinsics", intrinsics_path(dir, intrinsics)}};
  for (const char* sub : {"/color", "/depth"}) {
    std::error_code ec;
    for (std::filesystem::directory_iterator it(dir + sub, ec), end; !ec && it != end; it.increment(ec))
      in.push_back({"an --rgbd frame", it->path().string()});
  }
  return in;
}
}  // namespace

std::vector<ced::io::named_path> eval_input_paths(const std::string& input, const std::string& source,
                                                  const std::string& target, const std::string& transform,
                                                  const std::string& rgbd, const std::string& intrinsics) {
  std::vector<ced::io::named_path> in{{"the input", input},
                                      {"--source", source},
                                      {"--target", target},
                                      {"--transform", transform},
                                      {"--intrinsics", intrinsics}};
  if (!rgbd.empty())
    for (auto& p : rgbd_input_paths(rgbd, intrinsics)) in.push_back(std::move(p));
  return in;
}

rgbd_frames load_rgbd_frames(const std::string& dir, const std::string& intrinsics, double depth_max, double voxel) {
  const auto k = ced::io::read_intrinsics(intrinsics_path(dir, intrinsics));
  rgbd_frames f;
  f.poses = ced::io::read_trajectory_log(dir + "/odometry.log");
  ced::io::rgbd_options ro;
  ro.depth_max = depth_max;
  for (std::size_t i = 0; i < f.poses.size(); ++i) {
    char stem[32];
    std::snprintf(stem, sizeof stem, "%05zu", i);
    ced::point_cloud c = ced::io::read_rgbd(dir + "/depth/" + stem + ".png", dir + "/color/" + stem + ".jpg", k, ro);
    if (voxel > 0) c = ced::voxel_downsample(c, voxel).cloud;
    f.clouds.push_back(std::move(c));
  }
  if (f.clouds.size() < 2) throw ced::io::io_error(dir + "/odometry.log: fewer than two frames");
  return f;
}

CLI::Option* add_pair_options(CLI::App* cmd, pair_options& o, const std::string& rgbd_pairs) {
  cmd->add_option("--source", o.source, "A given pair instead of INPUT: the source cloud P");
  cmd->add_option("--target", o.target, "A given pair instead of INPUT: the target cloud Q");
  cmd->add_option("--transform", o.transform,
                  "4x4 row-major matrix file mapping P's coordinates into Q's (default: the identity)");
  cmd->add_option("--rgbd", o.rgbd,
                  "Given pairs instead of INPUT: an Open3D RGB-D folder (color/NNNNN.jpg, depth/NNNNN.png, "
                  "odometry.log), " +
                      rgbd_pairs);
  cmd->add_option("--intrinsics", o.intrinsics, "Camera JSON for --rgbd (default DIR/camera_primesense.json)");
  auto* depth_max =
      cmd->add_option("--depth-max", o.depth_max, "For --rgbd: drop depths beyond this, metres (default 3; 0 = none)");
  cmd->add_option("--neighborhood", o.neighborhood,
                  "Neighbourhood of ced's detectors, as in ced detect (default radius; 'DETECTOR|SPEC' overrides it)");
  cmd->add_option("--search", o.search, "grid (default) or cgal, as in ced detect");
  return depth_max;
}

}  // namespace ced_cli
