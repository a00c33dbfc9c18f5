// SPDX-License-Identifier: MIT
// `ced view`: the interactive page (--html) of a keypoint or viewer cloud
// written earlier.
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "../core/text.hpp"
#include "ced/ced.hpp"
#include "ced/html.hpp"
#include "ced/io/io.hpp"
#include "commands.hpp"
#include "common.hpp"

namespace ced_cli {
namespace {

struct view_options {
  std::string input, output, format = "auto", columns, title;
  long long max_points = 2000000;
  std::vector<std::string> thresholds;  // NAME=VALUE
};

bool starts_with(const std::string& s, const std::string& p) { return s.compare(0, p.size(), p) == 0; }

int run_view(const view_options& o) {
  if (o.max_points < 1) throw usage_error("--max-points must be at least 1");
  std::vector<std::pair<std::string, double>> given;
  for (const auto& t : o.thresholds) {
    const auto eq = t.find('=');
    if (eq == std::string::npos || eq == 0) throw usage_error("--threshold takes NAME=VALUE, got '" + t + "'");
    const std::string name = t.substr(0, eq);
    double v = 0;
    try {
      v = ced::parse_number(t.substr(eq + 1), "--threshold " + name);  // finite
    } catch (const std::invalid_argument& e) {
      throw usage_error(e.what());
    }
    if (v < 0) throw usage_error("--threshold " + name + ": a threshold is >= 0, got " + t.substr(eq + 1));
    for (const auto& g : given)
      if (g.first == name) throw usage_error("--threshold " + name + " given twice");
    given.push_back({name, v});
  }
  ced::io::atomic_output_file out(o.output);
  const ced::point_cloud cloud = ced::io::read_cloud(o.input, make_read_options(o.format, o.columns));
  if (cloud.empty()) throw std::invalid_argument(o.input + ": the cloud has no points");

  // A viewer cloud (--viewer) marks its keypoints; a keypoint cloud (-o) is
  // all keypoints. Saliencies: scalar_saliency_NAME or saliency_NAME.
  std::vector<std::uint32_t> keypoints;
  const ced::field* mark = cloud.find_field("scalar_keypoint");
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (!mark || mark->values[i] != 0) keypoints.push_back(static_cast<std::uint32_t>(i));
  std::vector<ced::html_layer> layers;
  for (const auto& f : cloud.fields()) {
    std::string name;
    if (starts_with(f.name, "scalar_saliency_"))
      name = f.name.substr(16);
    else if (starts_with(f.name, "saliency_"))
      name = f.name.substr(9);
    else
      continue;
    ced::html_layer l;
    l.name = name;
    l.threshold = std::nan("");
    for (const auto& [n, v] : given)
      if (n == name) l.threshold = v;
    l.saliency.resize(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) l.saliency[i] = static_cast<float>(f.values[i]);
    layers.push_back(std::move(l));
  }
  for (const auto& [n, v] : given) {
    bool found = false;
    for (const auto& l : layers) found = found || l.name == n;
    if (!found) throw usage_error("--threshold " + n + ": the cloud has no saliency_" + n + " field");
  }
  ced::html_options h;
  h.title = o.title.empty() ? "ced: " + std::to_string(keypoints.size()) + " keypoints" : o.title;
  h.source = o.input;
  h.max_points = static_cast<std::size_t>(o.max_points);
  h.info.push_back({"points", std::to_string(cloud.size())});
  h.info.push_back(
      {"keypoints", std::to_string(keypoints.size()) + (mark ? "" : " (every point of a keypoint cloud)")});
  for (const auto& l : layers)
    h.info.push_back({l.name, std::isnan(l.threshold) ? "threshold unknown (--threshold)"
                                                      : "t = " + ced::detail::number_text(l.threshold)});
  out.stream() << ced::html_page(cloud, keypoints, layers, h);
  out.commit();
  return exit_ok;
}

}  // namespace

command add_view_command(CLI::App& app) {
  auto o = std::make_shared<view_options>();
  auto* v = app.add_subcommand("view", "Interactive page (HTML) of a keypoint cloud (-o) or viewer cloud (--viewer)");
  add_input_options(v, o->input, "A cloud written by ced detect -o or --viewer", o->format, o->columns)->required();
  v->add_option("-o,--output", o->output, "The page: an .html file")->required();
  v->add_option("--threshold", o->thresholds,
                "NAME=VALUE: a modality's threshold, to show its candidates (the cloud does not store it)");
  v->add_option("--max-points", o->max_points, "Draw at most this many points (default 2000000)");
  v->add_option("--title", o->title, "The page's title");
  v->footer(
      "Examples:\n  ced detect scan.ply --preset ced6d --viewer all.ply\n  ced view all.ply -o view.html "
      "--threshold xyz=0.01 --threshold rgb=0.1");
  return {v, [o] {
            check_paths({{"the input", o->input}}, {{"-o", o->output}});
            return run_view(*o);
          }};
}

}  // namespace ced_cli
