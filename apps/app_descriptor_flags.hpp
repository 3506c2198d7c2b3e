// SPDX-License-Identifier: BSD-3-Clause
// The robots' place descriptor and LiDAR as flags (--descriptor, --lidar's presets, --solid-min-z-m, the loop
// gates), the descriptor they build, and what the sensor and descriptor choose elsewhere: tau_intra, the paper's
// tau_inter, the keyframe record kind, the colocation heading.
#pragma once

#include <CLI/CLI.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "core/agent/merge_server.hpp"
#include "core/agent/robot_agent.hpp"
#include "core/descriptor/place_descriptor.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/slam/robot_mapper.hpp"

namespace commerge::app {

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
  /// --record-descriptor-bits: ring and SOLiD keyframes travel in compact batches with this many bits per
  /// descriptor value, or as 92-byte records (0) (RobotAgentParams::record_descriptor_bits).
  int record_descriptor_bits = kDefaultRecordDescriptorBits;
  /// --ground-up-min-tilt-deg: ring descriptor: level by the keyframes' ground once the odometry frame leans from
  /// it by more than this (DescriptorInputParams::ground_up.min_frame_tilt_deg); 0 = by the frame's z alone;
  /// -1 = the sensor's default (RingDescriptorInput).
  double ground_up_min_tilt_deg = -1.0;
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
/// SOLiD the paper's table (PaperTauIntra of the sensor's scan traits); ring 0.15, Scan Context 0.2.
double DefaultTauIntra(const std::string& descriptor, const std::string& lidar);
/// Stage A's per-sensor default: when --tau-inter was not given (`tau_inter_given` false) and stage A thresholds
/// every cell (--neighbour-rank 0, the paper's stage A), tau_inter becomes PaperTauInter of the sensor's scan
/// traits (core/descriptor/sensor_presets.hpp). With a neighbour
/// rank it stays a cap (MergeServerParams{}: 0.5, measured by the recall benchmark for every sensor).
void ApplySensorTauInter(bool tau_inter_given, const std::string& lidar, MergeServerParams* params);
/// The keyframe records of a --descriptor (scan-context: Scan Context records; ring and solid: 40 unit values).
KeyframeRecordKind RecordKindForDescriptor(const std::string& descriptor);
/// Floats per keyframe descriptor of a --descriptor (40, Scan Context 1200): MemoryFlags::descriptor_floats.
std::int32_t DescriptorFloatsFor(const std::string& descriptor);
/// Stage A's threshold and stage B's cover in words, for the start-up line of run and server:
/// "stage A tau_inter 0.05 per cell, tau_area 10000 cells, stage B pairwise" or "stage A neighbour rank 1 under
/// tau_inter 0.5, tau_area 400 cells (at most (0.3 x keyframes)^2), stage B pairwise".
std::string CascadeSettingsText(const MergeServerParams& params);
/// Builds the descriptor named by the flags for a robot with `lidar`. Errors name the flag and value.
Result<RobotDescriptor> MakeRobotDescriptor(const DescriptorFlags& flags, const std::string& lidar);

/// The SOLiD preset named by --lidar with --solid-min-z-m applied, validated. Errors name the flag and value.
Result<SolidParams> SolidParamsFromFlags(const std::string& lidar, double min_z_m);
/// "every point" or "points below z -0.5 m left out", for banners and reports.
std::string SolidMinZText(const SolidParams& params);

}  // namespace commerge::app
