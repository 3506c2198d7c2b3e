// SPDX-License-Identifier: BSD-3-Clause
#include "apps/app_common.hpp"

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <optional>

#include "core/common/bytes.hpp"
#include "core/common/number_text.hpp"
#include "core/descriptor/ring_occupancy.hpp"
#include "core/descriptor/scan_context.hpp"
#include "core/descriptor/solid.hpp"
#include "platform/memory/allocator.hpp"
#include "platform/memory/budget_check.hpp"
#include "platform/memory/memory_limits.hpp"
#include "platform/memory/peak_rss.hpp"

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

void AddAuthFlags(CLI::App* cmd, AuthFlags* flags) {
  cmd->add_option("--auth-key", flags->key_file,
                  "team key file (mode 0600, from `commerge keygen`): every message is signed and every received one "
                  "verified; without it nothing is authenticated")
      ->check(CLI::ExistingFile);
  cmd->add_flag("--check", flags->check,
                "check the flags, the key file and the memory budget, print the configuration and exit (0 = it would "
                "start) without touching the network");
}

int SetUpAuth(const char* tag, const AuthFlags& flags, std::uint16_t sender, std::int64_t session, int robots,
              platform::LcmBusParams* bus) {
  bus->authenticate = false;
  if (flags.key_file.empty()) return kExitOk;
  auto ring = platform::LoadTeamKeyring(flags.key_file);
  if (!ring.ok()) {
    std::fprintf(stderr, "%s: --auth-key: %s\n", tag, ring.status().message().c_str());
    return kExitUsage;
  }
  bus->authenticate = true;
  bus->auth.keyring = std::move(*ring);
  bus->auth.sender = sender;
  bus->auth.session = session;
  bus->auth.max_robots = static_cast<std::uint16_t>(std::clamp(robots, 1, int{platform::kAuthMaxRobots}));
  if (auto check = platform::MessageAuthenticator::Create(bus->auth); !check.ok()) {
    std::fprintf(stderr, "%s: --auth-key %s: %s\n", tag, flags.key_file.c_str(), check.status().message().c_str());
    return kExitUsage;
  }
  return kExitOk;
}

std::string AuthDescription(const AuthFlags& flags, const platform::LcmBusParams& bus) {
  if (!bus.authenticate) {
    return "WARNING: messages are NOT authenticated (no --auth-key): anyone on the network can publish on the "
           "commerge channels";
  }
  return "messages signed with key id " + std::to_string(bus.auth.keyring.keys.front().id) + " (" +
         std::to_string(bus.auth.keyring.keys.size()) + " key(s) accepted) from " + flags.key_file;
}

Status CheckSigner(const platform::BusMessage& message, int expected) {
  if (message.sender < 0 || message.sender == expected) return Status::Ok();
  auto name = [](int id) {
    return id == platform::kAuthServerSender ? std::string("the server") : "robot " + std::to_string(id);
  };
  return InvalidArgument("signed by " + name(message.sender) + " but speaks for " + name(expected));
}

std::uint64_t AuthRejected(const platform::LcmBus& bus) {
  const std::optional<platform::AuthStats> a = bus.auth_stats();
  return a ? a->rejected() : 0;
}

std::string AuthSummary(const platform::LcmBus& bus) {
  const std::optional<platform::AuthStats> a = bus.auth_stats();
  if (!a) return "auth: off";
  const std::uint64_t published_bytes = bus.stats().published_bytes;
  const double sent = static_cast<double>(published_bytes);
  char head[256];
  std::snprintf(head, sizeof(head), "auth: %llu messages signed, %zu B each = %s (%.1f %% of %s sent); %llu refused",
                static_cast<unsigned long long>(a->signed_messages), platform::kAuthTrailerBytes,
                FormatBytes(static_cast<std::int64_t>(a->trailer_bytes)).c_str(),
                sent > 0 ? 100.0 * static_cast<double>(a->trailer_bytes) / sent : 0.0,
                FormatBytes(static_cast<std::int64_t>(published_bytes)).c_str(), static_cast<unsigned long long>(a->rejected()));
  std::string out = head;
  std::string detail;
  for (std::size_t v = 0; v < platform::kAuthVerdictCount; ++v) {
    const auto verdict = static_cast<platform::AuthVerdict>(v);
    if (verdict == platform::AuthVerdict::kOk || verdict == platform::AuthVerdict::kOwnEcho || a->verdicts[v] == 0) {
      continue;
    }
    detail += (detail.empty() ? "" : ", ") + std::string(platform::AuthVerdictName(verdict)) + " " +
              std::to_string(a->verdicts[v]);
  }
  if (!detail.empty()) out += " (" + detail + ")";
  return out;
}

void AddSolidMinZFlag(CLI::App* cmd, double* min_z_m) {
  cmd->add_option("--solid-min-z-m", *min_z_m,
                  "leave points below this z of the sensor frame out of the SOLiD descriptor (our extension; "
                  "default: off, every point as the paper). About -0.5 on a sensor 1.8 m up drops the ground, "
                  "whose rings move with roll and pitch; raise --tau-inter with it on the server (see core/README.md, "
                  "\"SOLiD without the ground\"). Every robot of a team needs the same value")
      ->check(CLI::Range(-1000.0, 1000.0));
}

void AddDescriptorFlags(CLI::App* cmd, DescriptorFlags* flags) {
  cmd->add_option("--descriptor", flags->name,
                  "the robots' place descriptor: ring (ours: occupancy of range rings by height above the ground, "
                  "on the levelled scan), solid (the paper's SOLiD on the raw scan) or scan-context (Kim & Kim's "
                  "20 x 60 Scan Context on the raw scan, 1226-byte keyframe records); every robot of a team and the "
                  "server need the same")
      ->check(CLI::IsMember({"ring", "solid", "scan-context"}))
      ->capture_default_str();
  cmd->add_option("--descriptor-window-m", flags->window_m,
                  "ring descriptor: the keyframes of the last this many metres of path join the scan (default: 5 "
                  "for a forward-looking --lidar such as avia, 0 for a spinning one) [m]")
      ->check(CLI::Range(-1.0, 50.0));
  AddSolidMinZFlag(cmd, &flags->solid_min_z_m);
  cmd->add_option("--tau-intra", flags->tau_intra,
                  "intra-robot loops: a keyframe's nearest earlier keyframe is a loop candidate (then checked by ICP) "
                  "when its descriptor distance is at most this (default: 0.15 for ring; SOLiD the paper's 0.05 for "
                  "a spinning, 0.01 for a non-repetitive --lidar; scan-context 0.2, the Scan Context distance's usual "
                  "loop threshold, not measured here) [unit-vector L2 distance; Scan Context distance; paper: "
                  "tau_intra]")
      ->check(CLI::Range(0.0, 2.0));
  cmd->add_option("--tau-window", flags->tau_window_keyframes,
                  "intra-robot loops: the last this many keyframes are never candidates (paper: tau_window = 100)"
                  " [keyframes]")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd->add_option("--tau-icp", flags->tau_icp_m2,
                  "intra-robot loops: ICP accepts a candidate when the mean squared residual of its inliers is at "
                  "most this (the paper's spinning value for every --lidar; its non-repetitive column says 2.0) "
                  "[m^2; paper: tau_ICP]")
      ->check(CLI::Range(1e-4, 100.0))
      ->capture_default_str();
  cmd->add_option("--odometry-roll-pitch-sigma-deg", flags->odometry_roll_pitch_sigma_deg,
                  "the odometry's uncertainty of a keyframe step's roll and pitch in the robot's pose graph (yaw: "
                  "0.29 deg). LiDAR-inertial odometry (FAST-LIO2, the paper's) keeps them by gravity; without an IMU "
                  "use 0.29 [deg]")
      ->check(CLI::Range(1e-5, 10.0))
      ->capture_default_str();
  cmd->add_option("--min-scan-points", flags->min_scan_points,
                  "stored keyframe scans: a scan that keeps fewer points than this at 1 m voxels (the paper's "
                  "Delta nu) is stored finer, in steps of 1/sqrt(2) down to 0.25 m, so small scenes and "
                  "forward-looking sensors keep enough points to register (try 1000 with --min-submap-points 4000); "
                  "0 = always 1 m (the paper) [points; ours]")
      ->check(CLI::Range(0, 1000000))
      ->capture_default_str();
}

AdaptiveVoxelParams StoredScanVoxel(const DescriptorFlags& flags) {
  AdaptiveVoxelParams voxel;  // 1 m down to 0.25 m
  voxel.min_points = flags.min_scan_points;
  return voxel;
}

namespace {

// A non-repetitive sensor (ScanTraits): the paper's thresholds for it, and local maps for the ring descriptor.
bool NonRepetitive(const std::string& lidar) {
  Result<LidarSensor> sensor = LidarSensorFor(lidar);
  return sensor.ok() && ScanTraits(*sensor).non_repetitive;
}

}  // namespace

double ColocationHeadingDeg(const std::string& lidar) {
  Result<LidarSensor> sensor = LidarSensorFor(lidar);
  return sensor.ok() ? std::min(180.0, ScanTraits(*sensor).horizontal_fov_deg) : 180.0;
}

double DefaultTauIntra(const std::string& descriptor, const std::string& lidar) {
  if (descriptor == "ring") return 0.15;
  if (descriptor == "scan-context") return 0.2;
  return NonRepetitive(lidar) ? 0.01 : 0.05;
}

double PaperTauInter(const std::string& lidar) { return NonRepetitive(lidar) ? 0.05 : 0.10; }

void ApplySensorTauInter(bool tau_inter_given, const std::string& lidar, MergeServerParams* params) {
  if (!tau_inter_given && params->cascade.stage_a.neighbour_rank == 0) {
    params->cascade.stage_a.tau_inter = PaperTauInter(lidar);
  }
}

KeyframeRecordKind RecordKindForDescriptor(const std::string& descriptor) {
  return descriptor == "scan-context" ? KeyframeRecordKind::kScanContext : KeyframeRecordKind::kUnit40;
}

std::int32_t DescriptorFloatsFor(const std::string& descriptor) {
  return static_cast<std::int32_t>(KeyframeRecordDimOf(RecordKindForDescriptor(descriptor)));
}

std::string CascadeSettingsText(const MergeServerParams& params) {
  const SequentialMatchParams& a = params.cascade.stage_a;
  std::string text = a.neighbour_rank == 0
                         ? "stage A tau_inter " + FormatNumber(a.tau_inter, 4) + " per cell"
                         : "stage A neighbour rank " + std::to_string(a.neighbour_rank) + " under tau_inter " +
                               FormatNumber(a.tau_inter, 4);
  return text + (params.record_kind == KeyframeRecordKind::kScanContext ? " (Scan Context distance)" : "") +
         ", stage B " + StageBCoverName(params.cover);
}

DescriptorInputParams RingDescriptorInput(const std::string& lidar) {
  DescriptorInputParams input;
  input.level = true;
  input.local_map_window_m = NonRepetitive(lidar) ? 5.0 : 0.0;
  return input;
}

Result<RobotDescriptor> MakeRobotDescriptor(const DescriptorFlags& flags, const std::string& lidar) {
  RobotDescriptor out;
  out.tau_intra = flags.tau_intra >= 0.0 ? flags.tau_intra : DefaultTauIntra(flags.name, lidar);
  if (flags.name == "solid") {
    auto params = SolidParamsFromFlags(lidar, flags.solid_min_z_m);
    if (!params.ok()) return params.status();
    auto solid = SolidDescriptor::Create(*params);
    if (!solid.ok()) return solid.status();
    out.descriptor = std::make_unique<SolidDescriptor>(std::move(*solid));
    out.text = "SOLiD " + lidar + ", " + SolidMinZText(*params) + ", on the raw scan";
    return out;
  }
  if (flags.name != "ring" && flags.name != "scan-context") {
    return InvalidArgument("--descriptor: unknown descriptor '" + flags.name + "' (ring, solid, scan-context)");
  }
  if (std::isfinite(flags.solid_min_z_m)) {
    return InvalidArgument("--solid-min-z-m: applies to --descriptor solid only (got --descriptor " + flags.name + ")");
  }
  if (flags.name == "scan-context") {
    if (auto preset = SolidPresetFor(lidar); !preset.ok()) {
      return Status(preset.status().code(), "--lidar: " + preset.status().message());
    }
    ScanContextParams params;  // the wire's grid, 80 m, sensor 2 m above the ground (Kim & Kim)
    params.num_rings = kScanContextWireRings;
    params.num_sectors = kScanContextWireSectors;
    auto sc = ScanContextDescriptor::Create(params);
    if (!sc.ok()) return sc.status();
    out.descriptor = std::make_unique<ScanContextDescriptor>(std::move(*sc));
    out.text = "Scan Context 20 x 60 to 80 m on the raw scan";
    return out;
  }
  if (auto preset = SolidPresetFor(lidar); !preset.ok()) {
    return Status(preset.status().code(), "--lidar: " + preset.status().message());
  }
  auto ring = RingOccupancyDescriptor::Create(RingOccupancyParams{});
  if (!ring.ok()) return ring.status();
  out.descriptor = std::make_unique<RingOccupancyDescriptor>(std::move(*ring));
  out.input = RingDescriptorInput(lidar);
  if (flags.window_m >= 0.0) out.input.local_map_window_m = flags.window_m;
  char text[128];
  std::snprintf(text, sizeof(text), "ring occupancy on the levelled scan%s", out.input.local_map_window_m > 0.0 ? "" : " alone");
  out.text = text;
  if (out.input.local_map_window_m > 0.0) {
    std::snprintf(text, sizeof(text), " and the last %.1f m of keyframes", out.input.local_map_window_m);
    out.text += text;
  }
  return out;
}

Result<SolidParams> SolidParamsFromFlags(const std::string& lidar, double min_z_m) {
  auto params = SolidPresetFor(lidar);
  if (!params.ok()) return Status(params.status().code(), "--lidar: " + params.status().message());
  params->min_z_m = min_z_m;
  const Status valid = ValidateSolidParams(*params);
  if (!valid.ok()) return Status(valid.code(), "--solid-min-z-m: " + valid.message());
  return params;
}

std::string SolidMinZText(const SolidParams& params) {
  if (!std::isfinite(params.min_z_m)) return "every point";
  char text[64];
  std::snprintf(text, sizeof(text), "points below z %.2f m left out", params.min_z_m);
  return text;
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
