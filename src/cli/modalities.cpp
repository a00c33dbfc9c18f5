// SPDX-License-Identifier: MIT
// `ced modalities`: the modalities that --modality accepts.
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "commands.hpp"
#include "common.hpp"

namespace ced_cli {
namespace {

int run_modalities(const std::vector<std::string>& plugins) {
  load_plugins(plugins);
  for (const auto& [name, help] : ced::registered_modalities()) std::cout << name << "\t" << help << "\n";
  std::cout << "\nEvery modality also takes scale=K: measured over K x the radius (its threshold too).\n"
            << "\nPresets (--preset):\n";
  for (const auto& p : ced::preset_names()) {
    std::string specs;
    for (const auto& s : ced::preset_specs(p)) specs += (specs.empty() ? "" : " ") + ("-m " + s);
    if (ced::preset_refines(p)) specs += " --refine";
    if (const double share = ced::preset_keypoint_share(p); share > 0) {
      char text[48];
      std::snprintf(text, sizeof text, " --keypoint-share %g", share);
      specs += text;
    }
    std::cout << p << "\t" << specs << "\n";
  }
  return exit_ok;
}

}  // namespace

command add_modalities_command(CLI::App& app) {
  auto plugins = std::make_shared<std::vector<std::string>>();
  auto* mods = app.add_subcommand("modalities", "List the modalities that --modality accepts");
  add_plugin_option(mods, *plugins);
  return {mods, [plugins] { return run_modalities(*plugins); }};
}

}  // namespace ced_cli
