// SPDX-License-Identifier: MIT
// Two stand-ins for ced's PCL module (tests/pcl/cli_pcl_module_test.sh): one
// with the entry point ced_pcl_module() but another ABI (FOREIGN_ABI), one
// without the entry point.
#ifdef FOREIGN_ABI
namespace {
void nothing() {}
struct table {
  const char* abi;
  void (*detect)();
  void (*register_keypoints)();
};
const table foreign{"ced plugin ABI 0, ced 0.0, PCL module table 0", &nothing, &nothing};
}  // namespace
extern "C" __attribute__((visibility("default"))) const void* ced_pcl_module() noexcept { return &foreign; }
#else
extern "C" __attribute__((visibility("default"))) int not_ced_pcl_module() noexcept { return 0; }
#endif
