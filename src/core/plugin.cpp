// SPDX-License-Identifier: MIT
// Loading plugins: dlopen, the ABI check, the registration.
#include "ced/plugin.hpp"

#include <dlfcn.h>
#include <sys/stat.h>

#include <map>
#include <mutex>

#include "core/registry.hpp"

namespace ced {

namespace {
std::mutex g_mutex;
std::map<std::string, plugin_info> g_loaded;  // by the path as given

[[noreturn]] void fail(const std::string& path, const std::string& why) {
  throw plugin_error("plugin '" + path + "': " + why);
}

std::string last_dl_error() {
  const char* e = dlerror();
  return e ? e : "unknown error";
}

/// Closes the library unless released (a plugin that failed leaves nothing).
struct library {
  void* handle = nullptr;
  ~library() {
    if (handle) dlclose(handle);
  }
  void* release() noexcept {
    void* h = handle;
    handle = nullptr;
    return h;
  }
};
}  // namespace

plugin_info load_plugin(const std::string& path) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (auto it = g_loaded.find(path); it != g_loaded.end()) return it->second;
  if (path.empty()) throw plugin_error("plugin: empty path");
  struct stat st {};
  if (path.find('/') != std::string::npos) {
    if (stat(path.c_str(), &st) != 0) fail(path, "no such file");
    if (S_ISDIR(st.st_mode)) fail(path, "is a directory, not a shared library");
  }
  library lib;
  dlerror();
  lib.handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!lib.handle) {
    const std::string e = last_dl_error();
    if (e.find("undefined symbol") != std::string::npos)
      fail(path, "needs a symbol this program does not provide (" + e +
                     "); was it built against another version of ced, or is this program not built to load plugins?");
    fail(path, "cannot be loaded as a shared library: " + e);
  }
  using text_fn = const char* (*)() noexcept;
  auto abi = reinterpret_cast<text_fn>(dlsym(lib.handle, "ced_plugin_abi"));
  auto init = reinterpret_cast<text_fn>(dlsym(lib.handle, "ced_plugin_init"));
  if (!abi || !init)
    fail(path,
         "is not a ced plugin: it lacks the entry points ced_plugin_abi() and ced_plugin_init() "
         "(define them with CED_PLUGIN(...) from <ced/plugin.hpp>)");
  const std::string theirs = abi() ? abi() : "";
  if (theirs != CED_PLUGIN_ABI)
    fail(path, "was built for '" + theirs + "', but this program is '" CED_PLUGIN_ABI "': rebuild the plugin");
  detail::begin_registration_log();
  const char* error = nullptr;
  try {
    error = init();
  } catch (...) {
    error = "its registration threw";
  }
  const auto names = detail::end_registration_log(error != nullptr);
  if (error) fail(path, std::string("failed to register its modalities: ") + error);
  if (names.empty()) fail(path, "registered no modality");
  lib.release();  // stays loaded: the registry now holds its code
  return g_loaded[path] = plugin_info{path, names};
}

}  // namespace ced
