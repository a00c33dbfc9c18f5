# ced's CMake helpers for plugins, written once: included by ced's own build
# (CMakeLists.txt) and installed beside cedConfig.cmake, which includes it
# for projects that use find_package(ced). Both need the targets ced::core
# and ced::plugin_api.

# A program that loads plugins (shared libraries that register modalities;
# see ced/plugin.hpp, ced::load_plugin) must export ced::core's symbols to
# them: the whole library is linked in and its symbols are exported from the
# executable. Plugins link nothing of ced (ced::plugin_api) and use the host's.
function(ced_enable_plugins target)
  set_target_properties(${target} PROPERTIES ENABLE_EXPORTS ON)
  target_link_libraries(${target} PRIVATE -Wl,--whole-archive ced::core -Wl,--no-whole-archive)
endfunction()

# A plugin: a shared module built against ced's headers only.
function(ced_add_plugin target)
  add_library(${target} MODULE ${ARGN})
  target_link_libraries(${target} PRIVATE ced::plugin_api)
endfunction()
