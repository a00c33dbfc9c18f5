// SPDX-License-Identifier: MIT
// The `ced` subcommands. Each add_*_command() registers a subcommand and its
// options on a CLI11 app; main() runs the one that was parsed.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace ced_cli {

/// A registered subcommand: `run` (valid after parsing, when `*app` is set)
/// runs it with the parsed options and returns the exit code.
struct command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};

struct detect_options;
/// `run`, when given, runs the parsed options instead of `ced detect` (ced-mpi).
command add_detect_command(CLI::App& app, std::function<int(const detect_options&)> run = {});  // detect.cpp
command add_info_command(CLI::App& app);                                                        // info.cpp
command add_modalities_command(CLI::App& app);                                                  // modalities.cpp
CLI::App* add_eval_command(CLI::App& app);          // eval.cpp: the `eval` group, for the two below
command add_repeatability_command(CLI::App& eval);  // eval.cpp
command add_registration_command(CLI::App& eval);   // registration.cpp
command add_convert_command(CLI::App& app);         // convert.cpp
command add_plan_command(CLI::App& app);            // tiled_commands.cpp
command add_merge_command(CLI::App& app);           // tiled_commands.cpp
command add_view_command(CLI::App& app);            // view.cpp

}  // namespace ced_cli
