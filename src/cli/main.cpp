// SPDX-License-Identifier: MIT
// The `ced` command line: a thin shell over the library. Each subcommand is
// in its own file (commands.hpp); this builds the app, parses and dispatches.
#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/io/io.hpp"
#include "commands.hpp"
#include "common.hpp"

using namespace ced_cli;

int main(int argc, char** argv) {
  keep_freed_memory();
  CLI::App app{"ced " CED_VERSION_STRING
               ": N-modal CEntroid Distance keypoint detection in point clouds (Teng et al., WACV 2023)",
               "ced"};  // the name: "Usage: ced [OPTIONS] SUBCOMMAND"
  app.require_subcommand(1);
  app.set_version_flag("--version", CED_VERSION_STRING);

  const command detect = add_detect_command(app);
  const command info = add_info_command(app);
  const command modalities = add_modalities_command(app);
  CLI::App* eval = add_eval_command(app);
  const command repeatability = add_repeatability_command(*eval);
  const command registration = add_registration_command(*eval);
  const command convert = add_convert_command(app);
  const command plan = add_plan_command(app);
  const command merge = add_merge_command(app);
  const command view = add_view_command(app);

  ced::io::remove_temporaries_on_signals();  // an interrupted run leaves no partial output
  if (const std::optional<int> rc = parse_command_line(app, *detect.app, argc, argv, "ced")) return *rc;
  try {
    for (const command* c :
         {&detect, &info, &repeatability, &registration, &convert, &modalities, &plan, &merge, &view})
      if (*c->app) {
        const int rc = c->run();
        check_stdout();
        return rc;
      }
  } catch (const usage_error& e) {
    std::cerr << "ced: error: " << e.what() << "\n";
    return exit_usage;
  } catch (const std::exception& e) {
    std::cerr << "ced: error: " << e.what() << "\n";
    return exit_failure;
  }
  return exit_usage;
}
