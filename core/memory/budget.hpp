// SPDX-License-Identifier: BSD-3-Clause
// commerge: memory budgets as data. Each app (robot, server, run) declares a table module -> bytes,
// computed from a MemoryConfig whose defaults depend on the board profile. platform/ compares the total
// against the board, MemAvailable and the cgroup limit at start-up, before any work starts; the pools of
// each module are then sized from the same table, so the check and the allocation cannot drift apart.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

enum class BoardProfile { kJetsonNano, kIpc6000, kDesktop };

struct BoardSpec {
  BoardProfile profile;
  const char* name;             ///< "jetson-nano", "ipc-6000", "desktop"
  std::int64_t ram_bytes;       ///< physical RAM; 0 = not fixed (desktop: only the host's limits apply)
  std::int64_t reserved_bytes;  ///< kept for the OS and co-running software (JetPack, CUDA, odometry)
  const char* description;
};

/// The three supported board profiles, in a fixed order.
Span<const BoardSpec> AllBoards();
const BoardSpec& GetBoard(BoardProfile profile);
/// Parses "jetson-nano" | "ipc-6000" | "desktop"; the error lists the valid names.
Result<BoardProfile> ParseBoardProfile(const std::string& name);

enum class AppKind { kRobot, kServer, kRun };  ///< kRun: robots and server in one process (`commerge run`)
const char* AppKindName(AppKind app);
Result<AppKind> ParseAppKind(const std::string& name);

/// Sizing inputs of the budget tables. Apps map their command-line flags onto these fields.
struct MemoryConfig {
  std::int32_t max_robots = 3;                       ///< robots whose data one server keeps
  std::int32_t max_keyframes_per_robot = 20000;      ///< keyframes (1 m apart: a 20 km mission)
  std::int32_t max_points_per_raw_scan = 131072;     ///< raw LiDAR points per scan (HDL-64E: ~120k)
  std::int32_t max_points_per_stored_scan = 8192;    ///< points of a 1 m voxelised scan
  std::int64_t scan_store_bytes = 160 * 1024 * 1024;  ///< robot: encoded voxelised scans kept for the server
  std::int32_t max_scans_in_flight = 512;            ///< server: requested scans being reassembled
  /// server: points of one submap (1 m voxels: about 300 x 300 m of street). Registration's workspace and time
  /// grow with it; larger submaps are voxelised coarser until both fit.
  std::int32_t max_submap_points = 100000;
  std::int64_t merged_map_bytes = 64 * 1024 * 1024;  ///< server: the merged global map
  std::int64_t message_queue_bytes = 8 * 1024 * 1024;     ///< outgoing/incoming message queues per process
  /// server: LP relaxations and branch-and-bound (0.3 MiB used at Town scale, profiling/RESULTS.md)
  std::int64_t solver_workspace_bytes = 32 * 1024 * 1024;
  /// Floats of one keyframe descriptor (40: SOLiD, the ring descriptor; 1200: Scan Context 20 x 60): the
  /// descriptor databases of robots and server hold one per keyframe (BudgetRecordSizes::DescriptorRecordBytes).
  std::int32_t descriptor_floats = 40;
};

/// Defaults sized for the board (the Jetson Nano defaults keep a robot under 384 MB and a server under 512 MB).
MemoryConfig DefaultMemoryConfig(BoardProfile profile);

/// What a process that opens its datasets before making its pools (`commerge run`) knows of the work: the
/// robots, the most keyframes one robot will make (its keyframer on its odometry) and the largest scan.
struct MissionExtent {
  std::int32_t robots = 0;                   ///< 0 = unknown: SizeMemoryForMission is not applied
  std::int32_t max_keyframes_per_robot = 0;  ///< keyframes of the robot that makes the most
  std::int32_t max_points_per_raw_scan = 0;  ///< points of the largest scan file
};

/// `board` (DefaultMemoryConfig) sized for `mission`: robots and keyframes as the mission needs them, raw points
/// at least the board's and more for larger scans (the start-up check then decides); the scan store, the scans
/// in flight and the merged map at most what the mission can fill, never more than `board`'s. Stored scans,
/// solver and queue sizes stay the board's.
MemoryConfig SizeMemoryForMission(const MemoryConfig& board, const MissionExtent& mission);
/// Every field positive and below a sanity cap; the error names the field and its value.
Status ValidateMemoryConfig(const MemoryConfig& config);

struct BudgetEntry {
  std::string module;  ///< e.g. "scan_store"
  std::int64_t bytes = 0;
  std::string basis;   ///< how the figure is computed, with the flag that changes it
};

class BudgetTable {
 public:
  void Add(std::string module, std::int64_t bytes, std::string basis);
  Span<const BudgetEntry> entries() const { return Span<const BudgetEntry>(entries_); }
  std::int64_t total_bytes() const;
  /// nullptr when absent.
  const BudgetEntry* Find(const std::string& module) const;

 private:
  std::vector<BudgetEntry> entries_;
};

/// Per-record sizes that the budget formulas use (exact sizes of the structures the modules hold).
struct BudgetRecordSizes {
  static constexpr std::int64_t kDescriptorRecordBytes = 512;  ///< R-SOLiD + A-SOLiD floats, pose, index
  /// A keyframe of the descriptor databases with `floats` descriptor values: kDescriptorRecordBytes for up to 40,
  /// 4 B more per value beyond (Scan Context's 1200: 5 152 B).
  static constexpr std::int64_t DescriptorRecordBytes(std::int32_t floats) noexcept {
    return kDescriptorRecordBytes + 4 * (floats > 40 ? static_cast<std::int64_t>(floats) - 40 : 0);
  }
  /// The server's decoded compact keyframe batch: 512 keyframes x sizeof(CompactKeyframe) (at most 320 B,
  /// checked in core/agent/keyframe_database.cpp).
  static constexpr std::int64_t kCompactBatchScratchBytes = 512 * 320;
  /// Node (128 B), the mapper's odometry pose (128 B), its edges (432 B each: odometry and loops) and the sparse
  /// solver's workspace (~2.4 kB per node on a plain circuit, profiling/bench_pose_graph; more with the fill-in
  /// of many loops). Sized for the worst case the pose-graph test measures: 5.3 kB with a loop at every
  /// keyframe.
  static constexpr std::int64_t kPoseGraphBytesPerKeyframe = 5632;
  /// Per raw point of capacity: the voxel grid's workspace (32 B, for the joined cloud of the descriptor input
  /// twice that: 64 B), the voxelised and encoded copies of a stored scan and the finer attempt of the
  /// scene-scaled voxel size (38 B, when a stored scan may be as large as a raw one), and the descriptor input
  /// (RobotMapper: the joined cloud of up to two raw scans 32 B, the local map's points of at most one raw scan
  /// 16 B, the voxelised joined cloud 32 B, the ground fit's z values 4 B), rounded up. Measured worst case
  /// (stored = raw capacity, 10 m local map, scene-scaled voxels on): 186 B (test_robot_mapper).
  static constexpr std::int64_t kRawPointWorkBytes = 192;
  static constexpr std::int64_t kStoredPointBytes = 6;    ///< int16 centimetres x 3
  /// A scan in a robot's scan store: its record header (8 B), the encoded scan's header (12 B) and points, and
  /// its index entry (16 B); ScanStore checks these against its layout.
  static constexpr std::int64_t kStoredScanOverheadBytes = 8 + 12 + 16;
  static constexpr std::int64_t StoredScanBytes(std::int64_t points) noexcept {
    return kStoredScanOverheadBytes + kStoredPointBytes * points;
  }
  /// Submaps (MergeServer::BuildSubmap): the union of a submap's scans is voxelised once it holds more than this
  /// many submaps' worth of points, so it, the voxel grid's workspace (32 B a point) and each voxelised submap
  /// (16 B a point) hold at most that plus one scan.
  static constexpr std::int64_t kSubmapUnionFactor = 4;
  static constexpr std::int64_t kSubmapUnionPointBytes = 16 + 32 + 2 * 16;
  /// A point of the merged map: x, y, z, intensity (16 B) and its robot id (2 B).
  static constexpr std::int64_t kMergedMapPointBytes = 18;
  /// Loop check per point of the two scans: k-d trees and ICP scratch, plus the GICP refinement's neighbour
  /// lists (10 per point), normals, covariances and factors; ~330 B on 1 800-point VLP-16 scans (LoopVerifier
  /// test).
  static constexpr std::int64_t kIcpPointBytes = 384;
  /// The loop check's path lengths (KeyframeGraphDistance): link 8, CSR 12, steps and frontiers 16 B, rounded.
  static constexpr std::int64_t kLoopPathBytesPerKeyframe = 40;
  /// Registration per point of each submap: k-d tree, neighbour lists, normals, GICP covariances, SPFH and
  /// FPFH-style features, the matcher's descriptor copies and GICP's target data: ~1.07 kB on generated street
  /// submaps (Merge server memory test).
  static constexpr std::int64_t kRegistrationPointBytes = 1152;
  /// The bird's-eye-view fallback's grids (BevSearch: ~44 x grid_cells^2 bytes at its 256-cell default).
  static constexpr std::int64_t kRegistrationGridBytes = 3 * 1024 * 1024;
  static constexpr std::int64_t kRuntimeBytes = 48 * 1024 * 1024;  ///< code, stacks, LCM/glib, allocator segments
};

/// The budget table of `app` for `config`.
BudgetTable MakeBudgetTable(AppKind app, const MemoryConfig& config);

/// The byte limit a process may plan for, and where it comes from.
struct BudgetLimit {
  std::int64_t bytes = 0;
  std::string source;  ///< e.g. "jetson-nano board (4.00 GiB RAM - 1.25 GiB reserved) x 0.90"
};

/// min(board RAM - reserved, MemAvailable, cgroup limit) x headroom. Pass -1 for an unknown MemAvailable or
/// an absent cgroup limit. `headroom` in (0, 1] keeps a margin for what the table does not model.
BudgetLimit EffectiveLimit(const BoardSpec& board, std::int64_t mem_available_bytes, std::int64_t cgroup_limit_bytes,
                           double headroom = 0.9);

struct BudgetVerdict {
  bool fits = false;
  std::int64_t total_bytes = 0;
  std::int64_t limit_bytes = 0;
  std::string largest_module;  ///< the module to shrink first when over budget
  std::int64_t largest_module_bytes = 0;
  /// One line: "... fits: 272 MiB of 2.47 GiB ..." or "over memory budget: module 'x' needs ..."
  std::string message;
};

BudgetVerdict CheckBudget(AppKind app, const BudgetTable& table, const BudgetLimit& limit);

}  // namespace commerge
