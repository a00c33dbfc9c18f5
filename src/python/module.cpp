// SPDX-License-Identifier: MIT
// The Python extension module ced._ced (the package `ced` wraps it).
#include "bindings.hpp"
#include "ced/io/output_file.hpp"
#include "ced/plugin.hpp"
#include "ced/version.hpp"

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
}
