// SPDX-License-Identifier: MIT
// `ced modalities`: the modalities that --modality accepts.
#include <iostream>

#include "ced/ced.hpp"
#include "commands.hpp"
#include "common.hpp"

namespace ced_cli {
namespace {

int run_modalities() {
  for (const auto& [name, help] : ced::registered_modalities()) std::cout << name << "\t" << help << "\n";
  return exit_ok;
}

}  // namespace

command add_modalities_command(CLI::App& app) {
  auto* mods = app.add_subcommand("modalities", "List the modalities that --modality accepts");
  return {mods, run_modalities};
}

}  // namespace ced_cli
