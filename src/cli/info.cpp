// SPDX-License-Identifier: MIT
// `ced info`: a cloud's fields, point count, bounds and resolution.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <iostream>
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

struct info_options {
  std::string input, format = "auto", columns;
  std::vector<int> knn = {8, 16, 32};
};

/// `v` in the fewest digits that read back as it (an origin, for --origin).
std::string exact(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

/// The bounds (absolute coordinates) and the resolution of a cloud of finite points.
void print_extent(const ced::point_cloud& cloud) {
  const auto& o = cloud.origin();
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (std::size_t i = 0; i < cloud.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], cloud.position(i)[k]);
      hi[k] = std::max(hi[k], cloud.position(i)[k]);
    }
  std::cout.precision(10);
  std::cout << "bounds: x " << lo[0] + o[0] << " .. " << hi[0] + o[0] << ", y " << lo[1] + o[1] << " .. "
            << hi[1] + o[1] << ", z " << lo[2] + o[2] << " .. " << hi[2] + o[2] << "\n";
  std::cout.precision(6);
  if (const std::size_t shared = ced::coincident_points(cloud))
    std::cout << "coincident points: " << shared
              << " points share a position with another (each counts as a neighbour; invalid returns stored at one "
                 "place are such points)\n";
  const double res = ced::estimate_resolution(cloud);
  std::cout << "resolution (median nearest-neighbour distance): " << res << "  -> --radius auto = " << 5 * res << "\n";
}

/// The distance to the K-th nearest point (knn:K's own radius) for a few K:
/// how far a k-nearest neighbourhood reaches, and how much the density varies.
void print_k_distances(const ced::point_cloud& cloud, const std::vector<int>& ks) {
  std::cout << "k-distance (to the K-th nearest, the point first; 5% / median / 95%; --neighborhood knn:K):\n";
  for (int k : ks) {
    if (k < 1 || std::size_t(k) > cloud.size()) continue;
    const auto d = ced::k_distance_quantiles(cloud, std::size_t(k), {0.05, 0.5, 0.95});
    std::cout << "  K = " << k << ": " << d[0] << " / " << d[1] << " / " << d[2];
    if (d[0] > 0) std::cout << "  (95% / 5% = " << d[2] / d[0] << ")";
    std::cout << "\n";
  }
}

/// Each field's name, type and range.
void print_fields(const ced::point_cloud& cloud) {
  std::cout << "fields:\n";
  for (const auto& f : cloud.fields()) {
    double mn = INFINITY, mx = -INFINITY;
    for (double v : f.values) {
      mn = std::min(mn, v);
      mx = std::max(mx, v);
    }
    std::cout << "  " << f.name << " (" << ced::name_of(f.type()) << ") ";
    if (cloud.empty())
      std::cout << "no values\n";
    else
      std::cout << mn << " .. " << mx << "\n";
  }
}

int run_info(const info_options& opt) {
  for (int k : opt.knn)
    if (k < 1 || k > 65535) throw usage_error("--knn: K must be from 1 to 65535, got " + std::to_string(k));
  const std::string& path = opt.input;
  ced::io::read_report report;
  ced::io::catalogue_report files;
  ced::point_cloud cloud = read_inputs({path}, make_read_options(opt.format, opt.columns), report, &files);
  std::cout << path << ": " << cloud.size() << " points (" << report.details << ")\n";
  for (std::size_t f = 0; f < files.files.size(); ++f)  // a folder or @LIST: its files, numbered
    std::cout << "  file " << f << ": " << files.files[f] << ": " << files.first[f + 1] - files.first[f] << " points ("
              << files.reports[f].details << ")\n";
  if (report.nonfinite_removed)
    std::cout << "non-finite points dropped while reading: " << report.nonfinite_removed << "\n";
  const auto& o = cloud.origin();
  if (o[0] != 0 || o[1] != 0 || o[2] != 0)
    std::cout << "origin: " << exact(o[0]) << " " << exact(o[1]) << " " << exact(o[2])
              << " (positions are stored relative to it; --origin X,Y,Z)\n";
  const std::size_t before = cloud.size();
  ced::remove_nonfinite(cloud);
  if (cloud.size() != before) std::cout << "non-finite points: " << before - cloud.size() << "\n";
  if (!cloud.empty()) print_extent(cloud);
  if (!cloud.empty()) print_k_distances(cloud, opt.knn);
  print_fields(cloud);
  std::cout << "colour: " << (cloud.has_rgb() ? "yes (default preset ced6d)" : "no (default preset ced3d)") << "\n";
  return exit_ok;
}

}  // namespace

command add_info_command(CLI::App& app) {
  auto o = std::make_shared<info_options>();
  auto* info = app.add_subcommand("info", "Print a cloud's fields, point count, bounds and resolution");
  add_input_options(info, o->input, "Input point cloud, or a folder or @LIST of files read as one", o->format,
                    o->columns)
      ->required();
  info->add_option("--knn", o->knn, "K values of the k-distance table (default 8 16 32)");
  return {info, [o] { return run_info(*o); }};
}

}  // namespace ced_cli
