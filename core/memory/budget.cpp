// SPDX-License-Identifier: BSD-3-Clause
#include "core/memory/budget.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/common/bytes.hpp"
#include "core/memory/consensus_bound.hpp"

namespace commerge {

namespace {

constexpr BoardSpec kBoards[] = {
    {BoardProfile::kJetsonNano, "jetson-nano", 4 * kGiB, 1280 * kMiB,
     "NVIDIA Jetson Nano, 4 GiB shared with the GPU; 1.25 GiB kept for JetPack, CUDA and odometry"},
    {BoardProfile::kIpc6000, "ipc-6000", 8 * kGiB, 2 * kGiB,
     "IPC-6000 class x86-64 (i5-8265U), 8 GiB; 2 GiB kept for the OS and the odometry stack"},
    {BoardProfile::kDesktop, "desktop", 0, 0, "workstation or server: only MemAvailable and cgroup limits apply"},
};

std::string Str(std::int64_t v) { return std::to_string(v); }

}  // namespace

Span<const BoardSpec> AllBoards() { return Span<const BoardSpec>(kBoards); }

const BoardSpec& GetBoard(BoardProfile profile) {
  for (const BoardSpec& b : kBoards) {
    if (b.profile == profile) return b;
  }
  return kBoards[2];
}

Result<BoardProfile> ParseBoardProfile(const std::string& name) {
  for (const BoardSpec& b : kBoards) {
    if (name == b.name) return b.profile;
  }
  return InvalidArgument("unknown board profile '" + name + "' (valid: jetson-nano, ipc-6000, desktop)");
}

const char* AppKindName(AppKind app) {
  switch (app) {
    case AppKind::kRobot: return "robot";
    case AppKind::kServer: return "server";
    case AppKind::kRun: return "run";
  }
  return "?";
}

Result<AppKind> ParseAppKind(const std::string& name) {
  for (AppKind a : {AppKind::kRobot, AppKind::kServer, AppKind::kRun}) {
    if (name == AppKindName(a)) return a;
  }
  return InvalidArgument("unknown app '" + name + "' (valid: robot, server, run)");
}

MemoryConfig DefaultMemoryConfig(BoardProfile profile) {
  MemoryConfig c;  // the struct defaults are the Jetson Nano ones
  switch (profile) {
    case BoardProfile::kJetsonNano:
      break;
    case BoardProfile::kIpc6000:
      c.max_robots = 5;
      c.max_keyframes_per_robot = 50000;
      c.scan_store_bytes = 512 * kMiB;
      c.max_scans_in_flight = 1024;
      c.merged_map_bytes = 256 * kMiB;
      c.message_queue_bytes = 16 * kMiB;
      c.solver_workspace_bytes = 256 * kMiB;
      break;
    case BoardProfile::kDesktop:
      c.max_robots = 8;
      c.max_keyframes_per_robot = 100000;
      c.scan_store_bytes = 512 * kMiB;
      c.max_scans_in_flight = 2048;
      c.merged_map_bytes = 512 * kMiB;
      c.message_queue_bytes = 32 * kMiB;
      c.solver_workspace_bytes = 256 * kMiB;
      break;
  }
  return c;
}

MemoryConfig SizeMemoryForMission(const MemoryConfig& board, const MissionExtent& mission) {
  using R = BudgetRecordSizes;
  MemoryConfig c = board;
  if (mission.robots <= 0) return c;
  c.max_robots = mission.robots;
  c.max_keyframes_per_robot = std::max<std::int32_t>(1, mission.max_keyframes_per_robot);
  // Raw and stored scan capacities never shrink below the board's: the mapper's local map (the ring descriptor's
  // input) is bounded by the raw capacity, so a smaller one would change the descriptors.
  c.max_points_per_raw_scan = std::max(board.max_points_per_raw_scan, mission.max_points_per_raw_scan);
  const std::int64_t keyframes = c.max_keyframes_per_robot;
  const std::int64_t all_keyframes = keyframes * c.max_robots;
  c.scan_store_bytes = std::min(board.scan_store_bytes, keyframes * R::StoredScanBytes(c.max_points_per_stored_scan));
  c.max_scans_in_flight =
      static_cast<std::int32_t>(std::min<std::int64_t>(board.max_scans_in_flight, all_keyframes));
  // Every stored point of every robot in the map, and the builder's batch (MergedMapParamsForBytes: a quarter).
  const std::int64_t map_points = all_keyframes * c.max_points_per_stored_scan;
  c.merged_map_bytes = std::min(board.merged_map_bytes, map_points * R::kMergedMapPointBytes * 4 / 3);
  return c;
}

Status ValidateMemoryConfig(const MemoryConfig& c) {
  struct Field {
    const char* name;
    std::int64_t value;
    std::int64_t max;
  };
  const Field fields[] = {
      {"max_robots", c.max_robots, 64},
      {"max_keyframes_per_robot", c.max_keyframes_per_robot, 10000000},
      {"max_points_per_raw_scan", c.max_points_per_raw_scan, 16 * 1024 * 1024},
      {"max_points_per_stored_scan", c.max_points_per_stored_scan, 16 * 1024 * 1024},
      {"scan_store_bytes", c.scan_store_bytes, 1024 * kGiB},
      {"max_scans_in_flight", c.max_scans_in_flight, 10000000},
      {"max_submap_points", c.max_submap_points, 1000000000},
      {"merged_map_bytes", c.merged_map_bytes, 1024 * kGiB},
      {"message_queue_bytes", c.message_queue_bytes, 1024 * kGiB},
      {"solver_workspace_bytes", c.solver_workspace_bytes, 1024 * kGiB},
      {"descriptor_floats", c.descriptor_floats, 65536},
  };
  for (const Field& f : fields) {
    if (f.value <= 0 || f.value > f.max) {
      return InvalidArgument(std::string("memory config: ") + f.name + " = " + Str(f.value) + " is outside [1, " +
                             Str(f.max) + "]");
    }
  }
  return Status::Ok();
}

void BudgetTable::Add(std::string module, std::int64_t bytes, std::string basis) {
  entries_.push_back(BudgetEntry{std::move(module), bytes, std::move(basis)});
}

std::int64_t BudgetTable::total_bytes() const {
  std::int64_t total = 0;
  for (const BudgetEntry& e : entries_) total += e.bytes;
  return total;
}

const BudgetEntry* BudgetTable::Find(const std::string& module) const {
  for (const BudgetEntry& e : entries_) {
    if (e.module == module) return &e;
  }
  return nullptr;
}

namespace {

using Sizes = BudgetRecordSizes;

// Modules of one robot; `prefix` is "" for a robot process, "robots." in `commerge run`; `n` robots.
void AddRobotModules(BudgetTable* t, const MemoryConfig& c, const std::string& prefix, std::int64_t n) {
  const std::string times = n > 1 ? " x " + Str(n) + " robots" : "";
  const std::int64_t k = c.max_keyframes_per_robot;
  const std::int64_t record = Sizes::DescriptorRecordBytes(c.descriptor_floats);
  t->Add(prefix + "descriptor_db", n * k * record,
         Str(k) + " keyframes (--max-keyframes) x " + Str(record) + " B" + times);
  t->Add(prefix + "pose_graph", n * k * Sizes::kPoseGraphBytesPerKeyframe,
         Str(k) + " keyframes x " + Str(Sizes::kPoseGraphBytesPerKeyframe) + " B" + times);
  t->Add(prefix + "scan_store", n * c.scan_store_bytes, "--scan-store-mb" + times);
  t->Add(prefix + "scan_workspace", n * c.max_points_per_raw_scan * Sizes::kRawPointWorkBytes,
         Str(c.max_points_per_raw_scan) + " raw points x " + Str(Sizes::kRawPointWorkBytes) + " B" + times);
  t->Add(prefix + "loop_closure",
         n * (2 * c.max_points_per_stored_scan * Sizes::kIcpPointBytes + k * Sizes::kLoopPathBytesPerKeyframe),
         "2 scans x " + Str(c.max_points_per_stored_scan) + " points x " + Str(Sizes::kIcpPointBytes) + " B + " + Str(k) +
             " keyframes x " + Str(Sizes::kLoopPathBytesPerKeyframe) + " B" + times);
  t->Add(prefix + "outbox", n * c.message_queue_bytes, "--queue-mb" + times);
}

void AddServerModules(BudgetTable* t, const MemoryConfig& c, const std::string& prefix) {
  const std::int64_t r = c.max_robots;
  const std::int64_t k = c.max_keyframes_per_robot;
  const std::int64_t record = Sizes::DescriptorRecordBytes(c.descriptor_floats);
  t->Add(prefix + "descriptor_db", r * k * record + Sizes::kCompactBatchScratchBytes,
         Str(r) + " robots (--robots) x " + Str(k) + " keyframes x " + Str(record) + " B + one compact batch " +
             Str(Sizes::kCompactBatchScratchBytes) + " B");
  // Streaming affinity: two 256x256 float tiles plus O(N + M) labelling state per robot pair.
  const std::int64_t pairs = r * (r - 1) / 2;
  // Place consensus: one pair's cluster set at a time, at most kServerConsensusMaxCells cells.
  const auto consensus_bytes = static_cast<std::int64_t>(kServerConsensusMaxCells * kConsensusCellBytes);
  t->Add(prefix + "affinity", 2 * 256 * 256 * 4 + std::max<std::int64_t>(pairs, 1) * 2 * k * 64 + consensus_bytes,
         "2 tiles of 256x256 floats + " + Str(std::max<std::int64_t>(pairs, 1)) + " pairs x 2 x " + Str(k) +
             " x 64 B of labelling state + " + Str(static_cast<std::int64_t>(kServerConsensusMaxCells)) + " x " +
             Str(static_cast<std::int64_t>(kConsensusCellBytes)) + " B of one pair's place-consensus clusters");
  t->Add(prefix + "solvers", c.solver_workspace_bytes, "--solver-mb");
  t->Add(prefix + "scan_reassembly", c.max_scans_in_flight * c.max_points_per_stored_scan * Sizes::kStoredPointBytes,
         Str(c.max_scans_in_flight) + " scans x " + Str(c.max_points_per_stored_scan) + " points x " +
             Str(Sizes::kStoredPointBytes) + " B");
  // The union of one submap's scans, the grid's workspace and both voxelised submaps (each at most the union),
  // one decoded scan, and each submap's scan origins (24 B a selected keyframe).
  const std::int64_t union_points = Sizes::kSubmapUnionFactor * c.max_submap_points + c.max_points_per_stored_scan;
  t->Add(prefix + "submaps",
         union_points * Sizes::kSubmapUnionPointBytes + 16 * std::int64_t{c.max_points_per_stored_scan} + 2 * 24 * k,
         "(" + Str(Sizes::kSubmapUnionFactor) + " x " + Str(c.max_submap_points) + " points (--max-submap-points) + " +
             Str(c.max_points_per_stored_scan) + ") x " + Str(Sizes::kSubmapUnionPointBytes) +
             " B of union, grid and both submaps + one scan + 2 x " + Str(k) + " scan origins x 24 B");
  t->Add(prefix + "registration",
         2 * std::int64_t{c.max_submap_points} * Sizes::kRegistrationPointBytes + Sizes::kRegistrationGridBytes,
         "2 submaps x " + Str(c.max_submap_points) + " points x " + Str(Sizes::kRegistrationPointBytes) + " B + " +
             Str(Sizes::kRegistrationGridBytes) + " B of bird's-eye-view grids");
  t->Add(prefix + "merged_map", c.merged_map_bytes, "--merged-map-mb");
  t->Add(prefix + "inbox", c.message_queue_bytes, "--queue-mb");
}

}  // namespace

BudgetTable MakeBudgetTable(AppKind app, const MemoryConfig& c) {
  BudgetTable t;
  switch (app) {
    case AppKind::kRobot:
      AddRobotModules(&t, c, "", 1);
      break;
    case AppKind::kServer:
      AddServerModules(&t, c, "");
      break;
    case AppKind::kRun:
      AddRobotModules(&t, c, "robots.", c.max_robots);
      AddServerModules(&t, c, "server.");
      break;
  }
  t.Add("runtime", Sizes::kRuntimeBytes, "code, stacks, LCM/glib, allocator segments");
  return t;
}

BudgetLimit EffectiveLimit(const BoardSpec& board, std::int64_t mem_available_bytes, std::int64_t cgroup_limit_bytes,
                           double headroom) {
  if (!(headroom > 0.0) || headroom > 1.0) headroom = 0.9;
  std::int64_t raw = -1;
  std::string source;
  auto consider = [&](std::int64_t bytes, const std::string& what) {
    if (bytes <= 0) return;
    if (raw < 0 || bytes < raw) {
      raw = bytes;
      source = what;
    }
  };
  if (board.ram_bytes > 0) {
    consider(board.ram_bytes - board.reserved_bytes, std::string(board.name) + " board (" + FormatBytes(board.ram_bytes) +
                                                         " RAM - " + FormatBytes(board.reserved_bytes) + " reserved)");
  }
  consider(mem_available_bytes, "MemAvailable (" + FormatBytes(mem_available_bytes) + ")");
  consider(cgroup_limit_bytes, "cgroup memory limit (" + FormatBytes(cgroup_limit_bytes) + ")");
  BudgetLimit limit;
  if (raw < 0) {
    limit.bytes = 0;
    limit.source = "no limit known (no board RAM, MemAvailable or cgroup figure)";
    return limit;
  }
  limit.bytes = static_cast<std::int64_t>(std::floor(static_cast<double>(raw) * headroom));
  char factor[32];
  std::snprintf(factor, sizeof factor, " x %.2f", headroom);
  limit.source = source + factor;
  return limit;
}

BudgetVerdict CheckBudget(AppKind app, const BudgetTable& table, const BudgetLimit& limit) {
  BudgetVerdict v;
  v.total_bytes = table.total_bytes();
  v.limit_bytes = limit.bytes;
  for (const BudgetEntry& e : table.entries()) {
    if (e.bytes > v.largest_module_bytes) {
      v.largest_module_bytes = e.bytes;
      v.largest_module = e.module;
    }
  }
  v.fits = limit.bytes > 0 && v.total_bytes <= limit.bytes;
  const std::string app_name = AppKindName(app);
  if (v.fits) {
    v.message = "memory budget of " + app_name + " fits: " + FormatBytes(v.total_bytes) + " of " +
                FormatBytes(limit.bytes) + " (" + limit.source + ")";
  } else if (limit.bytes <= 0) {
    v.message = "over memory budget: no memory limit could be determined for " + app_name + " (" + limit.source + ")";
  } else {
    const BudgetEntry* largest = table.Find(v.largest_module);
    v.message = "over memory budget: module '" + v.largest_module + "' needs " + FormatBytes(v.largest_module_bytes) +
                " (" + (largest ? largest->basis : std::string()) + "); " + app_name + " total " +
                FormatBytes(v.total_bytes) + " exceeds the limit " + FormatBytes(limit.bytes) + " (" + limit.source +
                ")";
  }
  return v;
}

}  // namespace commerge
