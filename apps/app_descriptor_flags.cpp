// SPDX-License-Identifier: BSD-3-Clause
#include "apps/app_descriptor_flags.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/common/number_text.hpp"
#include "core/descriptor/ring_occupancy.hpp"
#include "core/descriptor/scan_context.hpp"
#include "core/descriptor/solid.hpp"

namespace commerge::app {

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
  cmd->add_option("--record-descriptor-bits", flags->record_descriptor_bits,
                  "ring and solid: keyframes travel in compact batches (poses on a 1 mm grid, each keyframe predicted "
                  "from the one before) with this many bits per descriptor value, 4..14; 0 sends the 92-byte record "
                  "per keyframe (14 bits). The server takes both [bits]")
      ->check(CLI::Range(0, kCompactMaxDescriptorBits) &
              CLI::Validator([](const std::string& v) { return v == "1" || v == "2" || v == "3" ? "0 or 4..14" : ""; },
                             "0 or 4..14"))
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
  cmd->add_option("--ground-up-min-tilt-deg", flags->ground_up_min_tilt_deg,
                  "ring descriptor: the scan is levelled by the odometry frame's z, or, once the frame leans more than "
                  "this from the ground the keyframes see (a handheld sensor's frame is its first pose's, held "
                  "pitched), by that ground's up; 0 = by the frame's z alone (default: 2 for a spinning --lidar, 0 for a "
                  "forward-looking one, whose cone sees too little ground to fit it). Every robot of a team needs the "
                  "same value [deg; ours]")
      ->check(CLI::Range(0.0, 45.0));
}

AdaptiveVoxelParams StoredScanVoxel(const DescriptorFlags& flags) {
  AdaptiveVoxelParams voxel;  // 1 m down to 0.25 m
  voxel.min_points = flags.min_scan_points;
  return voxel;
}

namespace {

// A non-repetitive sensor (ScanTraits): the paper's thresholds for it, and local maps for the ring descriptor.
bool NonRepetitive(const std::string& lidar) { return ScanTraitsFor(lidar).non_repetitive; }

}  // namespace

double DefaultTauIntra(const std::string& descriptor, const std::string& lidar) {
  if (descriptor == "ring") return 0.15;
  if (descriptor == "scan-context") return 0.2;
  return PaperTauIntra(ScanTraitsFor(lidar));
}

void ApplySensorTauInter(bool tau_inter_given, const std::string& lidar, MergeServerParams* params) {
  if (!tau_inter_given && params->cascade.stage_a.neighbour_rank == 0) {
    params->cascade.stage_a.tau_inter = PaperTauInter(ScanTraitsFor(lidar));
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
  text += params.record_kind == KeyframeRecordKind::kScanContext ? " (Scan Context distance)" : "";
  text += ", tau_area " + std::to_string(a.tau_area) + " cells";
  if (a.tau_area_fraction > 0.0) text += " (at most (" + FormatNumber(a.tau_area_fraction, 4) + " x keyframes)^2)";
  return text + ", stage B " + StageBCoverName(params.cover);
}

DescriptorInputParams RingDescriptorInput(const std::string& lidar) {
  DescriptorInputParams input;
  input.level = true;
  input.local_map_window_m = NonRepetitive(lidar) ? 5.0 : 0.0;
  // A forward-looking cone sees a patch of ground ahead: on the real Avia splits its fitted up scattered by
  // 1-3 deg between robots of one frame (core/agent/decisions/030-level-by-the-ground.md).
  input.ground_up.min_frame_tilt_deg = NonRepetitive(lidar) ? 0.0 : GroundUpParams{}.min_frame_tilt_deg;
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
  if (flags.ground_up_min_tilt_deg >= 0.0) out.input.ground_up.min_frame_tilt_deg = flags.ground_up_min_tilt_deg;
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

}  // namespace commerge::app
