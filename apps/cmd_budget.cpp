// SPDX-License-Identifier: BSD-3-Clause
// `commerge budget`: prints an app's memory budget table for a board and checks it against this machine.
#include <cstdio>
#include <memory>
#include <string>

#include "apps/app_common.hpp"
#include "apps/app_descriptor_flags.hpp"
#include "apps/app_memory.hpp"
#include "apps/commands.hpp"
#include "platform/memory/allocator.hpp"

namespace commerge::app {

Command AddBudgetCommand(CLI::App& root) {
  struct Opts {
    std::string app = "robot";
    std::string descriptor = "ring";
    MemoryFlags memory;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = root.add_subcommand(
      "budget", "Print the memory budget of an app on a board and check it against this machine "
                "(exit 3 when it does not fit)");
  cmd->add_option("--app", o->app, "robot | server | run")
      ->check(CLI::IsMember({"robot", "server", "run"}))
      ->capture_default_str();
  cmd->add_option("--descriptor", o->descriptor,
                  "the robots' --descriptor: Scan Context keeps 1200 values per keyframe, the others 40")
      ->check(CLI::IsMember({"ring", "solid", "scan-context"}))
      ->capture_default_str();
  AddMemoryFlags(cmd, &o->memory);
  return {cmd, [o]() -> int {
    const AppKind app = *ParseAppKind(o->app);
    o->memory.descriptor_floats = DescriptorFloatsFor(o->descriptor);
    MemorySetup setup;
    const int rc = SetUpMemory(app, o->memory, &setup, /*print_table=*/true);
    if (rc != kExitOk) return rc;
    std::printf("%s\nallocator: %s\n", setup.verdict.c_str(), platform::AllocatorDescription().c_str());
    return kExitOk;
  }};
}

}  // namespace commerge::app
