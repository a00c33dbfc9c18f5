// SPDX-License-Identifier: MIT
// Plugins that must be refused, one per build (CED_BAD_PLUGIN selects):
//   no_entry   - a shared library without ced's entry points
//   wrong_abi  - entry points that claim another plugin ABI
//   throws     - a registration that throws
//   registers_nothing - a registration that registers no modality
#include <ced/plugin.hpp>
#include <stdexcept>

#include "../../examples/ndvi_modality.hpp"

#if defined(CED_BAD_PLUGIN_NO_ENTRY)
extern "C" int some_other_library_function() { return 42; }
#elif defined(CED_BAD_PLUGIN_WRONG_ABI)
extern "C" __attribute__((visibility("default"))) const char* ced_plugin_abi() noexcept {
  return "ced plugin ABI 999, ced 0.1, libstdc++ cxx11-abi 1";
}
extern "C" __attribute__((visibility("default"))) const char* ced_plugin_init() noexcept {
  ced::register_modality<example::ndvi>("must never be registered");
  return nullptr;
}
#elif defined(CED_BAD_PLUGIN_THROWS)
namespace {
void register_then_throw() {
  ced::register_modality<example::ndvi>("registered before the failure: must be rolled back");
  throw std::runtime_error("the plugin's own failure");
}
}  // namespace
CED_PLUGIN(register_then_throw)
#elif defined(CED_BAD_PLUGIN_REGISTERS_NOTHING)
namespace {
void register_nothing() {}
}  // namespace
CED_PLUGIN(register_nothing)
#endif
