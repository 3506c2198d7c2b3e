// SPDX-License-Identifier: BSD-3-Clause
#include "apps/app_memory.hpp"

#include <algorithm>
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

void AddMemoryFlags(CLI::App* cmd, MemoryFlags* f) {
  cmd->add_option("--board", f->board, "Board profile: jetson-nano (4 GiB), ipc-6000 (8 GiB), desktop")
      ->check(CLI::IsMember({"jetson-nano", "ipc-6000", "desktop"}))
      ->capture_default_str();
  cmd->add_option("--robots", f->robots, "Robots one server keeps data for (default: per board)")
      ->check(CLI::Range(1, 64));
  cmd->add_option("--max-keyframes", f->max_keyframes, "Keyframes per robot the pools hold (default: run: what the datasets make; robot, server: per board)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--scan-store-mb", f->scan_store_mb, "Robot scan store size [MiB] (default: run: what the datasets fill, at most the board's; robot: per board)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--max-submap-points", f->max_submap_points,
                  "Points per submap on the server; larger submaps are voxelised coarser (default: 100000)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--merged-map-mb", f->merged_map_mb, "Merged map on the server [MiB]: its points and the builder's workspace; a full map leaves later scans "
                  "out and says how many (default: per board; run: at most what the datasets fill)")
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
  c = SizeMemoryForMission(DefaultMemoryConfig(s->board), f.mission);
  if (f.robots > 0) c.max_robots = f.robots;
  if (f.max_keyframes > 0) c.max_keyframes_per_robot = f.max_keyframes;
  if (f.scan_store_mb > 0) c.scan_store_bytes = f.scan_store_mb * kMiB;
  if (f.max_submap_points > 0) c.max_submap_points = f.max_submap_points;
  if (f.merged_map_mb > 0) c.merged_map_bytes = f.merged_map_mb * kMiB;
  if (f.queue_mb > 0) c.message_queue_bytes = f.queue_mb * kMiB;
  if (f.solver_mb > 0) c.solver_workspace_bytes = f.solver_mb * kMiB;
  if (f.descriptor_floats > 0) c.descriptor_floats = f.descriptor_floats;
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

std::string MemorySummary(const BudgetTable& table, const std::vector<ModuleMemory>& measured,
                          std::int64_t peak_rss_bytes) {
  auto mib = [](std::int64_t bytes) {
    char text[32];
    if (bytes < 0) return std::string("-");
    std::snprintf(text, sizeof text, "%.2f MiB", static_cast<double>(bytes) / static_cast<double>(kMiB));
    return std::string(text);
  };
  std::string out;
  char line[512];
  std::snprintf(line, sizeof line, "memory: %-18s %12s %12s %12s\n", "module", "budget", "used", "high-water");
  out += line;
  std::int64_t pools_bytes = 0;
  for (const BudgetEntry& e : table.entries()) {
    std::int64_t used = -1, high_water = -1;
    for (const ModuleMemory& m : measured) {
      if (m.name != e.module) continue;
      used = m.used_bytes;
      high_water = std::max(m.high_water_bytes, m.used_bytes);
    }
    if (high_water > 0) pools_bytes += high_water;
    std::snprintf(line, sizeof line, "memory: %-18s %12s %12s %12s  [%lld %lld %lld]\n", e.module.c_str(),
                  mib(e.bytes).c_str(), mib(used).c_str(), mib(high_water).c_str(), static_cast<long long>(e.bytes),
                  static_cast<long long>(used), static_cast<long long>(high_water));
    out += line;
  }
  const std::int64_t total = table.total_bytes();
  char rest[32] = "-";
  if (peak_rss_bytes >= 0) {
    std::snprintf(rest, sizeof rest, "%.2f MiB",
                  static_cast<double>(peak_rss_bytes - pools_bytes) / static_cast<double>(kMiB));
  }
  std::snprintf(line, sizeof line,
                "memory: peak RSS %s of the budget total %s (%.0f %%); the measured pools' high-water marks %s, the "
                "rest %s (runtime: code, libraries, stacks, allocator; pool pages reserved but not in use)  [%lld %lld]\n",
                mib(peak_rss_bytes).c_str(), mib(total).c_str(),
                total > 0 ? 100.0 * static_cast<double>(peak_rss_bytes) / static_cast<double>(total) : 0.0,
                mib(pools_bytes).c_str(), rest,
                static_cast<long long>(peak_rss_bytes), static_cast<long long>(total));
  out += line;
  return out;
}

}  // namespace commerge::app
