// SPDX-License-Identifier: MIT
// Clouds larger than memory from Python: ced.plan_tiles, ced.detect_tile,
// ced.merge_parts (ced/tiled.hpp), for Dask, multiprocessing or any scheduler.
#include "ced/tiled.hpp"

#include <pybind11/stl.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "ced/io/output_file.hpp"

namespace ced_python {
namespace {

using plan_ptr = std::shared_ptr<ced::tile_plan>;
using part_ptr = std::shared_ptr<ced::tile_part>;

plan_ptr plan_from_json(const std::string& text, const std::string& name) {
  return std::make_shared<ced::tile_plan>(ced::tile_plan::from_json(text, name));
}

template <class T>
py::array_t<T> copy_array(const std::vector<T>& v) {
  py::array_t<T> a(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

/// Modality specs from a preset name, a spec string or a list of specs.
std::vector<std::string> specs_of(py::handle modalities) {
  if (modalities.is_none()) return {};
  if (py::isinstance<py::str>(modalities)) {
    const std::string s = modalities.cast<std::string>();
    for (const auto& p : ced::preset_names())
      if (s == p) return ced::preset_specs(s);
    return ced::split_modality_specs(s);
  }
  std::vector<std::string> out;
  for (py::handle h : modalities) {
    if (!py::isinstance<py::str>(h))
      throw py::type_error(
          "modalities: a plan is written as JSON, so its modalities are spec strings ('xyz:0.2') or a preset name, "
          "got " +
          std::string(py::str(py::type::of(h).attr("__name__"))));
    out.push_back(h.cast<std::string>());
  }
  return out;
}

/// A number (int, float, a numpy scalar; not bool or str) as a double, or a
/// TypeError naming `name`. An int too large for a double is infinite.
double number_arg(py::handle obj, const std::string& name, const std::string& expected) {
  if (!py::isinstance<py::bool_>(obj) && !py::isinstance<py::str>(obj) && !py::isinstance<py::bytes>(obj)) {
    const double v = PyFloat_AsDouble(obj.ptr());
    if (!(v == -1.0 && PyErr_Occurred())) return v;
    const bool overflow = PyErr_ExceptionMatches(PyExc_OverflowError);
    PyErr_Clear();
    if (overflow)
      return py::reinterpret_borrow<py::object>(obj) > py::int_(0) ? std::numeric_limits<double>::infinity()
                                                                   : -std::numeric_limits<double>::infinity();
  }
  throw py::type_error(name + ": expected " + expected + ", got " + type_name(obj));
}

/// A positive finite number, or a TypeError / ValueError naming `name`.
double positive_arg(py::handle obj, const std::string& name, const std::string& unit) {
  const double v = number_arg(obj, name, "a number");
  if (!(v > 0) || !std::isfinite(v))
    throw py::value_error(name + ": must be a positive number" + unit + ", got " + py::str(obj).cast<std::string>());
  return v;
}

/// Refuses to write `what` at `path` when that is the plan's input file
/// (however spelled: links, "..") with a ValueError naming both: nothing
/// ced writes may destroy what it reads.
void check_not_input(const ced::tile_plan& plan, const std::string& what, const std::string& path) {
  ced::io::check_outputs_distinct({{"the plan's input", plan.request.input}}, {{what, path}});
}

}  // namespace

bool refine_of(py::handle modalities, py::handle refine) {
  if (!refine.is_none()) {
    if (!py::isinstance<py::bool_>(refine))
      throw py::type_error("refine: expected True, False or None, got " +
                           py::str(py::type::of(refine).attr("__name__")).cast<std::string>());
    return refine.cast<bool>();
  }
  if (!py::isinstance<py::str>(modalities)) return false;
  const std::string s = modalities.cast<std::string>();
  for (const auto& p : ced::preset_names())
    if (s == p) return ced::preset_refines(s);
  return false;
}

double keypoint_share_of(py::handle modalities, py::handle share) {
  if (!share.is_none()) {
    if (py::isinstance<py::bool_>(share) || !(py::isinstance<py::int_>(share) || py::isinstance<py::float_>(share)))
      throw py::type_error("keypoint_share: expected a number from 0 to 1 or None, got " +
                           py::str(py::type::of(share).attr("__name__")).cast<std::string>());
    const double v = share.cast<double>();
    if (!(v >= 0 && v <= 1))
      throw py::value_error("keypoint_share: must be a share from 0 to 1 (0: no limit), got " +
                            py::str(share).cast<std::string>());
    return v;
  }
  if (!py::isinstance<py::str>(modalities)) return 0;
  const std::string s = modalities.cast<std::string>();
  for (const auto& p : ced::preset_names())
    if (s == p) return ced::preset_keypoint_share(s);
  return 0;
}

void bind_tiled(py::module_& m) {
  py::class_<ced::tile_plan, plan_ptr>(m, "TilePlan",
                                       "The tiles of a cloud file: what ced.detect_tile runs and ced.merge_parts "
                                       "merges (the same plan as `ced plan`).")
      .def_static(
          "from_json", [](const std::string& text) { return plan_from_json(text, "<json>"); }, py::arg("text"))
      .def_static(
          "load",
          [](py::handle path) {
            return std::make_shared<ced::tile_plan>(ced::tile_plan::load(path_arg(path, "path")));
          },
          py::arg("path"), "Reads a plan written by `ced plan` or TilePlan.save.")
      .def("to_json", &ced::tile_plan::to_json)
      .def(
          "save",
          [](const ced::tile_plan& p, const py::object& path) {
            const std::string file = path_arg(path, "path");
            check_not_input(p, "path", file);
            ced::io::write_text_file_atomic(file, p.to_json());
          },
          py::arg("path"), "Writes the plan as JSON (atomically); never over the plan's input.")
      .def_property_readonly("input", [](const ced::tile_plan& p) { return p.request.input; })
      .def_property_readonly("modalities", [](const ced::tile_plan& p) { return p.request.modalities; })
      .def_property_readonly("radius", [](const ced::tile_plan& p) { return p.request.params.radius; })
      .def_property_readonly(
          "neighborhood", [](const ced::tile_plan& p) { return ced::to_string(p.request.params.neighborhood); },
          "The tiles' neighbourhood spec, with the reach they take ('knn:16,reach=0.43').")
      .def_property_readonly(
          "reach_estimated", [](const ced::tile_plan& p) { return p.request.reach_estimated; },
          "True when the neighbourhood's reach= is ced's estimate from the cloud's density (knn:K, or "
          "adaptive:K without max, planned without reach=)")
      .def_property_readonly("tile_size", [](const ced::tile_plan& p) { return p.grid.size; })
      .def_property_readonly("halo", [](const ced::tile_plan& p) { return p.grid.halo; })
      .def_property_readonly("points", [](const ced::tile_plan& p) { return p.file_points; })
      .def_property_readonly("digest", &ced::tile_plan::digest)
      .def_property_readonly(
          "indexed", [](const ced::tile_plan& p) { return p.indexed; },
          "True when planned from the file's COPC index, or a catalogue's headers, without a pass over the "
          "points (tile counts are estimates)")
      .def_property_readonly(
          "tiles",
          [](const ced::tile_plan& p) {
            py::list out;
            for (const auto& t : p.tiles) out.append(py::make_tuple(t.id, t.core_points, t.points));
            return out;
          },
          "(id, points owned, points read) of every tile that owns points, ascending id.")
      .def("__repr__",
           [](const ced::tile_plan& p) {
             return "<ced.TilePlan " + p.request.input + ": " + std::to_string(p.tiles.size()) + " tiles of " +
                    std::to_string(p.grid.size) + ", " + std::to_string(p.file_points) + " points>";
           })
      .def(py::pickle([](const ced::tile_plan& p) -> py::object { return py::str(p.to_json()); },
                      [](const py::object& state) {  // validated as any plan file: a FileError naming <pickle>
                        if (!py::isinstance<py::str>(state))
                          throw py::type_error("TilePlan: the pickled state must be the plan's JSON text, got " +
                                               type_name(state));
                        return plan_from_json(state.cast<std::string>(), "<pickle>");
                      }));

  py::class_<ced::tile_part, part_ptr>(m, "TilePart",
                                       "The keypoints one tile contributes (or, merged, the whole cloud's).")
      .def_readonly("tile", &ced::tile_part::tile)
      .def_property_readonly(
          "keypoints", [](const ced::tile_part& p) { return copy_array(p.index); },
          "Indices into the file's finite points, ascending (uint64).")
      .def_property_readonly(
          "file_indices", [](const ced::tile_part& p) { return copy_array(p.file_index); },
          "Indices into all the file's points (uint64).")
      .def_property_readonly(
          "cloud", [](const ced::tile_part& p) { return std::make_shared<ced::point_cloud>(p.keypoints); },
          "The keypoints with their fields, as a ced.Cloud.")
      .def_property_readonly("saliency",
                             [](const ced::tile_part& p) {
                               py::dict d;
                               for (std::size_t k = 0; k < p.names.size(); ++k)
                                 d[py::str(p.names[k])] = copy_array(p.saliency[k]);
                               return d;
                             })
      .def_property_readonly(
          "rank", [](const ced::tile_part& p) { return copy_array(p.rank); },
          "What each keypoint ranks by when the merge keeps the strongest (float32; Result.rank_score).")
      .def_property_readonly("thresholds",
                             [](const ced::tile_part& p) {
                               py::dict d;
                               for (std::size_t k = 0; k < p.names.size(); ++k)
                                 d[py::str(p.names[k])] = p.thresholds[k];
                               return d;
                             })
      .def_readonly("detect_ms", &ced::tile_part::detect_ms)
      .def(
          "write",
          [](const ced::tile_part& p, const ced::tile_plan& plan, const py::object& path) {
            const std::string file = path_arg(path, "path");
            check_not_input(plan, "path", file);
            released_gil release;
            try {
              ced::write_part(file, plan, p);  // refuses a part of another plan
            } catch (const std::invalid_argument& e) {
              throw py::value_error(std::string("TilePart.write: ") + e.what());
            }
          },
          py::arg("plan"), py::arg("path"),
          "Writes the part for ced.merge_parts or `ced merge` (atomically); `plan` must be its own, and `path` not "
          "the plan's input.")
      .def("__repr__", [](const ced::tile_part& p) {
        return "<ced.TilePart tile " + std::to_string(p.tile) + ": " + std::to_string(p.index.size()) + " keypoints>";
      });

  m.def(
      "plan_tiles",
      [](py::handle input_path, py::object tile_size, py::object memory_limit, py::object modalities, py::object radius,
         py::object nms_radius, py::object min_neighbors, const std::string& format, py::object refine,
         py::object max_keypoints, bool scan, const std::string& neighborhood, const std::string& search,
         py::object keypoint_share) {
        ced::tiled_request r;
        set_neighborhood(r.params, neighborhood, search);
        r.input = path_arg(input_path, "input");
        r.scan = scan;
        r.read.format = ced::io::parse_format(format);
        r.params.radius = positive_arg(radius, "radius", "");
        r.params.nms_radius = nms_radius.is_none() ? r.params.radius : positive_arg(nms_radius, "nms_radius", "");
        r.params.min_neighbors = std::uint32_t(int_arg(min_neighbors, "min_neighbors", UINT32_MAX));
        modalities = py::module_::import("ced").attr("_preset_of")(modalities);  // ced.preset()'s list: the preset
        r.modalities = specs_of(modalities);
        r.params.refine = refine_of(modalities, refine);
        r.params.max_keypoints = std::size_t(int_arg(max_keypoints, "max_keypoints", UINT32_MAX));
        r.params.keypoint_share = keypoint_share_of(modalities, keypoint_share);
        if (tile_size.is_none() && memory_limit.is_none())
          throw py::value_error("give tile_size (metres) or memory_limit (bytes)");
        if (!tile_size.is_none() && !memory_limit.is_none())
          throw py::value_error("give tile_size or memory_limit, not both");
        if (!tile_size.is_none()) r.tile_size = positive_arg(tile_size, "tile_size", " of metres");
        if (!memory_limit.is_none()) {
          // Checked before the conversion: a double beyond uint64's range
          // (1e30, inf, nan) does not convert (undefined behaviour).
          const double v = number_arg(memory_limit, "memory_limit", "a number of bytes");
          if (!(v >= 1 && v <= 1e18))
            throw py::value_error("memory_limit: must be 1 .. 1e18 bytes, got " +
                                  py::str(memory_limit).cast<std::string>());
          r.memory_limit = static_cast<std::uint64_t>(v);
        }
        try {
          released_gil release;
          return std::make_shared<ced::tile_plan>(ced::plan_tiles(r));
        } catch (const std::invalid_argument& e) {
          // The core names the CLI's option; here it is the argument.
          const std::string what = e.what(), option = "--memory-limit ";
          if (what.compare(0, option.size(), option) == 0)
            throw py::value_error("memory_limit: " + what.substr(option.size()));
          throw;
        }
      },
      py::arg("input"), py::arg("tile_size") = py::none(), py::arg("memory_limit") = py::none(),
      py::arg("modalities") = py::none(), py::arg("radius") = 0.05, py::arg("nms_radius") = py::none(),
      py::arg("min_neighbors") = 5, py::arg("format") = "auto", py::arg("refine") = py::none(),
      py::arg("max_keypoints") = 0, py::arg("scan") = false, py::arg("neighborhood") = "radius",
      py::arg("search") = "grid", py::arg("keypoint_share") = py::none(),
      "Plans the tiles of a cloud file (two passes over it), as `ced plan`. A COPC file is planned from its "
      "index and header without a pass over the points (plan.indexed), unless scan=True or memory_limit is "
      "given; so is a folder or @LIST of LAS, LAZ and COPC files, from their headers, when its tiles are large "
      "against the files (docs/CLI.md). modalities: spec strings or a preset "
      "name (default: ced6d when the file has colour, else ced3d). refine: keypoint refinement (None: the "
      "preset's, on for robust3d, robust6d, corner3d). max_keypoints: the merge keeps the strongest of all tiles' "
      "keypoints, as detect(max_keypoints=...) (0: no limit); keypoint_share likewise (None: the preset's, 0.01 "
      "for robust3d and robust6d). neighborhood, search: as detect()'s. Under "
      "'knn:K,reach=R' or 'adaptive:K,...,reach=R' each tile checks the reach, detect_tile raising RuntimeError "
      "(naming the reach the tile needs) when a point reaches farther; without reach= (and, for adaptive, "
      "max=) the plan estimates one from the cloud's density (plan.reach_estimated, plan.neighborhood): a "
      "tile that finds it short raises the same error, and a new plan with the reach it names runs.");
  m.def(
      "detect_tile",
      [](const ced::tile_plan& plan, const py::object& tile_arg, const py::object& part,
         const py::object& threads_arg) {
        const std::uint64_t tile = int_arg(tile_arg, "tile", UINT64_MAX);
        const auto threads = unsigned(int_arg(threads_arg, "threads", 4096, "0 (all cores) .. 4096"));
        const std::string path = part.is_none() ? std::string() : path_arg(part, "part");
        if (!path.empty()) check_not_input(plan, "part", path);  // before any work
        std::shared_ptr<ced::tile_part> out;
        {
          released_gil release;
          const ced::tile_points pts = ced::read_tile(plan, tile);
          out = std::make_shared<ced::tile_part>(ced::detect_tile(plan, pts, threads_for(threads)));
          if (!path.empty()) ced::write_part(path, plan, *out);
        }
        return out;
      },
      py::arg("plan"), py::arg("tile"), py::arg("part") = py::none(), py::arg("threads") = 0,
      "Reads tile `tile` of the plan's input (one pass over LAS/LAZ, two over other formats), detects it, writes its "
      "part to `part` when "
      "given, and returns it. Any process that can read the file can run it.");
  m.def(
      "read_part",
      [](const ced::tile_plan& plan, py::handle path) { return ced::read_part(path_arg(path, "path"), plan); },
      py::arg("plan"), py::arg("path"));
  m.def(
      "merge_parts",
      [](const ced::tile_plan& plan, py::iterable parts) {
        std::vector<ced::tile_part> all;
        for (py::handle h : parts) {
          if (py::isinstance<py::str>(h) || py::hasattr(h, "__fspath__"))
            all.push_back(ced::read_part(path_arg(h, "parts"), plan));
          else if (py::isinstance<ced::tile_part>(h))
            all.push_back(h.cast<const ced::tile_part&>());
          else
            throw py::type_error("parts: expected ced.TilePart objects or paths of part files, got " + type_name(h));
        }
        released_gil release;
        return std::make_shared<ced::tile_part>(ced::merge_parts(plan, std::move(all)));
      },
      py::arg("plan"), py::arg("parts"),
      "Merges every tile's part (ced.TilePart objects or paths of part files) into the whole cloud's keypoints: "
      "exactly those of a whole-cloud detection. A missing or repeated tile is a ced.FileError.");
}

}  // namespace ced_python
