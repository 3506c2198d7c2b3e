// SPDX-License-Identifier: BSD-3-Clause
// commerge: the files a merge writes, one writer each, shared by `commerge run` and `commerge server`:
//   transforms.txt           robot placements and pairwise registrations of a merge result:
//                              "robot <id> merged|unmerged <T_world_map, row-major 3x4>"  (world = robot 0's map)
//                              "pair <alpha> <beta> merged|unmerged <T_alpha_beta, row-major 3x4>" (p_alpha = T p_beta)
//                            '#' lines are comments: the first names the producer, one after each pair line its
//                            verdict; transforms are the identity where unmerged.
//   merged_map.pcd / .ply    the merged map (core/merge/merged_map.hpp), binary PCD and PLY with a robot id
//                            per point.
//   trajectories/robot_<r>_world.tum      robot r's keyframe poses in the world frame (T_world_map T_map_sensor),
//   trajectories/robot_<r>_own_frame.tum  ... or in its own map frame when it is not in the world frame,
//   trajectories/robot_<r>_gt.tum         its ground truth, when there is one.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/agent/messages.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/merge/merged_map.hpp"

namespace commerge::platform {

/// Writes transforms.txt at `path` from merge result `m`; `producer` goes into the first comment line
/// (e.g. "commerge run, mode A+B+C" or "commerge server, round 3").
Status WriteTransforms(const std::string& path, const MergeResultMessage& m, const std::string& producer);

/// Writes <dir>/merged_map.pcd and <dir>/merged_map.ply from a finished builder.
Status WriteMergedMap(const std::string& dir, const MergedMapBuilder& map);

/// One robot's keyframe trajectory. times_s: one per pose (the server, which receives no time stamps, uses the
/// keyframe index); ground_truth: empty or one per pose.
struct RobotTrajectory {
  int robot = 0;
  bool in_world = false;
  Eigen::Isometry3d T_world_map = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Isometry3d> T_map_sensor;
  std::vector<double> times_s;
  std::vector<Eigen::Isometry3d> ground_truth;
};

/// Writes the trajectory files of `t` into `dir` (which must exist); see the file comment for the names.
Status WriteTrajectory(const std::string& dir, const RobotTrajectory& t);

}  // namespace commerge::platform
