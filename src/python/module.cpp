// SPDX-License-Identifier: MIT
// The Python extension module ced._ced (the package `ced` wraps it).
#include <atomic>
#include <chrono>
#include <thread>

#include "bindings.hpp"
#include "ced/io/output_file.hpp"
#include "ced/plugin.hpp"
#include "ced/version.hpp"

namespace ced_python {
namespace {
std::atomic<int> g_released{0};      // calls inside released_gil
std::atomic<bool> g_exiting{false};  // wait_for_released_calls() has begun
}  // namespace

// The exit wait ends only once each thread is back in Python, holding the
// GIL, where the interpreter may stop it safely.
released_gil::counted::counted() {
  if (g_exiting.load()) throw std::runtime_error("ced: the interpreter is exiting; no new work is started");
  ++g_released;
}
released_gil::counted::~counted() { --g_released; }

void wait_for_released_calls() {
  g_exiting.store(true);
  while (g_released.load() > 0) {
    py::gil_scoped_release release;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

void check_initialised(py::handle src, const std::type_info& type) {
  const auto* info = py::detail::get_type_info(type);
  if (!info || !src || !PyObject_TypeCheck(src.ptr(), info->type)) return;  // not of the type: pybind11's own checks
  auto* inst = reinterpret_cast<py::detail::instance*>(src.ptr());
  const auto v_h = inst->get_value_and_holder(info, false);
  if (v_h && v_h.instance_registered()) return;
  const std::string name = py::str(py::handle(reinterpret_cast<PyObject*>(info->type)).attr("__qualname__"));
  throw py::type_error("ced." + name + " object is not initialised (made by " + name + ".__new__ without __init__); " +
                       "create it with ced." + name + "(...) or the function that returns one");
}
}  // namespace ced_python

PYBIND11_MODULE(_ced, m) {
  namespace py = pybind11;
  m.doc() = "ced: N-modal CEntroid Distance keypoint detection (the C++ core)";
  m.attr("__version__") = CED_VERSION_STRING;
  py::register_exception<ced::io::io_error>(m, "FileError", PyExc_OSError);
  py::register_exception<ced::plugin_error>(m, "PluginError", PyExc_ImportError);
  m.attr("FileError").attr("__doc__") =
      "A file that cannot be read or written: missing, malformed, truncated, unsupported.";
  m.attr("PluginError").attr("__doc__") = "A plugin that cannot be loaded; the message names the file and says why.";
  ced_python::bind_cloud(m);
  ced_python::bind_modalities(m);
  ced_python::bind_detect(m);
  ced_python::bind_eval(m);
  ced_python::bind_tiled(m);
  m.def("_wait_for_released_calls", &ced_python::wait_for_released_calls,
        "For atexit: waits until no thread is inside ced's C++ work, then refuses new work.");
}
