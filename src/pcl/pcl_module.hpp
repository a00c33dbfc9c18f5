// SPDX-License-Identifier: MIT
// ced's PCL module: the shared library (libced_pcl.so, target
// ced_pcl_module) that carries pcl_bridge's detectors and registration, so
// that the `ced` tool loads PCL only when a command uses it
// (src/pcl/pcl_loader.cpp). The module links PCL and ced's headers only; the
// ced functions it calls are the tool's own, exported as they are to plugins
// (cmake/cedPlugins.cmake). Its one entry point, ced_pcl_module(), returns
// the table below.
#pragma once

#include "ced/plugin.hpp"
#include "pcl_bridge.hpp"

/// What the tool and its PCL module must agree on: the plugin ABI (the
/// layouts of point_cloud and friends) and the table's own version.
#define CED_PCL_MODULE_ABI CED_PLUGIN_ABI ", PCL module table 1"

namespace ced::pcl_bridge {

struct module_table {
  const char* abi;  ///< CED_PCL_MODULE_ABI of the module
  std::vector<std::uint32_t> (*detect)(const point_cloud&, detector, const detector_params&);
  registration_result (*register_keypoints)(const point_cloud&, const std::vector<std::uint32_t>&,
                                            const std::array<double, 3>&, const point_cloud&,
                                            const std::vector<std::uint32_t>&, const std::array<double, 3>&,
                                            const registration_params&);
};

}  // namespace ced::pcl_bridge

/// The module's entry point (extern "C", so that dlsym finds it by name).
extern "C" const ced::pcl_bridge::module_table* ced_pcl_module() noexcept;
