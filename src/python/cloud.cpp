// SPDX-License-Identifier: MIT
// ced.Cloud, ced.read, ced.write, ced.render and the cloud utilities.
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "ced/io/io.hpp"
#include "ced/preprocess.hpp"
#include "ced/render.hpp"

namespace ced_python {
namespace {

py::dict fields_of(const ced::point_cloud& c, py::handle owner) {
  py::dict d;
  for (const auto& f : c.fields()) d[py::str(f.name)] = view(f.values, owner);
  return d;
}

std::string repr(const ced::point_cloud& c) {
  std::string s = "<ced.Cloud: " + std::to_string(c.size()) + " points";
  if (c.origin() != std::array<double, 3>{0, 0, 0})
    s += ", origin (" + py::str(py::make_tuple(c.origin()[0], c.origin()[1], c.origin()[2])).cast<std::string>() + ")";
  s += ", fields [";
  for (std::size_t i = 0; i < c.fields().size(); ++i)
    s += (i ? ", " : "") + c.fields()[i].name + ":" + std::string(ced::name_of(c.fields()[i].type()));
  return s + "]>";
}

/// The points `indices` names, in that order (fields follow).
cloud_ptr select(const ced::point_cloud& c, py::handle indices) {
  const std::vector<std::uint32_t> at = to_indices(indices, "indices", c.size());
  const std::size_t n = at.size();
  auto out = std::make_shared<ced::point_cloud>();
  out->set_origin(c.origin());
  out->resize(n);
  for (std::size_t k = 0; k < n; ++k) std::copy_n(c.position(at[k]), 3, out->positions().data() + 3 * k);
  for (const auto& f : c.fields()) {
    ced::column col(f.type(), n);
    const std::size_t size = ced::size_of(f.type());
    for (std::size_t k = 0; k < n; ++k) std::memcpy(col.bytes() + k * size, f.values.bytes() + at[k] * size, size);
    out->add_field(f.name, std::move(col));
  }
  return out;
}

ced::io::file_format format_arg(const std::optional<std::string>& format) {
  return format ? ced::io::parse_format(*format) : ced::io::file_format::automatic;
}

ced::view_direction parse_view(const std::string& v) {
  if (v == "iso") return ced::view_direction::iso;
  if (v == "top") return ced::view_direction::top;
  if (v == "front") return ced::view_direction::front;
  throw py::value_error("view: expected 'iso', 'top' or 'front', got '" + v + "'");
}

}  // namespace

void bind_cloud(py::module_& m) {
  py::class_<ced::point_cloud, cloud_ptr>(m, "Cloud", "A point cloud: positions and named per-point fields.")
      .def(py::init([](py::handle points, py::handle channels) { return to_cloud(points, channels); }),
           py::arg("points"), py::arg("channels") = py::none(),
           "Builds a cloud from an (N, 3) array and a dict of channels, a structured array, or a Cloud (copied, "
           "channels added).")
      .def("__len__", &ced::point_cloud::size)
      .def_property_readonly(
          "points",
          [](py::object self) {
            const auto& c = self.cast<const ced::point_cloud&>();
            return view(c.positions().data(), {py::ssize_t(c.size()), 3}, self);
          },
          "(N, 3) float32 view of the positions, relative to `origin` (no copy).")
      .def_property_readonly(
          "origin",
          [](const ced::point_cloud& c) { return py::make_tuple(c.origin()[0], c.origin()[1], c.origin()[2]); },
          "The point that positions are relative to (non-zero for georeferenced data).")
      .def(
          "absolute_points",
          [](const ced::point_cloud& c) {
            py::array_t<double> out({py::ssize_t(c.size()), py::ssize_t(3)});
            double* p = out.mutable_data();
            for (std::size_t i = 0; i < 3 * c.size(); ++i) p[i] = c.origin()[i % 3] + double(c.positions()[i]);
            return out;
          },
          "(N, 3) float64 copy of the absolute positions: origin + points.")
      .def_property_readonly(
          "fields", [](py::object self) { return fields_of(self.cast<const ced::point_cloud&>(), self); },
          "Dict name -> (N,) array viewing each field in its own dtype (no copy).")
      .def("select", &select, py::arg("indices"), "A new cloud of the points `indices` names, fields included.")
      .def(py::pickle(  // for multiprocessing and Dask: positions, origin and fields, exactly
          [](const ced::point_cloud& c) {
            py::dict fields;
            for (const auto& f : c.fields()) fields[py::str(f.name)] = view(f.values, py::none()).attr("copy")();
            py::array_t<float> xyz({py::ssize_t(c.size()), py::ssize_t(3)}, c.positions().data());
            return py::make_tuple(xyz, py::make_tuple(c.origin()[0], c.origin()[1], c.origin()[2]), fields);
          },
          [](const py::tuple& state) {
            if (state.size() != 3) throw py::value_error("Cloud: bad pickle state");
            // A foreign or damaged pickle must not read past its arrays.
            const auto xyz = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(state[0]);
            if (!xyz || xyz.ndim() != 2 || xyz.shape(1) != 3)
              throw py::value_error("Cloud: bad pickle state (positions are not an (N, 3) array)");
            const py::tuple origin = py::tuple(py::reinterpret_borrow<py::object>(state[1]));
            if (origin.size() != 3) throw py::value_error("Cloud: bad pickle state (the origin is not 3 numbers)");
            std::array<double, 3> o{};
            for (std::size_t a = 0; a < 3; ++a) {
              o[a] = origin[a].cast<double>();
              if (!std::isfinite(o[a])) throw py::value_error("Cloud: bad pickle state (a non-finite origin)");
            }
            auto c = std::make_shared<ced::point_cloud>();
            c->resize(std::size_t(xyz.shape(0)));
            std::copy_n(xyz.data(), 3 * c->size(), c->positions().data());
            for (std::size_t k = 0; k < 3 * c->size(); ++k)
              if (!std::isfinite(xyz.data()[k]))
                throw py::value_error("Cloud: bad pickle state (a non-finite coordinate)");
            c->set_origin(o);
            add_channels(*c, state[2], "Cloud state");
            return c;
          }))
      .def("__repr__", &repr);

  m.def(
      "read",
      [](py::handle path_obj, std::optional<std::vector<std::string>> fields, std::optional<std::string> format) {
        const std::string path = path_arg(path_obj, "path");
        ced::io::read_options o;
        o.format = format_arg(format);
        if (fields) o.fields = ced::field_selection::only(*fields);
        released_gil release;
        return std::make_shared<ced::point_cloud>(ced::io::read_cloud(path, o));
      },
      py::arg("path"), py::arg("fields") = py::none(), py::arg("format") = py::none(),
      "Reads a PLY, PCD, LAS or CSV file into a Cloud (only `fields` when given).");
  m.def(
      "write",
      [](py::handle path_obj, py::handle cloud, std::optional<std::string> format) {
        const std::string path = path_arg(path_obj, "path");
        const cloud_ptr c = to_cloud(cloud, py::none());
        const auto f = format_arg(format);
        released_gil release;
        ced::io::write_cloud(path, *c, f);
      },
      py::arg("path"), py::arg("cloud"), py::arg("format") = py::none(),
      "Writes a cloud atomically; the format from the extension unless given.");
  m.def(
      "render",
      [](py::handle path_obj, py::handle cloud, std::optional<std::vector<std::uint32_t>> keypoints,
         const std::string& view_name, int width, int height) {
        const std::string path = path_arg(path_obj, "path");
        const cloud_ptr c = to_cloud(cloud, py::none());
        ced::render_options o;
        o.view = parse_view(view_name);
        o.width = width;
        o.height = height;
        const std::vector<std::uint32_t> kp = keypoints.value_or(std::vector<std::uint32_t>{});
        released_gil release;
        ced::render_png(path, *c, kp, o);
      },
      py::arg("path"), py::arg("cloud"), py::arg("keypoints") = py::none(), py::arg("view") = "iso",
      py::arg("width") = 1280, py::arg("height") = 960, "Draws the cloud and its keypoints into a PNG file.");
  m.def(
      "estimate_resolution",
      [](py::handle cloud) {
        const cloud_ptr c = to_cloud(cloud, py::none());
        released_gil release;
        return ced::estimate_resolution(*c);
      },
      py::arg("cloud"), "Median nearest-neighbour distance over up to 20000 evenly spread points.");
  m.def(
      "estimate_normals",
      [](py::handle cloud, double radius, unsigned threads) {
        const cloud_ptr c = to_cloud(cloud, py::none());
        std::vector<float> n;
        {
          released_gil release;
          n = ced::estimate_normals(*c, radius, threads_for(threads));
        }
        py::array_t<float> out({py::ssize_t(c->size()), py::ssize_t(3)});
        std::copy(n.begin(), n.end(), out.mutable_data());
        return out;
      },
      py::arg("cloud"), py::arg("radius"), py::arg("threads") = 0,
      "Unit normals (N x 3) by PCA of the neighbours within `radius`, unoriented; (0, 0, 0) with fewer than 3 "
      "neighbours. What the normals modality uses when the cloud has no nx, ny, nz.");
  m.def(
      "voxel_downsample",
      [](py::handle cloud, double size) {
        const cloud_ptr c = to_cloud(cloud, py::none());
        released_gil release;
        return std::make_shared<ced::point_cloud>(ced::voxel_downsample(*c, size).cloud);
      },
      py::arg("cloud"), py::arg("size"), "Voxel-grid down-sampling as PCL's VoxelGrid (fields averaged).");
}

}  // namespace ced_python
