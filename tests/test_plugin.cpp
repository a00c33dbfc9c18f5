// SPDX-License-Identifier: MIT
// Plugins: the example NDVI plugin end to end, and every plugin that must be
// refused with a clear error (ced/plugin.hpp).
#include <gtest/gtest.h>

#include <string>

#include "../examples/ndvi_modality.hpp"
#include "ced/plugin.hpp"
#include "file_support.hpp"
#include "test_support.hpp"

namespace {
std::string help_of(const std::string& name) {
  for (const auto& [n, h] : ced::registered_modalities())
    if (n == name) return h;
  return "";
}

std::string load_error(const std::string& path) {
  try {
    ced::load_plugin(path);
  } catch (const ced::plugin_error& e) {
    return e.what();
  }
  return "no error";
}
}  // namespace

TEST(Plugin, ExampleRegistersNdviThatMatchesTheCompiledModality) {
  const ced::plugin_info info = ced::load_plugin(CED_NDVI_PLUGIN);
  EXPECT_EQ(info.path, CED_NDVI_PLUGIN);
  EXPECT_EQ(info.modalities, std::vector<std::string>{"ndvi"});
  EXPECT_NE(help_of("ndvi").find("(plugin)"), std::string::npos);
  // Loading again is a no-op that returns the same.
  EXPECT_EQ(ced::load_plugin(CED_NDVI_PLUGIN).modalities, info.modalities);

  const ced::point_cloud c = ced_test::ndvi_edge(ced::scalar_type::uint8);
  ced::detect_params p;
  p.radius = p.nms_radius = 0.035;
  p.threads = 1;
  const auto from_plugin = ced::detect(c, p, {ced::make_modality("ndvi:0.05")});
  const auto compiled = ced::detect(c, p, example::ndvi{0.05});
  EXPECT_EQ(from_plugin.keypoints, compiled.keypoints);
  EXPECT_EQ(from_plugin.saliency, compiled.saliency);
  EXPECT_EQ(from_plugin.names, std::vector<std::string>{"ndvi"});
  // The edge is found, and only there: |0.6 - mean| / 2 on both sides of x = 0.
  ASSERT_FALSE(compiled.keypoints.empty());
  for (auto k : compiled.keypoints) EXPECT_LT(std::abs(c.position(k)[0] - 0.005f), 0.006f);
  EXPECT_EQ(compiled.saliency[0][10 * 21 + 2], 0.0f);  // interior: one NDVI
}

TEST(Plugin, MissingFileIsAClearError) {
  EXPECT_CONTAINS(load_error("./no_such_plugin.so"), "plugin './no_such_plugin.so': no such file");
  EXPECT_CONTAINS(load_error(CED_TEST_DATA_DIR), "is a directory");
  EXPECT_CONTAINS(load_error(""), "empty path");
}

TEST(Plugin, AFileThatIsNoSharedLibraryIsAClearError) {
  EXPECT_CONTAINS(load_error(CED_TEST_DATA_DIR "/SOURCES.md"), "cannot be loaded as a shared library");
}

TEST(Plugin, ALibraryWithoutTheEntryPointsIsRefused) {
  EXPECT_CONTAINS(load_error(CED_BAD_PLUGIN_NO_ENTRY), "is not a ced plugin: it lacks the entry points");
}

TEST(Plugin, APluginBuiltForAnotherAbiIsRefusedBeforeItRuns) {
  const std::string e = load_error(CED_BAD_PLUGIN_WRONG_ABI);
  EXPECT_CONTAINS(e, "was built for 'ced plugin ABI 999");
  EXPECT_CONTAINS(e, "but this program is '" CED_PLUGIN_ABI "': rebuild the plugin");
  EXPECT_NE(help_of("ndvi"), "must never be registered");
}

TEST(Plugin, AFailingRegistrationIsRolledBack) {
  const std::string before = help_of("ndvi");
  EXPECT_CONTAINS(load_error(CED_BAD_PLUGIN_THROWS), "failed to register its modalities: the plugin's own failure");
  EXPECT_EQ(help_of("ndvi"), before);  // what it registered before throwing is gone
  EXPECT_CONTAINS(load_error(CED_BAD_PLUGIN_REGISTERS_NOTHING), "registered no modality");
}
