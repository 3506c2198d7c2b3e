// SPDX-License-Identifier: BSD-3-Clause
// Wiring shared by the subcommands: memory flags, the start-up budget check, peak-RSS reporting.
#pragma once

#include <CLI/CLI.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "core/agent/merge_server.hpp"
#include "core/agent/messages.hpp"
#include "core/descriptor/place_descriptor.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/slam/robot_mapper.hpp"
#include "core/memory/budget.hpp"
#include "platform/lcm/lcm_bus.hpp"

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

/// --solid-min-z-m for the subcommands that compute descriptors (robot, run): SolidParams::min_z_m, off
/// (-infinity) unless given.
void AddSolidMinZFlag(CLI::App* cmd, double* min_z_m);
/// The robots' place descriptor: --descriptor (ring: ours, the default; solid: the paper's SOLiD on the raw
/// scan), --descriptor-window-m (the ring descriptor's local map), --lidar and --solid-min-z-m (SOLiD's).
struct DescriptorFlags {
  std::string name = "ring";
  double window_m = -1.0;  ///< -1: the preset's (RingDescriptorInput)
  double solid_min_z_m = SolidParams{}.min_z_m;
  double tau_intra = -1.0;  ///< --tau-intra; -1: the descriptor's (DefaultTauIntra)
  /// --tau-window: the last this many keyframes are never intra-robot loop candidates (ours 30; the paper's 100
  /// keeps a robot of fewer than 100 keyframes from ever closing a loop; ICP from the graph's estimate and the
  /// drift bound check every candidate).
  std::uint32_t tau_window_keyframes = 30;
  /// --tau-icp [m^2]: an intra-robot loop candidate is accepted when ICP's mean squared inlier residual is at most
  /// this (LoopDetectorParams::max_icp_mean_squared_residual_m2). The paper's spinning value 0.3 for every sensor:
  /// the recall benchmark's forward-looking (Livox) scenarios were measured with it; the paper's non-repetitive
  /// 2.0 is `--tau-icp 2`.
  double tau_icp_m2 = 0.3;
  /// --min-scan-points: a keyframe scan that keeps fewer points at 1 m voxels is stored finer
  /// (RobotMapperParams::voxel.min_points; ours). Default 0 = the paper's 1 m: 1 000 (street scans of a spinning
  /// sensor stay at 1 m, corridors, caves and a forward-looking sensor's cone go to 0.5 m) merged no more robots
  /// in the recall benchmark, doubled the bytes of small scenes and let one more wrong corridor registration
  /// through (profiling/RESULTS.md "Scene-scaled voxels").
  std::size_t min_scan_points = 0;
  /// --odometry-roll-pitch-sigma-deg: how well the odometry knows a keyframe step's roll and pitch
  /// (RobotMapperParams::odometry_sigma_roll_pitch_rad, in degrees).
  double odometry_roll_pitch_sigma_deg = RobotMapperParams{}.odometry_sigma_roll_pitch_rad * 180.0 / kPi;
};
/// The robot's stored-scan voxel parameters from the flags (RobotMapperParams::voxel).
AdaptiveVoxelParams StoredScanVoxel(const DescriptorFlags& flags);
void AddDescriptorFlags(CLI::App* cmd, DescriptorFlags* flags);

/// The descriptor of one robot and what it is computed on.
struct RobotDescriptor {
  std::unique_ptr<PlaceDescriptor> descriptor;
  DescriptorInputParams input;
  double tau_intra = 0.05;  ///< the intra-robot loop gate for this descriptor (LoopDetectorParams)
  std::string text;  ///< for banners: "ring occupancy on the levelled scan and 5 m of local map", "SOLiD vlp-16, ..."
};
/// The ring descriptor's input for a sensor: levelled, with a 5 m local map for a forward-looking sensor (one
/// scan sees a narrow cone) and the keyframe's own scan for a spinning one.
DescriptorInputParams RingDescriptorInput(const std::string& lidar);
/// tau_intra (the intra-robot loop candidate gate on the descriptor distance) of a descriptor for a sensor:
/// SOLiD the paper's table (0.05 spinning, 0.01 non-repetitive); ring 0.15 (measured: true revisits' nearest
/// neighbours lie below 0.11 in 9 of 10 cases, false ones above 0.2 in 9 of 10; the ICP check decides).
double DefaultTauIntra(const std::string& descriptor, const std::string& lidar);
/// [deg] Headings within which two keyframes at one place see the same scene: a forward-looking sensor's
/// horizontal field of view (avia 70.4), 180 (any) for a spinning one or an unknown name. The server's
/// descriptor agreement (MergeServerParams::colocation) takes it.
double ColocationHeadingDeg(const std::string& lidar);
/// The paper's tau_inter for a sensor (its threshold table): 0.05 for a non-repetitive, 0.10 for a spinning one.
double PaperTauInter(const std::string& lidar);
/// Stage A's per-sensor default: when --tau-inter was not given (`tau_inter_given` false) and stage A thresholds
/// every cell (--neighbour-rank 0, the paper's stage A), tau_inter becomes PaperTauInter(lidar). With a neighbour
/// rank it stays a cap (MergeServerParams{}: 0.5, measured by the recall benchmark for every sensor).
void ApplySensorTauInter(bool tau_inter_given, const std::string& lidar, MergeServerParams* params);
/// The keyframe records of a --descriptor (scan-context: Scan Context records; ring and solid: 40 unit values).
KeyframeRecordKind RecordKindForDescriptor(const std::string& descriptor);
/// Floats per keyframe descriptor of a --descriptor (40, Scan Context 1200): MemoryFlags::descriptor_floats.
std::int32_t DescriptorFloatsFor(const std::string& descriptor);
/// Stage A's threshold and stage B's cover in words, for the start-up line of run and server:
/// "stage A tau_inter 0.05 per cell, stage B pairwise" or "stage A neighbour rank 1 under tau_inter 0.5, ...".
std::string CascadeSettingsText(const MergeServerParams& params);
/// Builds the descriptor named by the flags for a robot with `lidar`. Errors name the flag and value.
Result<RobotDescriptor> MakeRobotDescriptor(const DescriptorFlags& flags, const std::string& lidar);

/// The SOLiD preset named by --lidar with --solid-min-z-m applied, validated. Errors name the flag and value.
Result<SolidParams> SolidParamsFromFlags(const std::string& lidar, double min_z_m);
/// "every point" or "points below z -0.5 m left out", for banners and reports.
std::string SolidMinZText(const SolidParams& params);

/// The daemons' test-only fault injection on outgoing messages (platform::LcmBusParams): --delay-ms,
/// --jitter-ms (reorders), --duplicate-pct, in their own help group.
void AddFaultFlags(CLI::App* cmd, double* delay_ms, double* jitter_ms, double* duplicate_pct);

/// The daemons' message authentication and dry-run flags: --auth-key FILE (the team key file; without it,
/// messages are neither signed nor verified, and a warning says so) and --check.
struct AuthFlags {
  std::string key_file;
  bool check = false;  ///< validate everything, print the configuration, exit 0 without opening the network
};
void AddAuthFlags(CLI::App* cmd, AuthFlags* flags);

/// Loads --auth-key into `bus` (sender = robot id or platform::kAuthServerSender, session, robot ids
/// 0..robots-1 accepted). Returns kExitOk, or kExitUsage with the reason (naming the file) on stderr.
int SetUpAuth(const char* tag, const AuthFlags& flags, std::uint16_t sender, std::int64_t session, int robots,
              platform::LcmBusParams* bus);
/// One line for --check and the start-up banner: "messages signed with key 1 of 2 from FILE" or the warning.
std::string AuthDescription(const AuthFlags& flags, const platform::LcmBusParams& bus);
/// Refuses a message whose authenticated signer is not `expected` (a robot id, or kAuthServerSender): a team
/// member speaking for another. Unauthenticated messages (sender -1) pass.
Status CheckSigner(const platform::BusMessage& message, int expected);
/// Messages the bus refused for authentication (0 without authentication).
std::uint64_t AuthRejected(const platform::LcmBus& bus);
/// "auth: 1234 messages signed, 40 B each = 48.2 KiB (3.1 % of 1.5 MiB sent); 7 refused (bad MAC 3, replayed 4)"
/// or "auth: off".
std::string AuthSummary(const platform::LcmBus& bus);

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
