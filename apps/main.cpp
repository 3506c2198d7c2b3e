// SPDX-License-Identifier: BSD-3-Clause
// commerge: one executable, one subcommand per job.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <new>
#include <vector>

#include "apps/app_common.hpp"
#include "apps/commands.hpp"

int main(int argc, char** argv) {
  using namespace commerge::app;
  CLI::App root{"commerge: communication-efficient multi-robot 3D LiDAR map merging"};
  root.set_version_flag("--version", "commerge " CM_VERSION);
  root.require_subcommand(1);

  const std::vector<Command> commands = {AddDemoCommand(root), AddBudgetCommand(root), AddVoxelizeCommand(root),
                                       AddSimCommand(root), AddRunCommand(root), AddRobotCommand(root),
                                       AddServerCommand(root), AddFeedCommand(root),
                                       AddKeygenCommand(root), AddRecordCommand(root),
                                       AddImportCommand(root)};

  try {
    root.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = root.exit(e);
    return rc == 0 ? kExitOk : kExitUsage;
  }

  try {
    for (const Command& c : commands) {
      if (c.cli->parsed()) return c.run();
    }
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "commerge: out of memory (std::bad_alloc): the heap cap or the machine's memory ran out; "
                         "lower the budgets (see `commerge budget --help`) or raise --heap-cap-mb\n");
    return kExitOutOfMemory;
  }
  return kExitUsage;
}
