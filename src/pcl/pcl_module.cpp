// SPDX-License-Identifier: MIT
// The entry point of ced's PCL module (libced_pcl.so): the table of
// pcl_bridge's functions. Everything else in the module is hidden.
#include "pcl_module.hpp"

#include <pcl/exceptions.h>

#include <stdexcept>

namespace ced::pcl_bridge {
namespace {

// PCL's exceptions are types of libpcl_common, which the tool does not link:
// they cross into the tool as what the tool knows, std::runtime_error.
template <typename F>
auto rethrow_as_std(F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const pcl::PCLException& e) {
    throw std::runtime_error(std::string("PCL: ") + e.what());
  }
}

std::vector<std::uint32_t> module_detect(const point_cloud& cloud, detector d, const detector_params& params) {
  return rethrow_as_std([&] { return detect(cloud, d, params); });
}

registration_result module_register(const point_cloud& source, const std::vector<std::uint32_t>& source_keypoints,
                                    const std::array<double, 3>& source_viewpoint, const point_cloud& target,
                                    const std::vector<std::uint32_t>& target_keypoints,
                                    const std::array<double, 3>& target_viewpoint, const registration_params& params) {
  return rethrow_as_std([&] {
    return register_keypoints(source, source_keypoints, source_viewpoint, target, target_keypoints, target_viewpoint,
                              params);
  });
}

const module_table table{CED_PCL_MODULE_ABI, &module_detect, &module_register};

}  // namespace
}  // namespace ced::pcl_bridge

extern "C" __attribute__((visibility("default"))) const ced::pcl_bridge::module_table* ced_pcl_module() noexcept {
  return &ced::pcl_bridge::table;
}
