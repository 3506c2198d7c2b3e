// SPDX-License-Identifier: BSD-3-Clause
// `commerge run`: robots and server in one process, every message LCM-encoded, counted and decoded again
// (the bytes reported are the bytes on the wire). Shared with `commerge demo`.
#pragma once

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "apps/app_common.hpp"
#include "apps/app_descriptor_flags.hpp"
#include "apps/app_memory.hpp"
#include "core/agent/merge_server.hpp"

namespace commerge::app {

struct RunOptions {
  std::vector<std::string> datasets;  ///< one robot each: DIR or DIR:FIRST-LAST
  std::string out_dir = "out/run";
  /// Modes run side by side; the last one gives the final result (merged map, trajectories).
  std::vector<std::string> modes = {"send-all", "A", "A+B", "A+C", "A+B+C"};
  std::string sensor = "hdl-64e";  ///< --lidar: the robots' LiDAR (its preset)
  DescriptorFlags descriptor;      ///< --descriptor, --descriptor-window-m, --solid-min-z-m
  bool gt_from_poses = false;
  std::string odometry_file;  ///< --odometry: the robots' odometry file in each dataset directory ("" = poses.txt)
  /// The merge server's parameters: the flags `run` shares with `server` (apps/merge_flags.hpp); max_submap_points
  /// comes from the memory configuration.
  MergeServerParams server;
  std::string profile = "commerge";  ///< --profile: what the merge flags not given take (ApplyMergeProfile)
  double keyframe_spacing_m = 1.0;  ///< the robots' keyframe spacing (paper: 1 m)
  int threads = 2;                  ///< robots processed at once
  bool report = true;
  bool dump_keyframes = false;  ///< --dump-keyframes: report/keyframes_<r>.tsv (descriptors, poses, truth)
  bool progress = true;
  MemoryFlags memory;
  std::string tag = "commerge run";  ///< message prefix
};

/// Figures of a finished run, for callers (the demo) that judge it.
struct RunSummary {
  std::vector<double> final_rmse_m;  ///< per robot, e_rmse against robot 0 in the final mode; -1 = none
  double final_reduction_percent = 0.0;  ///< bytes saved against send-all (0 when send-all did not run)
  int pairs_merged = 0;
};

/// Adds the flags of `commerge run` (except the positional datasets) to `cmd`.
void AddRunFlags(CLI::App* cmd, RunOptions* options);

/// Runs the whole job; returns an exit code (kExitOk also when a pair could not be merged: the report says
/// why; kExitFailure for unreadable input or when no pair merged at all).
int RunMergeJob(const RunOptions& options, RunSummary* summary = nullptr);

}  // namespace commerge::app
