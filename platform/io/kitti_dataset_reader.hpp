// SPDX-License-Identifier: BSD-3-Clause
// Reads one robot's data in KITTI layout, as `commerge sim` writes it and as real sequences come:
//   DIR/velodyne/*.bin           scans (sensor frame), taken in file-name order
//   DIR/poses.txt                estimated poses, one per scan (KITTI-12: T_frame_sensor); also accepted under
//                                the name poses_lidar.txt
//   DIR/poses_gt.txt             optional ground truth, one per scan (else: no ground truth, or --gt-from-poses)
//   DIR/T_gt_robotstart.txt      optional (the simulator's): ground truth in the dataset's common frame
//                                gt = this * poses_gt; also accepted under its older name T_world_robotstart.txt
//                                (T_gt_robotstart.txt wins when both exist)
//   DIR/times.txt                optional timestamps [s]
// A time range DIR:FIRST-LAST keeps scans FIRST..LAST-1 (0-based) and makes that slice a robot of its own:
// the paper's protocol for splitting a single-robot sequence into several robots.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/common/status.hpp"

namespace commerge::platform {

struct RobotDatasetSpec {
  std::string dir;
  std::size_t first_scan = 0;
  std::size_t end_scan = 0;  ///< 0 = to the end
  bool has_range = false;
};

/// Parses "DIR" or "DIR:FIRST-LAST" (LAST exclusive, FIRST < LAST). A ':' followed by a '/' belongs to the
/// path (write "dir:v2/" for a last component with a ':'). Errors name the argument.
Result<RobotDatasetSpec> ParseRobotDatasetSpec(const std::string& argument);

struct RobotDataset {
  std::string name;                          ///< the argument as given
  std::vector<std::string> scan_files;       ///< of the range, in order
  std::vector<Eigen::Isometry3d> poses;      ///< estimated, one per scan of the range (as in the file)
  std::vector<Eigen::Isometry3d> ground_truth;  ///< frame gt, one per scan of the range; empty = none
  std::vector<double> times_s;               ///< one per scan of the range; empty = none
  std::size_t first_scan = 0;                ///< index of scan_files[0] in the whole sequence
  std::string ground_truth_source;           ///< which file, for the report
};

/// Lists and validates (counts agree, files present). `gt_from_poses`: with no poses_gt.txt, take the poses
/// file as ground truth (real sequences whose poses are the reference trajectory; the robot's own estimate then
/// starts from the slice's first pose, so the unknown start frames remain to be found). `odometry_file`
/// (non-empty): the robot's odometry is DIR/odometry_file (e.g. odom_poses.txt, the trajectory before loop
/// closure) while poses.txt stays the reference for `gt_from_poses`. Errors name the file.
Result<RobotDataset> OpenRobotDataset(const RobotDatasetSpec& spec, bool gt_from_poses,
                                      const std::string& odometry_file = "");

}  // namespace commerge::platform
