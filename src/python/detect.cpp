// SPDX-License-Identifier: MIT
// ced.detect and ced.Result: detection without the GIL, interruptible, with
// the result's arrays viewing the C++ result (no copy).
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <future>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "ced/preprocess.hpp"

namespace ced_python {

void set_neighborhood(ced::detect_params& p, const std::string& neighborhood, const std::string& search) {
  try {
    p.neighborhood = ced::parse_neighborhood(neighborhood);
  } catch (const std::invalid_argument& e) {
    throw py::value_error(std::string("neighborhood: ") + e.what());
  }
  try {
    p.search = ced::parse_search_kind(search);
  } catch (const std::invalid_argument& e) {
    throw py::value_error(std::string("search: ") + e.what());
  }
}

namespace {

/// What a cancelled detection throws from its progress callback.
struct cancelled {};

/// A detection result and the parameters it was computed with.
struct result {
  ced::detection_result r;
  double radius = 0, nms_radius = 0;
  std::uint32_t min_neighbors = 0;
  bool refine = false;
  std::size_t max_keypoints = 0;
  double keypoint_share = 0;
};

}  // namespace
}  // namespace ced_python

CED_PYTHON_CHECKED_HOLDER(ced_python::result)

namespace ced_python {
namespace {

/// Unique keys for the modalities (a name given twice gets "#2", ...).
std::vector<std::string> keys(const std::vector<std::string>& names) {
  std::vector<std::string> out;
  for (const auto& n : names) {
    std::string k = n;
    for (int i = 2; std::find(out.begin(), out.end(), k) != out.end(); ++i) k = n + "#" + std::to_string(i);
    out.push_back(k);
  }
  return out;
}

std::string repr(const result& res) {
  const auto& r = res.r;
  const std::size_t candidates = ced::candidate_count(r);
  char head[160];
  std::snprintf(head, sizeof head, "<ced.Result: %zu keypoints, %zu candidates of %zu points; radius %g, nms_radius %g",
                r.keypoints.size(), candidates, r.candidate.size(), res.radius, res.nms_radius);
  std::string s = head;
  const auto k = keys(r.names);
  for (std::size_t m = 0; m < k.size(); ++m) {
    std::size_t reached = 0;
    for (float v : r.saliency[m]) reached += double(v) >= r.thresholds[m];
    char part[96];
    std::snprintf(part, sizeof part, "; %s >= %g at %zu", k[m].c_str(), r.thresholds[m], reached);
    s += part;
  }
  char tail[64];
  std::snprintf(tail, sizeof tail, "; %.1f ms>", r.times.total_ms());
  return s + tail;
}

/// Runs `detect` on a thread of its own while this thread, without the GIL,
/// checks for signals every 20 ms: Ctrl-C cancels the detection (at its next
/// progress report) and raises KeyboardInterrupt.
ced::detection_result run_interruptible(const ced::point_cloud& cloud, ced::detect_params params,
                                        const std::vector<ced::any_modality>& modalities) {
  std::atomic<bool> cancel{false};
  params.progress = [&cancel](double) {
    if (cancel.load(std::memory_order_relaxed)) throw cancelled{};
  };
  std::future<ced::detection_result> job;
  bool interrupted = false;
  {
    released_gil release;
    job = std::async(std::launch::async, [&] { return ced::detect(cloud, params, modalities); });
    while (job.wait_for(std::chrono::milliseconds(20)) != std::future_status::ready) {
      py::gil_scoped_acquire gil;
      if (PyErr_CheckSignals() != 0) {
        interrupted = true;
        break;
      }
    }
    if (interrupted) {
      cancel = true;
      job.wait();
    }
  }
  if (interrupted) {
    try {
      job.get();
    } catch (const cancelled&) {
    } catch (...) {  // the signal's exception wins
    }
    throw py::error_already_set();
  }
  try {
    return job.get();
  } catch (const cancelled&) {
    throw std::logic_error("detection cancelled without a signal");
  }
}

ced::detect_params make_params(const ced::point_cloud& cloud, py::handle radius, double radius_factor,
                               std::optional<double> nms_radius, py::handle min_neighbors, py::handle threads) {
  ced::detect_params p;
  if (py::isinstance<py::str>(radius)) {
    if (radius.cast<std::string>() != "auto")
      throw py::value_error("radius: expected a positive number or 'auto', got '" + radius.cast<std::string>() + "'");
    if (!(radius_factor > 0) || !std::isfinite(radius_factor))
      throw py::value_error("radius_factor: must be a positive number");
    const double res = ced::estimate_resolution(cloud);
    if (!(res > 0))
      throw py::value_error("radius='auto': cannot estimate the resolution (fewer than two distinct points)");
    p.radius = radius_factor * res;
  } else {
    try {
      p.radius = radius.cast<double>();
    } catch (const py::cast_error&) {
      throw py::type_error("radius: expected a number or 'auto', got " +
                           py::str(py::type::of(radius)).cast<std::string>());
    }
  }
  p.nms_radius = nms_radius.value_or(p.radius);
  p.min_neighbors = std::uint32_t(int_arg(min_neighbors, "min_neighbors", UINT32_MAX));
  p.threads = unsigned(int_arg(threads, "threads", 4096));
  ced::validate(p);  // std::invalid_argument -> ValueError, naming the parameter
  return p;
}

/// A spec string or a ced.Modality; nullopt for anything else.
std::optional<ced::any_modality> one_modality(py::handle m) {
  if (py::isinstance<py::str>(m)) return ced::make_modality(m.cast<std::string>());
  if (py::isinstance<ced::any_modality>(m)) return m.cast<ced::any_modality>();
  return std::nullopt;
}

std::vector<ced::any_modality> make_modalities(const ced::point_cloud& cloud, py::handle modalities) {
  if (modalities.is_none()) return ced::preset(cloud.has_rgb() ? "ced6d" : "ced3d");
  if (py::isinstance<py::str>(modalities)) {
    const auto s = modalities.cast<std::string>();
    for (const auto& p : ced::preset_names())
      if (s == p) return ced::preset(s);
  }
  if (auto m = one_modality(modalities)) return {*m};
  std::vector<ced::any_modality> out;
  if (!py::isinstance<py::iterable>(modalities))
    throw py::type_error("modalities: expected a spec string, a ced.Modality or a sequence of them");
  for (auto item : modalities) {
    auto m = one_modality(item);
    if (!m)
      throw py::type_error("modalities: expected spec strings (e.g. 'xyz:0.2') or ced.Modality objects, got " +
                           py::str(py::type::of(item)).cast<std::string>());
    out.push_back(std::move(*m));
  }
  if (out.empty()) throw py::value_error("modalities: the list is empty");
  return out;
}

/// ced.Result.
void bind_result(py::module_& m) {
  py::class_<result, std::shared_ptr<result>>(m, "Result", "What ced.detect found, and why.")
      .def_property_readonly(
          "keypoints", [](py::object self) { return view(self.cast<const result&>().r.keypoints, self); },
          "Keypoint indices into the input, ascending (uint32).")
      .def_property_readonly(
          "rank_score", [](py::object self) { return view(self.cast<const result&>().r.rank_score, self); },
          "(K,) float32, one per keypoint: what max_keypoints ranks it by, its score (the product of its "
          "saliencies), or refined, the highest score of the maxima refined onto it.")
      .def_property_readonly(
          "saliency",
          [](py::object self) {
            const auto& r = self.cast<const result&>().r;
            py::dict d;
            const auto k = keys(r.names);
            for (std::size_t i = 0; i < k.size(); ++i) d[py::str(k[i])] = view(r.saliency[i], self);
            return d;
          },
          "Dict modality name -> (N,) float32 saliency of every point (views, no copy).")
      .def_property_readonly(
          "candidate",
          [](py::object self) {
            const auto& c = self.cast<const result&>().r.candidate;  // 0 or 1: valid bools
            return view(py::dtype("bool"), c.data(), {py::ssize_t(c.size())}, self);
          },
          "(N,) bool: some modality reaches its threshold.")
      .def_property_readonly(
          "neighbor_count", [](py::object self) { return view(self.cast<const result&>().r.neighbor_count, self); },
          "(N,) uint32: neighbours within the radius, the point itself included.")
      .def_property_readonly(
          "point_radius",
          [](py::object self) -> py::object {
            const auto& r = self.cast<const result&>().r.point_radius;
            if (r.empty()) return py::none();
            return view(r, self);
          },
          "(N,) float32: each point's own radius under neighborhood='knn:K' or 'adaptive:...'; None for the "
          "fixed radius.")
      .def_property_readonly(
          "thresholds",
          [](const result& res) {
            py::dict d;
            const auto k = keys(res.r.names);
            for (std::size_t i = 0; i < k.size(); ++i) d[py::str(k[i])] = res.r.thresholds[i];
            return d;
          },
          "Dict modality name -> absolute threshold (xyz: ratio x radius).")
      .def_property_readonly("names", [](const result& res) { return keys(res.r.names); })
      .def_property_readonly(
          "times",
          [](const result& res) {
            py::dict d;
            d["index_ms"] = res.r.times.index_ms;
            d["saliency_ms"] = res.r.times.saliency_ms;
            d["nms_ms"] = res.r.times.nms_ms;
            d["total_ms"] = res.r.times.total_ms();
            return d;
          },
          "Stage times in milliseconds: index_ms, saliency_ms, nms_ms, total_ms.")
      .def_readonly("radius", &result::radius)
      .def_readonly("nms_radius", &result::nms_radius)
      .def_readonly("min_neighbors", &result::min_neighbors)
      .def_readonly("refine", &result::refine, "Whether the keypoints were refined (detect(refine=...)).")
      .def_readonly("max_keypoints", &result::max_keypoints,
                    "The limit on the keypoints' number (detect(max_keypoints=...)); 0: none.")
      .def_readonly("keypoint_share", &result::keypoint_share,
                    "The share of the candidates kept at most as keypoints (detect(keypoint_share=...)); 0: none.")
      .def("__len__", [](const result& res) { return res.r.keypoints.size(); })
      .def("__repr__", &repr);
}

/// ced._detect (ced.detect's work, behind its Python signature).
std::shared_ptr<result> detect_cloud(py::handle points, py::handle channels, py::handle modalities, py::handle radius,
                                     double radius_factor, std::optional<double> nms_radius, py::handle min_neighbors,
                                     py::handle threads, py::handle refine, py::handle max_keypoints,
                                     const std::string& neighborhood, const std::string& search,
                                     py::handle keypoint_share) {
  const cloud_ptr cloud = to_cloud(points, channels);
  if (cloud->empty()) throw py::value_error("points: the cloud is empty");
  ced::detect_params p = make_params(*cloud, radius, radius_factor, nms_radius, min_neighbors, threads);
  set_neighborhood(p, neighborhood, search);
  p.refine = refine_of(modalities, refine);
  p.max_keypoints = std::size_t(int_arg(max_keypoints, "max_keypoints", INT64_MAX));
  p.keypoint_share = keypoint_share_of(modalities, keypoint_share);
  const auto mods = make_modalities(*cloud, modalities);
  auto res = std::make_shared<result>();
  if (python_callbacks_running()) {
    // Called from a python_modality's function (or from a thread it
    // waits for): the outer detection's workers hold the task arena
    // while they wait in Python, so this one runs here, on one thread,
    // outside TBB (bindings.hpp). The result is the same for any
    // thread count; Ctrl-C then stops the outer detection, after it.
    p.threads = 1;
    released_gil release;
    res->r = ced::detect(*cloud, p, mods);
  } else {
    res->r = run_interruptible(*cloud, p, mods);
  }
  res->radius = p.radius;
  res->nms_radius = p.nms_radius;
  res->min_neighbors = p.min_neighbors;
  res->refine = p.refine;
  res->max_keypoints = p.max_keypoints;
  res->keypoint_share = p.keypoint_share;
  return res;
}

}  // namespace

void bind_detect(py::module_& m) {
  bind_result(m);
  m.def("_detect", &detect_cloud, py::arg("points"), py::arg("channels"), py::arg("modalities"), py::arg("radius"),
        py::arg("radius_factor"), py::arg("nms_radius"), py::arg("min_neighbors"), py::arg("threads"),
        py::arg("refine"), py::arg("max_keypoints"), py::arg("neighborhood"), py::arg("search"),
        py::arg("keypoint_share"));
  m.def("release_cached_memory", &ced::release_cached_memory,
        "Frees the up to 32 MiB that detections keep cached for the next one.");
}

}  // namespace ced_python
