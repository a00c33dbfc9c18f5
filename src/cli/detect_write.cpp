// SPDX-License-Identifier: MIT
// `ced detect`'s outputs: indices, keypoints, viewer cloud, picture, summary,
// and the report on stderr.
#include <algorithm>
#include <array>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "../core/text.hpp"
#include "ced/ced.hpp"
#include "ced/html.hpp"
#include "ced/io/io.hpp"
#include "ced/render.hpp"
#include "common.hpp"
#include "detect.hpp"

namespace ced_cli {

std::string column_name(const std::string& modality) {
  std::string s;
  for (char c : modality) s += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  while (!s.empty() && s.back() == '_') s.pop_back();
  return s;
}

std::vector<std::string> saliency_columns(const std::vector<std::string>& names) {
  std::vector<std::string> columns;
  for (const auto& name : names) {
    columns.push_back(column_name(name));
    for (std::size_t a = 0; a + 1 < columns.size(); ++a)
      if (columns[a] == columns.back())
        throw std::invalid_argument("modalities '" + names[a] + "' and '" + name +
                                    "' would both write the column 'saliency_" + columns.back() +
                                    "' (of -o and --viewer): give each modality once");
  }
  return columns;
}

ced::point_cloud keypoint_cloud(ced::point_cloud kp, const std::vector<std::string>& names,
                                const std::vector<std::vector<float>>& saliency) {
  const auto columns = saliency_columns(names);
  for (std::size_t m = 0; m < names.size(); ++m)
    kp.add_field("saliency_" + columns[m], ced::scalar_type::float32,
                 std::vector<double>(saliency[m].begin(), saliency[m].end()));
  return kp;
}

void write_keypoint_cloud(std::ostream& out, ced::point_cloud kp, const std::vector<std::string>& names,
                          const std::vector<std::vector<float>>& saliency, ced::io::file_format format) {
  ced::io::write_cloud(out, keypoint_cloud(std::move(kp), names, saliency), format);
}

std::size_t png_saliency_index(const std::string& name, const std::vector<std::string>& names) {
  std::string known;
  for (std::size_t m = 0; m < names.size(); ++m) {
    if (names[m] == name || column_name(names[m]) == name) return m;
    known += (m ? ", " : "") + names[m];
  }
  throw usage_error("--png-color saliency:" + name + ": no such modality in this run (" + known + ")");
}

namespace {

/// Adds one saliency field per modality to `c`: of every point, or of `subset`'s.
void add_saliency(ced::point_cloud& c, const ced::detection_result& r, const std::vector<std::uint32_t>* subset,
                  const std::string& prefix) {
  const auto columns = saliency_columns(r.names);
  for (std::size_t m = 0; m < r.names.size(); ++m) {
    std::vector<double> v;
    if (subset)
      for (std::uint32_t k : *subset) v.push_back(r.saliency[m][k]);
    else
      v.assign(r.saliency[m].begin(), r.saliency[m].end());
    c.add_field(prefix + columns[m], ced::scalar_type::float32, std::move(v));
  }
}

/// Several inputs: each keypoint's file and its index there.
file_places places_of(const detect_input& in, const ced::detection_result& r) {
  file_places at;
  for (std::uint32_t k : r.keypoints) at.push_back(in.catalogue->locate(in.original[k]));
  return at;
}

/// -o: the keypoints with all their fields and their saliencies (with
/// several inputs, `at`: their files and indices).
void write_keypoints(std::ostream& out, const detect_input& in, const ced::detection_result& r,
                     ced::io::file_format format, const file_places& at) {
  const ced::point_cloud& cloud = in.cloud;
  std::vector<std::uint8_t> keep(cloud.size(), 0);
  for (std::uint32_t k : r.keypoints) keep[k] = 1;
  ced::point_cloud kp = cloud;
  kp.filter(keep);
  if (in.catalogue) add_file_fields(kp, at, in.catalogue->first.back());
  std::vector<std::vector<float>> saliency(r.names.size());
  for (std::size_t m = 0; m < r.names.size(); ++m)
    for (std::uint32_t k : r.keypoints) saliency[m].push_back(r.saliency[m][k]);
  write_keypoint_cloud(out, std::move(kp), r.names, saliency, format);
}

/// --viewer: the whole cloud, keypoints red, with scalar_* fields.
void write_viewer(std::ostream& out, const ced::point_cloud& cloud, const ced::detection_result& r) {
  ced::point_cloud v = cloud;
  std::vector<std::array<std::uint8_t, 3>> colours(cloud.size(), {170, 170, 170});
  const auto f = ced::find_rgb_fields(cloud);
  if (f[0]) {
    const auto s = ced::rgb::scale(f, std::nullopt);
    for (std::size_t i = 0; i < cloud.size(); ++i)
      for (std::size_t c = 0; c < 3; ++c)
        colours[i][c] = static_cast<std::uint8_t>(std::clamp(f[c]->values[i] * s[c] * 255.0 + 0.5, 0.0, 255.0));
  }
  std::vector<double> is_kp(cloud.size(), 0.0);
  for (std::uint32_t k : r.keypoints) {
    colours[k] = {255, 0, 0};
    is_kp[k] = 1.0;
  }
  if (f[0]) {  // replace the colour fields by the keypoint-marked colours
    const std::string names[3] = {f[0]->name, f[1]->name, f[2]->name};
    auto& fs = v.fields();
    fs.erase(std::remove_if(
                 fs.begin(), fs.end(),
                 [&](const ced::field& x) { return x.name == names[0] || x.name == names[1] || x.name == names[2]; }),
             fs.end());
  }
  v.add_rgb(colours);
  v.add_field("scalar_keypoint", ced::scalar_type::float32, std::move(is_kp));
  add_saliency(v, r, nullptr, "scalar_saliency_");
  ced::io::write_ply(out, v, ced::io::ply_format::binary_little_endian);
}

/// Points at or above modality m's threshold.
std::size_t modality_candidates(const ced::detection_result& r, std::size_t m) {
  std::size_t n = 0;
  for (float v : r.saliency[m]) n += v >= r.thresholds[m];
  return n;
}

/// The names of the cloud's fields: those the run read.
std::vector<std::string> field_names(const ced::point_cloud& cloud) {
  std::vector<std::string> names;
  for (const auto& f : cloud.fields()) names.push_back(f.name);
  return names;
}

/// --summary: input, parameters used, counts, per-stage times.
nlohmann::json summary_json(const detect_options& o, const detect_plan& plan, const detect_input& in,
                            const ced::detection_result& r) {
  const ced::point_cloud& cloud = in.cloud;
  const ced::detect_params& params = plan.params;
  nlohmann::json j;
  if (in.catalogue) j["input_files"] = in.catalogue->files;
  j["input"] = {{"path", o.input},
                {"format", ced::io::format_name(in.report.format)},
                {"details", in.report.details},
                {"points_in_file", in.n_file},
                {"nonfinite_removed", in.n_dropped},
                {"points_after_voxel", cloud.size()},
                {"points_used", cloud.size()},
                {"fields_read", field_names(cloud)}};
  j["params"] = {{"radius", params.radius},
                 {"radius_auto", plan.auto_radius},
                 {"resolution", plan.resolution},
                 {"nms_radius", params.nms_radius},
                 {"min_neighbors", params.min_neighbors},
                 {"refine", params.refine},
                 {"max_keypoints", params.max_keypoints},
                 {"keypoint_share", params.keypoint_share},
                 {"neighborhood", ced::to_string(params.neighborhood)},
                 {"search", ced::to_string(params.search)},
                 {"voxel", o.voxel},
                 {"threads", ced::resolve_threads(params.threads)}};
  auto& mods = j["modalities"] = nlohmann::json::array();
  for (std::size_t m = 0; m < r.names.size(); ++m)
    mods.push_back({{"name", r.names[m]}, {"threshold", r.thresholds[m]}, {"candidates", modality_candidates(r, m)}});
  j["counts"] = {{"candidates", ced::candidate_count(r)}, {"keypoints", r.keypoints.size()}};
  j["times_ms"] = {{"read", in.load_ms},        {"voxel", in.voxel_ms},
                   {"index", r.times.index_ms}, {"saliency", r.times.saliency_ms},
                   {"nms", r.times.nms_ms},     {"detect", r.times.total_ms()}};
  return j;
}

/// --png-color: the points' colours (empty: the cloud's own).
std::vector<std::uint8_t> png_colors(const detect_options& o, const ced::point_cloud& cloud,
                                     const ced::detection_result& r) {
  if (o.png_color == "rgb") return {};
  std::vector<float> values;
  double lo = 0, hi = 0;
  if (o.png_color == "height") {
    for (std::size_t i = 0; i < cloud.size(); ++i) values.push_back(cloud.position(i)[2]);
    if (!values.empty()) {
      lo = *std::min_element(values.begin(), values.end());
      hi = *std::max_element(values.begin(), values.end());
    }
  } else {
    const std::size_t m = png_saliency_index(o.png_color.substr(9), r.names);
    values = r.saliency[m];
    // 0 to the 99th percentile (or the threshold, if larger): a few peaks
    // do not wash out the rest.
    std::vector<float> sorted = values;
    const auto at = sorted.begin() + std::ptrdiff_t(sorted.size() * 99 / 100);
    if (!sorted.empty()) std::nth_element(sorted.begin(), at, sorted.end());
    hi = std::max(sorted.empty() ? 0.0 : double(*at), r.thresholds[m]);
  }
  if (!o.quiet) std::fprintf(stderr, "ced: --png-color %s: viridis from %g to %g\n", o.png_color.c_str(), lo, hi);
  return ced::colour_map(values, lo, hi);
}

std::string number(double v) { return ced::detail::number_text(v); }

/// --html: the page's text beside the cloud (the run's parameters and counts).
ced::html_options html_options_of(const detect_options& o, const detect_plan& plan, const detect_input& in,
                                  const ced::detection_result& r) {
  ced::html_options h;
  h.title = "ced: " + std::to_string(r.keypoints.size()) + " keypoints";
  h.source = o.input;
  h.max_points = static_cast<std::size_t>(o.html_max_points);
  h.spacing = plan.resolution;
  h.point_radius = r.point_radius;
  h.info.push_back(
      {"points", std::to_string(in.cloud.size()) + (o.voxel > 0 ? " (voxel " + number(o.voxel) + ")" : "")});
  for (std::size_t m = 0; m < r.names.size(); ++m)
    h.info.push_back({r.names[m], "t = " + number(r.thresholds[m]) + ", " + std::to_string(modality_candidates(r, m)) +
                                      " candidates"});
  h.info.push_back({"radius", number(plan.params.radius) + (plan.auto_radius ? " (auto)" : "")});
  if (!plan.params.neighborhood.fixed()) h.info.push_back({"neighbourhood", ced::to_string(plan.params.neighborhood)});
  if (plan.params.search == ced::search_kind::cgal) h.info.push_back({"search", "CGAL Kd_tree"});
  h.info.push_back({"NMS radius", number(plan.params.nms_radius)});
  h.info.push_back({"min neighbours", std::to_string(plan.params.min_neighbors)});
  if (plan.params.refine) h.info.push_back({"refine", "on"});
  if (plan.params.max_keypoints) h.info.push_back({"max keypoints", std::to_string(plan.params.max_keypoints)});
  if (plan.params.keypoint_share > 0) h.info.push_back({"keypoint share", number(plan.params.keypoint_share)});
  h.info.push_back({"candidates", std::to_string(ced::candidate_count(r))});
  h.info.push_back({"keypoints", std::to_string(r.keypoints.size())});
  char ms[32];
  std::snprintf(ms, sizeof ms, "%.1f ms", r.times.total_ms());
  h.info.push_back({"detect time", ms});
  return h;
}

}  // namespace

void write_file_places(std::ostream& out, const file_places& at) {
  std::string text;
  for (const auto& [f, i] : at) text += std::to_string(f) + ' ' + std::to_string(i) + '\n';
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
}

void add_file_fields(ced::point_cloud& kp, const file_places& at, std::uint64_t points) {
  for (const char* name : {"file_id", "file_index"})
    if (kp.find_field(name))
      throw ced::io::io_error(std::string("-o: the inputs already have a field '") + name +
                              "', which -o writes with several inputs");
  std::vector<double> id, index;
  for (const auto& [f, i] : at) {
    id.push_back(double(f));
    index.push_back(double(i));
  }
  kp.add_field("file_id", ced::scalar_type::uint32, id);
  kp.add_field("file_index", points <= 0xffffffffu ? ced::scalar_type::uint32 : ced::scalar_type::uint64, index);
}

void write_indices(std::ostream& out, const detect_input& in, const ced::detection_result& r) {
  if (in.catalogue) return write_file_places(out, places_of(in, r));
  for (std::uint32_t k : r.keypoints) out << k << '\n';
}

void write_outputs(const detect_options& o, const detect_plan& plan, const detect_input& in,
                   const ced::detection_result& r, detect_outputs& out) {
  const file_places at = in.catalogue ? places_of(in, r) : file_places{};
  if (in.catalogue) {
    if (out.indices) write_file_places(out.indices->stream(), at);
    if (out.original) write_file_places(out.original->stream(), at);
    if (!out.per_file.empty()) out.write_per_file(at);
  } else {
    if (out.indices)
      for (std::uint32_t k : r.keypoints) out.indices->stream() << k << '\n';
    if (out.original)
      for (std::uint32_t k : r.keypoints) out.original->stream() << in.original[k] << '\n';
  }
  if (out.global)
    for (std::uint32_t k : r.keypoints) out.global->stream() << in.original[k] << '\n';
  if (out.keypoints)
    ced::io::write_named(*out.keypoints, [&](std::ostream& s) { write_keypoints(s, in, r, plan.out_format, at); });
  if (out.viewer) ced::io::write_named(*out.viewer, [&](std::ostream& s) { write_viewer(s, in.cloud, r); });
  if (out.png) {
    ced::render_options view = plan.view;
    view.point_colors = png_colors(o, in.cloud, r);
    int w = 0, h = 0;
    auto rgb = ced::render_rgb(in.cloud, r.keypoints, view, w, h);
    if (o.png_top) {  // the view from above, beside
      view.view = ced::view_direction::top;
      int w2 = 0, h2 = 0;
      const auto top = ced::render_rgb(in.cloud, r.keypoints, view, w2, h2);
      rgb = ced::side_by_side(rgb, w, top, w2, h);
      w += w2;
    }
    out.png->stream() << ced::encode_png(rgb, w, h);
  }
  if (out.html)
    out.html->stream() << ced::html_page(in.cloud, r.keypoints, ced::html_layers(r), html_options_of(o, plan, in, r));
  if (out.summary) out.summary->stream() << summary_json(o, plan, in, r).dump(2) << '\n';
  // All or none: every file written out before any lands on its path.
  for (auto& file : out.files) file->finish();
  for (auto& file : out.files) file->commit();
}

void print_report(const detect_options& o, const detect_plan& plan, const detect_input& in,
                  const ced::detection_result& r, clock_type::time_point t_start) {
  const ced::detect_params& params = plan.params;
  std::fprintf(stderr, "ced: %s: %zu points (%s, %.1f ms)\n", o.input.c_str(), in.n_file, in.report.details.c_str(),
               in.load_ms);
  if (in.n_dropped) std::fprintf(stderr, "ced: dropped %zu points with non-finite coordinates\n", in.n_dropped);
  if (o.voxel > 0)
    std::fprintf(stderr, "ced: voxel %g: %zu -> %zu points (%.1f ms)\n", o.voxel, in.n_finite, in.cloud.size(),
                 in.voxel_ms);
  if (plan.auto_radius)
    std::fprintf(stderr, "ced: radius auto = %g x resolution %g = %g\n", o.radius_factor, plan.resolution,
                 params.radius);
  std::string mods;
  for (std::size_t m = 0; m < r.names.size(); ++m)
    mods += (m ? " + " : "") + r.names[m] + " (t=" + number(r.thresholds[m]) + ")";
  const std::string limit = keypoint_limit_text(params);
  std::string how;
  if (!params.neighborhood.fixed()) how += ", neighbourhood " + ced::to_string(params.neighborhood);
  if (params.search == ced::search_kind::cgal) how += ", search cgal";
  std::fprintf(stderr, "ced: modalities %s; radius %g, nms radius %g, min neighbours %u%s%s%s, %u thread(s)\n",
               mods.c_str(), params.radius, params.nms_radius, params.min_neighbors, how.c_str(),
               params.refine ? ", refined" : "", limit.c_str(), ced::resolve_threads(params.threads));
  if (!r.point_radius.empty()) {
    std::vector<float> radii = r.point_radius;
    auto at = [&](double q) {
      const auto k = static_cast<std::ptrdiff_t>(q * double(radii.size() - 1));
      std::nth_element(radii.begin(), radii.begin() + k, radii.end());
      return radii[std::size_t(k)];
    };
    std::fprintf(stderr, "ced: each point's own radius: 5%% %g, median %g, 95%% %g\n", at(0.05), at(0.5), at(0.95));
  }
  std::fprintf(stderr, "ced: %zu keypoints; detect %.1f ms (index %.1f, saliency %.1f, nms %.1f); total %.1f ms\n",
               r.keypoints.size(), r.times.total_ms(), r.times.index_ms, r.times.saliency_ms, r.times.nms_ms,
               ms_since(t_start));
}

}  // namespace ced_cli
