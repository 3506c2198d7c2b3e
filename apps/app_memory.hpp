// SPDX-License-Identifier: BSD-3-Clause
// Memory wiring of the subcommands that allocate: the board profile and sizing flags, the start-up budget check
// (and heap cap), the budget as status modules, peak RSS and the daemons' exit summary of memory.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "apps/app_common.hpp"
#include "core/agent/messages.hpp"
#include "core/memory/budget.hpp"

namespace commerge::app {

/// Board profile and memory-sizing flags, shared by every subcommand that allocates (budget, demo, ...).
struct MemoryFlags {
  std::string board = "desktop";
  std::int32_t robots = 0;          // 0 = the board default
  std::int32_t max_keyframes = 0;
  std::int64_t scan_store_mb = 0;
  std::int32_t max_submap_points = 0;
  std::int64_t merged_map_mb = 0;
  std::int64_t queue_mb = 0;
  std::int64_t solver_mb = 0;
  std::int64_t heap_cap_mb = 0;     // 0 = no hard cap
  std::int32_t descriptor_floats = 0;  // 0 = 40; set from --descriptor (1200 for scan-context), not a flag
  MissionExtent mission;               // `run`: the opened datasets (SizeMemoryForMission before the flags), not a flag
  std::string proc_root = "/proc";  // testing hooks: fake /proc and cgroup trees
  std::string cgroup_root = "/sys/fs/cgroup";
};

void AddMemoryFlags(CLI::App* cmd, MemoryFlags* flags);

/// Result of the start-up memory check of one app.
struct MemorySetup {
  BoardProfile board = BoardProfile::kDesktop;
  MemoryConfig config;
  BudgetTable table;
  bool fits = false;
  std::string table_text;  ///< FormatBudgetTable output
  std::string verdict;     ///< one line
  std::int64_t limit_bytes = 0;  ///< what the budget was checked against (board, MemAvailable, cgroup)
};

/// The budget table as status-message modules (budget only; used_bytes 0 = not measured), at most
/// kMaxStatusModules; `measured` fills used / high-water of the named modules.
std::vector<ModuleMemory> StatusModules(const BudgetTable& table, const std::vector<ModuleMemory>& measured);

/// Maps the flags onto a MemoryConfig for `app`, validates it, checks the budget against this machine and
/// applies the heap cap. Returns an exit code: kExitOk, kExitUsage (bad flag: message on stderr) or
/// kExitOverBudget (one line naming the module, its need and the limit on stderr).
int SetUpMemory(AppKind app, const MemoryFlags& flags, MemorySetup* setup, bool print_table);

/// "peak RSS 123.4 MiB (allocator mimalloc 2.0.9)".
std::string PeakRssLine();

/// The daemons' exit summary of memory (printed on stderr, also with --quiet): one row per module of `table`
/// with its budget, used and high-water bytes from `measured` ("-" = not measured, e.g. runtime), then the
/// process's peak RSS against the budget total and what remains after the measured pools' high-water marks (the
/// runtime, and pool pages that are resident but not in use, e.g. a pool zeroed at start-up). Every line
/// starts with "memory:"; each row ends with its exact figures "[budget used high-water]" in bytes (-1 = not
/// measured) for scripts (profiling/profile_town.sh).
std::string MemorySummary(const BudgetTable& table, const std::vector<ModuleMemory>& measured,
                          std::int64_t peak_rss_bytes);

}  // namespace commerge::app
