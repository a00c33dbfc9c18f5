// SPDX-License-Identifier: MIT
// Plugins: shared libraries that register modalities with a program built
// on ced (the `ced` tool: `ced detect --plugin ./libmymod.so -m mymod:0.1`).
//
// A plugin is built against ced's headers only (CMake: ced_add_plugin(),
// or a MODULE library linked to ced::plugin_api) and defines its one entry
// point with CED_PLUGIN:
//
//     #include <ced/plugin.hpp>
//     #include "my_modality.hpp"
//     void register_mine() { ced::register_modality<my_modality>("one line of help"); }
//     CED_PLUGIN(register_mine)
//
// The host checks, before it calls the plugin's registration, that the
// plugin was built for the same plugin ABI (CED_PLUGIN_ABI: the ABI version below,
// ced's major.minor version, and the C++ standard library's ABI). ced's
// functions that the plugin calls (register_modality, require_fields,
// interleave, ...) are the host's own: the host exports them (CMake:
// ced_enable_plugins()).
#pragma once

#include <exception>
#include <string>
#include <vector>

#include "ced/modality.hpp"
#include "ced/version.hpp"

/// Raised whenever a public type's layout or a virtual interface that
/// plugins see changes (any_modality, bound_modality, block_view, point_cloud,
/// field, modality_spec, detect_params...).
// 2: column views (ced::column::view); 3: field::whole_range;
// 4: detect_params::max_keypoints; 5: precomputed_saliency (the centroid shift);
// 6: any_modality::channels_from_neighborhoods (and detect_params::neighborhood, search);
// 7: detect_params::keypoint_share; 8: field::whole_sample and any_modality::whole_cloud_fields.
#define CED_PLUGIN_ABI_VERSION 8

#define CED_PLUGIN_STR_(x) #x
#define CED_PLUGIN_STR(x) CED_PLUGIN_STR_(x)
#if defined(_LIBCPP_VERSION)
#define CED_PLUGIN_STDLIB "libc++ " CED_PLUGIN_STR(_LIBCPP_ABI_VERSION)
#elif defined(_GLIBCXX_USE_CXX11_ABI)
#define CED_PLUGIN_STDLIB "libstdc++ cxx11-abi " CED_PLUGIN_STR(_GLIBCXX_USE_CXX11_ABI)
#else
#define CED_PLUGIN_STDLIB "unknown C++ library"
#endif
/// What a plugin and its host must agree on, as text.
#define CED_PLUGIN_ABI                                                              \
  "ced plugin ABI " CED_PLUGIN_STR(CED_PLUGIN_ABI_VERSION) ", ced " CED_PLUGIN_STR( \
      CED_VERSION_MAJOR) "." CED_PLUGIN_STR(CED_VERSION_MINOR) ", " CED_PLUGIN_STDLIB

/// Defines the plugin's entry points: `ced_plugin_abi()`, which returns the
/// CED_PLUGIN_ABI it was built with, and `ced_plugin_init()`, which calls
/// `register_function()` (a `void()` that registers modalities) and returns
/// nullptr, or the message of the exception it threw.
#define CED_PLUGIN(register_function)                                                                                \
  extern "C" __attribute__((visibility("default"))) const char* ced_plugin_abi() noexcept { return CED_PLUGIN_ABI; } \
  extern "C" __attribute__((visibility("default"))) const char* ced_plugin_init() noexcept {                         \
    static std::string ced_plugin_error_;                                                                            \
    try {                                                                                                            \
      register_function();                                                                                           \
      return nullptr;                                                                                                \
    } catch (const std::exception& e) {                                                                              \
      ced_plugin_error_ = e.what();                                                                                  \
    } catch (...) {                                                                                                  \
      ced_plugin_error_ = "an unknown exception";                                                                    \
    }                                                                                                                \
    return ced_plugin_error_.c_str();                                                                                \
  }

namespace ced {

/// A plugin that could not be loaded; the message names the file and says why.
struct plugin_error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// What load_plugin() loaded.
struct plugin_info {
  std::string path;
  /// Names of the modalities it registered (new or replaced), sorted.
  std::vector<std::string> modalities;
};

/// Loads the plugin at `path` (a path with a '/', or a name the dynamic
/// loader searches for) and runs its registration. Throws plugin_error when
/// the file is missing or not a shared library, lacks the entry points, was
/// built for another CED_PLUGIN_ABI, needs symbols this program does not
/// export, or its registration fails; nothing of such a plugin stays loaded.
/// (Loading a library runs its static initialisers, as for any dlopen: a
/// plugin should do its work in its registration function, not in them.)
/// Loading the same path again returns the first load's info. Plugins stay
/// loaded until the program exits. Thread-safe.
plugin_info load_plugin(const std::string& path);

}  // namespace ced
