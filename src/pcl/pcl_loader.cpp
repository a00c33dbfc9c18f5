// SPDX-License-Identifier: MIT
// pcl_bridge in the `ced` tool: each call goes to ced's PCL module
// (libced_pcl.so, src/pcl/pcl_module.cpp), which is loaded on first use, so
// that a command that does not use PCL does not load PCL's libraries.
//
// Where the module is: $CED_PCL_MODULE when set, else CED_PCL_MODULE_RELPATH
// (set by cmake/pcl.cmake) from the directory of the running executable, the
// same path in the build tree as in an installation.
#include <dlfcn.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdlib>
#include <mutex>
#include <stdexcept>
#include <string>

#include "pcl_bridge.hpp"
#include "pcl_module.hpp"

#ifndef CED_PCL_MODULE_RELPATH
#error "CED_PCL_MODULE_RELPATH: the module's path relative to the executable's directory (cmake/pcl.cmake)"
#endif

namespace ced::pcl_bridge {
namespace {

std::string executable_dir() {
  char buffer[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", buffer, sizeof buffer - 1);
  if (n <= 0) return ".";
  const std::string path(buffer, static_cast<std::size_t>(n));
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? "." : path.substr(0, slash);
}

std::string module_path() {
  if (const char* env = std::getenv("CED_PCL_MODULE"); env && *env) return env;
  return executable_dir() + "/" CED_PCL_MODULE_RELPATH;
}

[[noreturn]] void fail(const std::string& path, const std::string& problem) {
  throw std::runtime_error("ced's PCL module '" + path + "' " + problem +
                           " (it carries PCL's detectors and ced eval registration; reinstall ced, or point "
                           "CED_PCL_MODULE at the libced_pcl.so of this build)");
}

const module_table& load() {
  const std::string path = module_path();
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) fail(path, "is not there");
  if (!S_ISREG(st.st_mode)) fail(path, "is not a file");
  dlerror();
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* e = dlerror();
    fail(path, std::string("cannot be loaded: ") + (e ? e : "unknown error"));
  }
  using entry_fn = const module_table* (*)() noexcept;
  auto entry = reinterpret_cast<entry_fn>(dlsym(handle, "ced_pcl_module"));
  const module_table* t = entry ? entry() : nullptr;
  if (!t || !t->abi || !t->detect || !t->register_keypoints) {
    dlclose(handle);
    fail(path, "is not ced's PCL module: it lacks the entry point ced_pcl_module()");
  }
  if (std::string(t->abi) != CED_PCL_MODULE_ABI) {
    const std::string theirs = t->abi;
    dlclose(handle);
    fail(path, "was built for '" + theirs + "', but this ced is '" CED_PCL_MODULE_ABI "'");
  }
  return *t;  // the module stays loaded for the life of the process
}

const module_table& table() {
  static std::mutex mutex;
  static const module_table* loaded = nullptr;
  std::lock_guard<std::mutex> lock(mutex);
  if (!loaded) loaded = &load();  // a failure is retried (and reported) on the next call
  return *loaded;
}

}  // namespace

void require_pcl() { table(); }

std::vector<std::uint32_t> detect(const point_cloud& cloud, detector d, const detector_params& params) {
  return table().detect(cloud, d, params);
}

registration_result register_keypoints(const point_cloud& source, const std::vector<std::uint32_t>& source_keypoints,
                                       const std::array<double, 3>& source_viewpoint, const point_cloud& target,
                                       const std::vector<std::uint32_t>& target_keypoints,
                                       const std::array<double, 3>& target_viewpoint,
                                       const registration_params& params) {
  return table().register_keypoints(source, source_keypoints, source_viewpoint, target, target_keypoints,
                                    target_viewpoint, params);
}

}  // namespace ced::pcl_bridge
