// SPDX-License-Identifier: MIT
// numpy arrays in: positions, channels and structured arrays to a point_cloud.
#include <pybind11/stl.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "bindings.hpp"

namespace ced_python {
namespace {

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

std::string dtype_text(const py::array& a) { return py::str(a.dtype()).cast<std::string>(); }

/// `obj` as a numpy array (no copy when it is one already).
py::array as_array(py::handle obj, const std::string& argument) {
  if (py::isinstance<py::array>(obj)) return py::reinterpret_borrow<py::array>(obj);
  try {
    return py::module_::import("numpy").attr("asarray")(obj);
  } catch (py::error_already_set&) {
    throw py::type_error(argument + ": expected an array, got " + py::str(py::type::of(obj)).cast<std::string>());
  }
}

/// `a` in the machine's byte order (a converted copy when it is big-endian).
py::array native_order(const py::array& a) {
  if (a.dtype().attr("byteorder").cast<std::string>() != ">") return a;
  return a.attr("astype")(a.dtype().attr("newbyteorder")("="));
}

/// The storage type of a numpy dtype, or throws naming `argument`. bool,
/// float16 and big-endian arrays are converted first (`a` then holds the copy).
ced::scalar_type storage_type(py::array& a, const std::string& argument) {
  if (a.dtype().kind() == 'b') a = a.attr("astype")("uint8");
  if (a.dtype().kind() == 'f' && a.dtype().itemsize() == 2) a = a.attr("astype")("float32");
  a = native_order(a);
  const py::dtype dt = a.dtype();
  const char k = dt.kind();
  const auto size = dt.itemsize();
  using ced::scalar_type;
  if (k == 'f' && size == 4) return scalar_type::float32;
  if (k == 'f' && size == 8) return scalar_type::float64;
  if (k == 'u' || k == 'i') {
    switch (size) {
      case 1:
        return k == 'u' ? scalar_type::uint8 : scalar_type::int8;
      case 2:
        return k == 'u' ? scalar_type::uint16 : scalar_type::int16;
      case 4:
        return k == 'u' ? scalar_type::uint32 : scalar_type::int32;
      case 8:
        return k == 'u' ? scalar_type::uint64 : scalar_type::int64;
      default:
        break;
    }
  }
  throw py::type_error(argument + ": expected a numeric array (integers, float32 or float64), got dtype " +
                       dtype_text(a));
}

/// Keeps a Python object alive for as long as a C++ owner lives, on any thread.
std::shared_ptr<const void> keep_alive(py::handle obj) {
  PyObject* o = obj.inc_ref().ptr();
  return std::shared_ptr<const void>(o, [](const void* p) {
    py::gil_scoped_acquire gil;
    Py_DECREF(static_cast<PyObject*>(const_cast<void*>(p)));
  });
}

/// Column `j` of a 1-D or 2-D array (rows strided by strides(0), columns by
/// strides(1)) as a typed column: a view of the array (no copy) when its
/// values are contiguous and aligned, else a copy.
ced::column to_column(const py::array& a, ced::scalar_type type, py::ssize_t j) {
  const auto n = static_cast<std::size_t>(a.shape(0));
  const auto* base = static_cast<const char*>(a.data()) + (a.ndim() == 2 ? j * a.strides(1) : 0);
  const py::ssize_t stride = a.strides(0);
  const std::size_t size = ced::size_of(type);
  if ((stride == py::ssize_t(size) || n <= 1) && reinterpret_cast<std::uintptr_t>(base) % size == 0)
    return ced::column::view(type, base, n, keep_alive(a));
  return ced::copy_strided(type, base, stride, n);
}

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

void add_channel(ced::point_cloud& cloud, const std::string& name, py::handle value, const std::string& argument) {
  py::array a = as_array(value, argument);
  if (a.ndim() != 1 && a.ndim() != 2)
    throw py::value_error(argument + ": expected an (N,) or (N, k) array, got shape " + shape_text(a));
  if (std::size_t(a.shape(0)) != cloud.size())
    throw py::value_error(argument + ": " + std::to_string(a.shape(0)) + " values, but there are " +
                          std::to_string(cloud.size()) + " points");
  const ced::scalar_type type = storage_type(a, argument);
  const py::ssize_t k = a.ndim() == 2 ? a.shape(1) : 1;
  const auto names = ced::channel_field_names(cloud, name, std::size_t(k), argument);
  for (py::ssize_t j = 0; j < k; ++j) cloud.add_field(names[std::size_t(j)], to_column(a, type, j));
}

void positions_from(ced::point_cloud& cloud, const py::array& a, const char* x, const char* y, const char* z,
                    py::ssize_t stride, const std::string& argument) {
  const bool single = a.dtype().kind() == 'f' && a.dtype().itemsize() == 4;
  ced::set_positions(cloud, single ? ced::scalar_type::float32 : ced::scalar_type::float64, x, y, z, stride,
                     static_cast<std::size_t>(a.shape(0)), argument);
}

/// An (N, 3) array of float32 or float64, any strides.
ced::point_cloud cloud_from_points(py::handle points) {
  py::array a = as_array(points, "points");
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error("points: expected an (N, 3) array, got shape " + shape_text(a));
  const char k = a.dtype().kind();
  const auto size = a.dtype().itemsize();
  if (k != 'f' || (size != 4 && size != 8))
    throw py::type_error("points: expected float32 or float64 coordinates, got dtype " + dtype_text(a));
  a = native_order(a);
  ced::point_cloud cloud;
  const auto* base = static_cast<const char*>(a.data());
  positions_from(cloud, a, base, base + a.strides(1), base + 2 * a.strides(1), a.strides(0), "points");
  return cloud;
}

/// A structured array: X, Y, Z (any case) are the positions, every other
/// numeric field a channel.
ced::point_cloud cloud_from_structured(const py::array& a) {
  if (a.ndim() != 1) throw py::value_error("points: expected a 1-D structured array, got shape " + shape_text(a));
  const auto names = a.dtype().attr("names").cast<std::vector<std::string>>();
  std::string xyz[3];
  for (const auto& name : names)
    for (int d = 0; d < 3; ++d)
      if (lower(name) == std::string(1, "xyz"[d])) {
        if (!xyz[d].empty())
          throw py::value_error("points: the fields '" + xyz[d] + "' and '" + name + "' both name the " +
                                std::string(1, "xyz"[d]) + " coordinate");
        xyz[d] = name;
      }
  for (int d = 0; d < 3; ++d)
    if (xyz[d].empty())
      throw py::value_error(std::string("points: the structured array has no ") + "XYZ"[d] +
                            " field (fields: " + py::str(a.dtype().attr("names")).cast<std::string>() + ")");
  const py::dict fields = a.dtype().attr("fields");
  py::array col[3];
  for (int d = 0; d < 3; ++d) {
    const std::string argument = "points['" + xyz[d] + "']";
    // A subarray field ('X', 'f8', (2,)) would be read as one interleaved column.
    const py::dtype field = py::reinterpret_borrow<py::tuple>(fields[py::str(xyz[d])])[0].cast<py::dtype>();
    if (py::len(field.attr("shape")) != 0)
      throw py::value_error(argument +
                            ": a coordinate is one number per point, but this is a subarray field of shape " +
                            py::str(field.attr("shape")).cast<std::string>());
    const char k = field.kind();
    if (k != 'f' && k != 'i' && k != 'u')
      throw py::type_error(argument + ": expected a numeric coordinate field (integers or floats), got dtype " +
                           py::str(py::handle(field)).cast<std::string>());
    col[d] = py::array(a[py::str(xyz[d])]).attr("astype")("float64");  // coordinates: float, int or scaled
  }
  ced::point_cloud cloud;
  const auto* x = static_cast<const char*>(col[0].data());
  const auto* y = static_cast<const char*>(col[1].data());
  const auto* z = static_cast<const char*>(col[2].data());
  positions_from(cloud, col[0], x, y, z, sizeof(double), "points");
  for (const auto& name : names) {
    if (name == xyz[0] || name == xyz[1] || name == xyz[2]) continue;
    add_channel(cloud, name, a[py::str(name)], "points['" + name + "']");
  }
  return cloud;
}

}  // namespace

void add_channels(ced::point_cloud& cloud, py::handle channels, const char* argument) {
  if (channels.is_none()) return;
  if (py::isinstance<py::array>(channels) && !channels.attr("dtype").attr("names").is_none()) {
    // A structured array (PDAL's): every field but X, Y, Z is a channel.
    const auto a = py::reinterpret_borrow<py::array>(channels);
    for (const auto& name : a.dtype().attr("names").cast<std::vector<std::string>>()) {
      const std::string l = lower(name);
      if (l == "x" || l == "y" || l == "z") continue;
      add_channel(cloud, name, a[py::str(name)], std::string(argument) + "['" + name + "']");
    }
    return;
  }
  if (!py::isinstance<py::dict>(channels))
    throw py::type_error(std::string(argument) + ": expected a dict of name -> array or a structured array, got " +
                         py::str(py::type::of(channels)).cast<std::string>());
  for (auto item : py::reinterpret_borrow<py::dict>(channels)) {
    if (!py::isinstance<py::str>(item.first))
      throw py::type_error(std::string(argument) + ": keys must be field names (str)");
    const auto name = item.first.cast<std::string>();
    add_channel(cloud, name, item.second, std::string(argument) + "['" + name + "']");
  }
}

cloud_ptr to_cloud(py::handle points, py::handle channels) {
  if (py::isinstance<ced::point_cloud>(points)) {
    auto c = points.cast<std::shared_ptr<ced::point_cloud>>();
    if (channels.is_none()) return c;
    auto copy = std::make_shared<ced::point_cloud>(*c);
    add_channels(*copy, channels, "channels");
    return copy;
  }
  ced::point_cloud cloud;
  if (py::isinstance<py::array>(points) && !points.attr("dtype").attr("names").is_none())
    cloud = cloud_from_structured(py::reinterpret_borrow<py::array>(points));
  else
    cloud = cloud_from_points(points);
  add_channels(cloud, channels, "channels");
  return std::make_shared<ced::point_cloud>(std::move(cloud));
}

std::string type_name(py::handle obj) { return py::str(py::type::of(obj).attr("__name__")).cast<std::string>(); }

std::string path_arg(py::handle obj, const std::string& name) {
  if (py::isinstance<py::str>(obj)) return obj.cast<std::string>();
  if (py::hasattr(obj, "__fspath__")) {
    const py::object p = py::module_::import("os").attr("fspath")(obj);
    if (py::isinstance<py::str>(p)) return p.cast<std::string>();
  }
  throw py::type_error(name + ": expected a path, got " + type_name(obj));
}

std::uint64_t int_arg(py::handle obj, const std::string& name, std::uint64_t max, const std::string& range) {
  // (numpy's bool_ is not a Python bool, but no more a count.)
  if (py::isinstance<py::bool_>(obj) || type_name(obj) == "bool_" || !PyIndex_Check(obj.ptr()))
    throw py::type_error(name + ": expected an int, got " + type_name(obj));
  const auto i = py::reinterpret_steal<py::int_>(PyNumber_Index(obj.ptr()));
  if (!i) throw py::error_already_set();
  if (i < py::int_(0) || i > py::int_(max))
    throw py::value_error(name + ": must be " + (range.empty() ? "0 .. " + std::to_string(max) : range) + ", got " +
                          py::str(obj).cast<std::string>());
  return i.cast<std::uint64_t>();
}

std::vector<std::uint32_t> to_indices(py::handle indices, const std::string& argument, std::size_t n) {
  // A boolean mask or floats would be cast to indices 0 and 1, or truncated: a wrong answer, not an error.
  const py::array given = py::array::ensure(indices);
  if (given) {
    const char kind = given.dtype().kind();
    // An empty list or tuple becomes a float64 array: it asks for no points.
    if (given.size() == 0 && given.ndim() == 1 && !py::isinstance<py::array>(indices)) return {};
    if (kind == 'b')
      throw py::type_error(argument + ": expected indices, got a boolean mask (pass np.flatnonzero(mask))");
    if (kind != 'i' && kind != 'u')
      throw py::type_error(argument + ": expected integer indices, got dtype " + std::string(py::str(given.dtype())));
  }
  const auto idx = py::array_t<std::int64_t, py::array::forcecast>::ensure(indices);
  if (!idx || idx.ndim() != 1) throw py::type_error(argument + ": expected a 1-D array of integers");
  std::vector<std::uint32_t> out(std::size_t(idx.shape(0)));
  for (std::size_t k = 0; k < out.size(); ++k) {
    const std::int64_t i = idx.at(py::ssize_t(k));
    if (i < 0 || std::uint64_t(i) >= n)
      throw py::index_error(argument + ": " + std::to_string(i) + " is out of range for " + std::to_string(n) +
                            " points");
    out[k] = std::uint32_t(i);
  }
  return out;
}

py::array view(const ced::column& c, py::handle owner) {
  return c.visit([&](const auto* p, std::size_t n) { return view(p, {py::ssize_t(n)}, owner); });
}

}  // namespace ced_python
