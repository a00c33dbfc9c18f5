// SPDX-License-Identifier: MIT
// A plugin: the NDVI modality for the `ced` tool, without rebuilding it.
//
//   ced modalities --plugin build/lib/libced_ndvi.so
//   ced detect field.las --plugin build/lib/libced_ndvi.so -m xyz:0.2 -m ndvi:0.1 --radius 0.5
//
// Built against ced's headers only (CMake: ced_add_plugin(ced_ndvi ...)).
#include <ced/plugin.hpp>

#include "../ndvi_modality.hpp"

namespace {
void register_ndvi() {
  ced::register_modality<example::ndvi>("NDVI (NIR-red)/(NIR+red) from fields nir, red; ndvi(NIR,RED) (plugin)");
}
}  // namespace

CED_PLUGIN(register_ndvi)
