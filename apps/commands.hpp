// SPDX-License-Identifier: BSD-3-Clause
// Each subcommand registers its flags on the root CLI and returns the function that runs it.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace commerge::app {

struct Command {
  CLI::App* cli = nullptr;      ///< the subcommand, to ask whether it was given
  std::function<int()> run;  ///< runs it after parsing; returns the process exit code
};

Command AddBudgetCommand(CLI::App& root);
Command AddDemoCommand(CLI::App& root);
Command AddVoxelizeCommand(CLI::App& root);
Command AddSimCommand(CLI::App& root);
Command AddRunCommand(CLI::App& root);
Command AddRobotCommand(CLI::App& root);
Command AddServerCommand(CLI::App& root);
Command AddFeedCommand(CLI::App& root);
Command AddKeygenCommand(CLI::App& root);
Command AddRecordCommand(CLI::App& root);
Command AddImportCommand(CLI::App& root);

}  // namespace commerge::app
