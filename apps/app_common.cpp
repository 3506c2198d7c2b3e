// SPDX-License-Identifier: BSD-3-Clause
#include "apps/app_common.hpp"

#include <cstdio>

#include "core/common/bytes.hpp"
#include "platform/memory/allocator.hpp"
#include "platform/memory/budget_check.hpp"
#include "platform/memory/memory_limits.hpp"
#include "platform/memory/peak_rss.hpp"

namespace commerge::app {

std::vector<ModuleMemory> StatusModules(const BudgetTable& table, const std::vector<ModuleMemory>& measured) {
  std::vector<ModuleMemory> out;
  for (const BudgetEntry& e : table.entries()) {
    if (out.size() == kMaxStatusModules) break;
    ModuleMemory m;
    m.name = e.module.substr(0, kMaxStatusTextBytes);
    m.budget_bytes = e.bytes;
    for (const ModuleMemory& x : measured) {
      if (x.name == e.module) {
        m.used_bytes = x.used_bytes;
        m.high_water_bytes = x.high_water_bytes;
      }
    }
    out.push_back(std::move(m));
  }
  return out;
}

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

void AddMemoryFlags(CLI::App* cmd, MemoryFlags* f) {
  cmd->add_option("--board", f->board, "Board profile: jetson-nano (4 GiB), ipc-6000 (8 GiB), desktop")
      ->check(CLI::IsMember({"jetson-nano", "ipc-6000", "desktop"}))
      ->capture_default_str();
  cmd->add_option("--robots", f->robots, "Robots one server keeps data for (default: per board)")
      ->check(CLI::Range(1, 64));
  cmd->add_option("--max-keyframes", f->max_keyframes, "Keyframes per robot the pools hold (default: per board)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--scan-store-mb", f->scan_store_mb, "Robot scan store size [MiB] (default: per board)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--max-submap-points", f->max_submap_points, "Points per submap on the server (default: per board)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--merged-map-mb", f->merged_map_mb, "Merged map size on the server [MiB] (default: per board)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--queue-mb", f->queue_mb, "Message queue bytes per process [MiB] (default: per board)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--solver-mb", f->solver_mb, "Solver workspace on the server [MiB] (default: per board)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--heap-cap-mb", f->heap_cap_mb,
                  "Hard heap cap [MiB]: allocations beyond it fail with an out-of-memory error (exit 4) "
                  "instead of waking the OOM killer (default: none)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--proc-root", f->proc_root, "Testing: read meminfo/cgroup from this /proc")->group("");
  cmd->add_option("--cgroup-root", f->cgroup_root, "Testing: cgroup filesystem root")->group("");
}

int SetUpMemory(AppKind app, const MemoryFlags& f, MemorySetup* s, bool print_table) {
  auto board = ParseBoardProfile(f.board);
  if (!board.ok()) {
    std::fprintf(stderr, "commerge: --board: %s\n", board.status().message().c_str());
    return kExitUsage;
  }
  s->board = *board;
  MemoryConfig& c = s->config;
  c = DefaultMemoryConfig(s->board);
  if (f.robots > 0) c.max_robots = f.robots;
  if (f.max_keyframes > 0) c.max_keyframes_per_robot = f.max_keyframes;
  if (f.scan_store_mb > 0) c.scan_store_bytes = f.scan_store_mb * kMiB;
  if (f.max_submap_points > 0) c.max_submap_points = f.max_submap_points;
  if (f.merged_map_mb > 0) c.merged_map_bytes = f.merged_map_mb * kMiB;
  if (f.queue_mb > 0) c.message_queue_bytes = f.queue_mb * kMiB;
  if (f.solver_mb > 0) c.solver_workspace_bytes = f.solver_mb * kMiB;
  if (Status st = ValidateMemoryConfig(c); !st.ok()) {
    std::fprintf(stderr, "commerge: %s\n", st.message().c_str());
    return kExitUsage;
  }
  s->table = MakeBudgetTable(app, c);
  platform::ProbeRoots roots;
  roots.proc = f.proc_root;
  roots.cgroup_fs = f.cgroup_root;
  const platform::StartupBudget check =
      platform::CheckStartupBudget(app, GetBoard(s->board), s->table, platform::ProbeMemoryLimits(roots));
  s->fits = check.verdict.fits;
  s->verdict = check.verdict.message;
  s->limit_bytes = check.verdict.limit_bytes;
  s->table_text = platform::FormatBudgetTable(s->table, check);
  if (print_table) {
    std::printf("memory budget: %s on %s\n%s", AppKindName(app), f.board.c_str(), s->table_text.c_str());
  }
  if (!s->fits) {
    std::fprintf(stderr, "commerge: %s\n", s->verdict.c_str());
    return kExitOverBudget;
  }
  if (f.heap_cap_mb > 0) {
    if (Status st = platform::CapHeap(f.heap_cap_mb * kMiB); !st.ok()) {
      std::fprintf(stderr, "commerge: --heap-cap-mb: %s\n", st.message().c_str());
      return kExitUsage;
    }
  }
  return kExitOk;
}

std::string PeakRssLine() {
  const platform::RssFigures rss = platform::ReadRss();
  return "peak RSS " + FormatBytes(rss.peak_bytes) + " (allocator: " + platform::AllocatorDescription() + ")";
}

}  // namespace commerge::app
