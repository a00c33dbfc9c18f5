// SPDX-License-Identifier: MIT
// ced.Modality: built-in and registered modalities from specs, presets,
// plugins, and modalities written in Python.
#include <dlfcn.h>
#include <pybind11/stl.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "bindings.hpp"
#include "ced/modalities/builtin.hpp"
#include "ced/plugin.hpp"

namespace ced_python {
namespace {

/// Python modalities' functions running now, on any thread (see
/// python_callbacks_running()).
std::atomic<int> callbacks_running{0};

struct callback_scope {
  callback_scope() noexcept { callbacks_running.fetch_add(1); }
  ~callback_scope() { callbacks_running.fetch_sub(1); }
  callback_scope(const callback_scope&) = delete;
  callback_scope& operator=(const callback_scope&) = delete;
};

/// A modality whose saliency a Python callable computes, for prototyping:
/// per block, fn(points, offsets, neighbors) -> (B,) saliencies, where the
/// neighbours of points[k] are neighbors[offsets[k]:offsets[k+1]]; or, with
/// per_point, fn(point, neighbors) -> saliency. Runs under the GIL (one
/// block at a time), so it is much slower than a C++ modality. Saliencies
/// must be finite and >= 0 (the Modality contract) and fit a float; any
/// other value of a point the detector uses is a ValueError naming it.
struct python_modality {
  std::string label;
  double threshold_value;
  py::object fn;  // copied and destroyed only under the GIL (by the binding)
  bool per_point;

  std::string name() const { return label; }
  double threshold(const ced::detect_params&) const { return threshold_value; }
  std::vector<std::string> fields() const { return {}; }

  struct evaluator {
    PyObject* fn;  // borrowed: the modality outlives the detection
    bool per_point;
    std::uint32_t min_neighbors;  // points with fewer get 0 whatever fn says
    const std::string* label;
    void evaluate(const ced::block_view& block, float* out) const;
    /// `v` as point `point`'s saliency, or a ValueError naming both.
    float saliency(double v, std::uint32_t point) const;
  };
  evaluator bind(const ced::point_cloud&, const ced::detect_params& params) const {
    return {fn.ptr(), per_point, params.min_neighbors, &label};
  }
};

float python_modality::evaluator::saliency(double v, std::uint32_t point) const {
  if (std::isfinite(v) && v >= 0 && v <= double(std::numeric_limits<float>::max())) return static_cast<float>(v);
  throw py::value_error("Python modality '" + *label + "': the function gave " +
                        py::repr(py::float_(v)).cast<std::string>() + " for point " + std::to_string(point) +
                        " (saliencies must be finite and >= 0, and fit a float32)");
}

void python_modality::evaluator::evaluate(const ced::block_view& block, float* out) const {
  py::gil_scoped_acquire gil;
  const callback_scope running;
  const auto callable = py::reinterpret_borrow<py::object>(fn);
  const std::size_t n = block.size();
  if (per_point) {
    for (std::size_t k = 0; k < n; ++k) {
      const ced::neighborhood nb = block[k];
      py::array_t<std::uint32_t> neighbors(py::ssize_t(nb.size), nb.indices);
      const py::object s = callable(nb.point, neighbors);
      double v = 0;
      try {
        v = s.cast<double>();
      } catch (const py::cast_error&) {
        throw py::type_error("Python modality '" + *label + "': fn(point, neighbors) must return a number, got " +
                             py::str(py::type::of(s)).cast<std::string>());
      }
      out[k] = block.count(k) >= min_neighbors ? saliency(v, nb.point) : 0.0f;
    }
    return;
  }
  py::array_t<std::uint32_t> points(py::ssize_t{static_cast<py::ssize_t>(n)});
  py::array_t<std::int64_t> offsets(py::ssize_t(n + 1));
  std::vector<std::uint32_t> all;
  auto* o = offsets.mutable_data();
  o[0] = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const ced::neighborhood nb = block[k];
    points.mutable_data()[k] = nb.point;
    all.insert(all.end(), nb.begin(), nb.end());
    o[k + 1] = std::int64_t(all.size());
  }
  py::array_t<std::uint32_t> neighbors(py::ssize_t(all.size()), all.data());
  // float64, so that a value beyond float32's range is named, not made infinite.
  const auto result = py::array_t<double, py::array::forcecast>::ensure(callable(points, offsets, neighbors));
  if (!result || result.ndim() != 1 || std::size_t(result.shape(0)) != n)
    throw py::value_error("Python modality '" + *label + "': the function must return " + std::to_string(n) +
                          " saliencies (one per point of the block), as an array of shape (" + std::to_string(n) +
                          ",)");
  for (std::size_t k = 0; k < n; ++k)
    out[k] = block.count(k) >= min_neighbors ? saliency(result.at(py::ssize_t(k)), block.point(k)) : 0.0f;
}

/// Lets plugins loaded later resolve ced's symbols in this module: Python
/// loads extension modules with RTLD_LOCAL, so promote this one to global.
void export_symbols_to_plugins() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&export_symbols_to_plugins), &info) && info.dli_fname)
    dlopen(info.dli_fname, RTLD_NOW | RTLD_NOLOAD | RTLD_GLOBAL);
}

}  // namespace

bool python_callbacks_running() { return callbacks_running.load() > 0; }

unsigned threads_for(unsigned threads) { return python_callbacks_running() ? 1u : threads; }

void bind_modalities(py::module_& m) {
  py::class_<ced::any_modality>(m, "Modality", "A modality: a channel and its saliency measure.")
      .def(py::init([](const std::string& spec) { return ced::make_modality(spec); }), py::arg("spec"),
           "A modality from a spec string, the CLI's grammar: 'xyz:0.2', 'bands(nir,red):0.1,range=0..255'.")
      .def_property_readonly("name", &ced::any_modality::name)
      .def_property_readonly("fields", &ced::any_modality::fields,
                             "The fields it reads (None: it does not say; [] positions only).")
      .def(
          "threshold",
          [](const ced::any_modality& mod, double radius) {
            ced::detect_params p;
            p.radius = radius;
            return mod.threshold(p);
          },
          py::arg("radius") = 0.05, "The absolute threshold at `radius` (xyz: ratio x radius).")
      .def("__repr__", [](const ced::any_modality& mod) { return "<ced.Modality " + mod.name() + ">"; });

  m.def(
      "python_modality",
      [](std::string name, py::function fn, double threshold, bool per_point) {
        if (name.empty()) throw py::value_error("name: must not be empty");
        if (!std::isfinite(threshold) || threshold < 0)
          throw py::value_error("threshold: must be a finite number >= 0, got " +
                                py::repr(py::float_(threshold)).cast<std::string>());
        return ced::any_modality(python_modality{std::move(name), threshold, std::move(fn), per_point});
      },
      py::arg("name"), py::arg("fn"), py::arg("threshold"), py::arg("per_point") = false,
      "A modality whose saliency a Python function computes (slow; for prototyping). By block: "
      "fn(points, offsets, neighbors) -> saliencies, neighbours of points[k] in "
      "neighbors[offsets[k]:offsets[k+1]]; with per_point=True: fn(point, neighbors) -> float. Saliencies must be "
      "finite and >= 0 (else ValueError naming the point). fn may call ced.detect: that detection then runs on "
      "its thread, single-threaded.");
  m.def(
      "preset_names", [] { return ced::preset_names(); },
      "The presets' names: ced3d, ced6d, robust3d, robust6d, corner3d.");
  m.def(
      "preset", [](const std::string& name) { return ced::preset(name); }, py::arg("name"),
      "The modalities of a preset: 'ced3d' (xyz:0.2), 'ced6d' (xyz:0.2, rgb:0.1), 'robust3d' "
      "(xyz:0.2,scale=2), "
      "'robust6d' (xyz:0.2,scale=2.25,inner=1, rgb:0.5) or 'corner3d' (corner:0.05, corner:0.05,scale=1.5). The robust "
      "presets and "
      "corner3d also refine their keypoints (preset_refines).");
  m.def("preset_refines", &ced::preset_refines, py::arg("name"),
        "Whether a preset refines its keypoints (detect(refine=...)): the robust presets and corner3d do, ced3d and "
        "ced6d not.");
  m.def("preset_keypoint_share", &ced::preset_keypoint_share, py::arg("name"),
        "The share of the candidates a preset keeps at most as keypoints (detect(keypoint_share=...)): 0.01 for "
        "robust3d and robust6d, whose counts would otherwise grow with noise; 0 (no limit) for the others.");
  m.def("_split_modality_specs", &ced::split_modality_specs, py::arg("text"),
        "Modality specs joined by commas, split as `ced eval --detector` splits them.");
  m.def("modalities", &ced::registered_modalities, "(name, help) of every registered modality, sorted.");
  m.def(
      "_builtin_modalities",
      [] {
        std::vector<std::pair<std::string, std::string>> out;
        ced::builtin_modalities::for_each([&](auto* type) {
          using M = std::remove_pointer_t<decltype(type)>;
          out.emplace_back(M::spec_name, M::spec_help);
        });
        return out;
      },
      "(name, help) of each built-in modality (ced/modalities/builtin.hpp), in its order.");
  m.def(
      "load_plugin",
      [](py::handle path) {
        export_symbols_to_plugins();
        const ced::plugin_info info = ced::load_plugin(path_arg(path, "path"));
        return info.modalities;
      },
      py::arg("path"),
      "Loads a plugin (a shared library built with ced_add_plugin) and returns the modalities it added.");
}

}  // namespace ced_python
