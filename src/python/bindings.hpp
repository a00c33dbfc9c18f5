// SPDX-License-Identifier: MIT
// The Python module `ced._ced`: what its source files share.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/tiled.hpp"

namespace ced_python {

namespace py = pybind11;

/// The name of obj's type ("float", "bool_"), for messages.
std::string type_name(py::handle obj);
/// A path (str or os.PathLike), or a TypeError naming `name`.
std::string path_arg(py::handle obj, const std::string& name);
/// An int (or a numpy integer; not a bool) in 0 .. max, or a TypeError /
/// ValueError naming `name` (and `range`, when given, for the range).
std::uint64_t int_arg(py::handle obj, const std::string& name, std::uint64_t max, const std::string& range = "");

/// `refine=` of detect and plan_tiles: a bool, or None for the preset's
/// (robust3d, robust6d and corner3d refine; the others do not).
bool refine_of(py::handle modalities, py::handle refine);
/// detect_params::keypoint_share from a `keypoint_share` argument: a number
/// from 0 to 1, or None (the preset's when `modalities` names one, else 0).
double keypoint_share_of(py::handle modalities, py::handle share);
/// Sets p.neighborhood and p.search from the arguments `neighborhood` and
/// `search` (ValueError naming the argument).
void set_neighborhood(ced::detect_params& p, const std::string& neighborhood, const std::string& search);

/// True while the function of a ced.python_modality runs, on any thread.
/// A TBB worker of that detection then waits outside TBB (for the GIL, or
/// for whatever the function waits for) while it holds its place in the
/// shared task arena, so a detection (or any multithreaded work) started
/// meanwhile must not enter TBB: it would wait for those places forever.
bool python_callbacks_running();

/// The threads that work started now may use: 1 (no TBB at all) while
/// python_callbacks_running(), else `threads`. Results do not depend on it.
unsigned threads_for(unsigned threads);

/// Releases the GIL for C++ work, as py::gil_scoped_release, and counts the
/// calls inside such work. At interpreter exit (atexit) the module waits for
/// that count to reach 0 (wait_for_released_calls()): a daemon thread still
/// inside ced.detect would otherwise be killed when it takes the GIL back,
/// through C++ frames that cannot unwind, and abort the process. Throws
/// RuntimeError once the wait has begun (work started at exit).
class released_gil {
 public:
  released_gil() = default;
  released_gil(const released_gil&) = delete;
  released_gil& operator=(const released_gil&) = delete;

 private:
  // Counted before the GIL is released, and again after it is taken back
  // (members are destroyed in reverse order).
  struct counted {
    counted();
    ~counted();
    counted(const counted&) = delete;
    counted& operator=(const counted&) = delete;
  } m_counted;
  py::gil_scoped_release m_release;
};
/// Waits, the GIL released, until no released_gil is alive (for atexit).
void wait_for_released_calls();

/// A cloud shared between Python objects (Cloud, Result's views) and C++.
using cloud_ptr = std::shared_ptr<ced::point_cloud>;

/// The cloud that `points` and `channels` describe: a ced.Cloud (no copy), an
/// (N, 3) float32/float64 array of any strides plus a dict of channels, or a
/// numpy structured array with X, Y, Z fields (PDAL's arrays). Throws
/// py::type_error / py::value_error naming the argument and what was expected.
cloud_ptr to_cloud(py::handle points, py::handle channels);

/// Adds the channels of a dict (name -> (N,) or (N, k) numeric arrays) to
/// `cloud` (whose size is known).
void add_channels(ced::point_cloud& cloud, py::handle channels, const char* argument);

/// A read-only numpy array of `dtype` viewing `data` (no copy), kept alive by `owner`.
inline py::array view(const py::dtype& dtype, const void* data, std::vector<py::ssize_t> shape, py::handle owner) {
  py::array a(dtype, std::move(shape), {}, data, owner);
  a.attr("setflags")(py::arg("write") = false);
  return a;
}
template <class T>
py::array view(const T* data, std::vector<py::ssize_t> shape, py::handle owner) {
  return view(py::dtype::of<T>(), data, std::move(shape), owner);
}
template <class T>
py::array view(const std::vector<T>& v, py::handle owner) {
  return view(v.data(), {py::ssize_t(v.size())}, owner);
}

/// A 1-D array of indices as uint32, each below `n`; throws py::type_error /
/// py::index_error naming `argument`.
std::vector<std::uint32_t> to_indices(py::handle indices, const std::string& argument, std::size_t n);

/// A typed column as a numpy array viewing it, kept alive by `owner`.
py::array view(const ced::column& c, py::handle owner);

void bind_cloud(py::module_& m);
void bind_modalities(py::module_& m);
void bind_detect(py::module_& m);
void bind_eval(py::module_& m);
void bind_tiled(py::module_& m);

/// Throws TypeError when `src` is an instance of `type` (or of a Python
/// subclass) whose C++ value was never made: an object from
/// `Class.__new__(Class)` without `__init__` or `__setstate__`. pybind11
/// would otherwise hand its methods uninitialised memory.
void check_initialised(py::handle src, const std::type_info& type);

}  // namespace ced_python

/// The casters of ced's bound classes, by value and by holder: as pybind11's
/// own, after check_initialised(). Declare one with CED_PYTHON_CHECKED_CLASS
/// in every translation unit that converts the type (before its first use).
namespace ced_python::detail {
template <class T>
struct checked_caster : pybind11::detail::type_caster_base<T> {
  bool load(pybind11::handle src, bool convert) {
    check_initialised(src, typeid(T));
    return pybind11::detail::type_caster_base<T>::load(src, convert);
  }
};
template <class T, class Holder>
struct checked_holder_caster : pybind11::detail::copyable_holder_caster<T, Holder> {
  bool load(pybind11::handle src, bool convert) {
    check_initialised(src, typeid(T));
    return pybind11::detail::copyable_holder_caster<T, Holder>::load(src, convert);
  }
};
}  // namespace ced_python::detail

#define CED_PYTHON_CHECKED_CLASS(T)                                       \
  namespace pybind11::detail {                                            \
  template <>                                                             \
  class type_caster<T> : public ced_python::detail::checked_caster<T> {}; \
  }
#define CED_PYTHON_CHECKED_HOLDER(T)                                                                                  \
  CED_PYTHON_CHECKED_CLASS(T)                                                                                         \
  namespace pybind11::detail {                                                                                        \
  template <>                                                                                                         \
  class type_caster<std::shared_ptr<T>> : public ced_python::detail::checked_holder_caster<T, std::shared_ptr<T>> {}; \
  }

CED_PYTHON_CHECKED_HOLDER(ced::point_cloud)
CED_PYTHON_CHECKED_HOLDER(ced::tile_plan)
CED_PYTHON_CHECKED_HOLDER(ced::tile_part)
CED_PYTHON_CHECKED_CLASS(ced::any_modality)
