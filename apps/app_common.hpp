// SPDX-License-Identifier: BSD-3-Clause
// Wiring shared by every subcommand: the stop signals, the exit codes, the daemons' fault-injection flags. The
// rest is by concern: app_memory.hpp (memory flags, the start-up budget check, peak RSS), app_auth.hpp (message
// authentication), app_descriptor_flags.hpp (the descriptor and sensor flags and what they choose).
#pragma once

#include <CLI/CLI.hpp>

namespace commerge::app {

/// SIGINT and SIGTERM counted instead of killing the process, so daemons finish their summary and outputs.
void InstallStopSignalHandlers();
/// How many SIGINT/SIGTERM arrived since InstallStopSignalHandlers() (0: keep running).
int StopSignalCount();

/// Exit codes of the commerge executable.
enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,      ///< the job ran and failed (bad input file, failed merge, ...)
  kExitUsage = 2,        ///< bad command line or configuration value
  kExitOverBudget = 3,   ///< the memory budget does not fit this machine
  kExitOutOfMemory = 4,  ///< std::bad_alloc at run time
};

/// The daemons' test-only fault injection on outgoing messages (platform::LcmBusParams): --delay-ms,
/// --jitter-ms (reorders), --duplicate-pct, in their own help group.
void AddFaultFlags(CLI::App* cmd, double* delay_ms, double* jitter_ms, double* duplicate_pct);

}  // namespace commerge::app
