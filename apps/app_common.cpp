// SPDX-License-Identifier: BSD-3-Clause
#include "apps/app_common.hpp"

#include <csignal>

namespace commerge::app {

namespace {
volatile std::sig_atomic_t g_stop_signals = 0;
void CountStopSignal(int) {
  if (g_stop_signals < 1000) g_stop_signals = g_stop_signals + 1;
}
}  // namespace

void InstallStopSignalHandlers() {
  std::signal(SIGINT, CountStopSignal);
  std::signal(SIGTERM, CountStopSignal);
}

int StopSignalCount() { return static_cast<int>(g_stop_signals); }

void AddFaultFlags(CLI::App* cmd, double* delay_ms, double* jitter_ms, double* duplicate_pct) {
  const char* group = "Fault injection on outgoing messages (network fault tests; sch_netem is often unavailable)";
  cmd->add_option("--delay-ms", *delay_ms, "hold every outgoing message this long [ms]")
      ->check(CLI::Range(0.0, 600000.0))
      ->group(group);
  cmd->add_option("--jitter-ms", *jitter_ms, "plus a random extra hold up to this [ms] (reorders messages)")
      ->check(CLI::Range(0.0, 600000.0))
      ->group(group);
  cmd->add_option("--duplicate-pct", *duplicate_pct, "send this percentage of messages twice")
      ->check(CLI::Range(0.0, 100.0))
      ->group(group);
}

}  // namespace commerge::app
