// SPDX-License-Identifier: BSD-3-Clause
// Writes a simulated multi-robot dataset in KITTI odometry layout, one sequence folder per robot:
//
//   <root>/sim_info.txt                 parameters, frame conventions, measured overlap ("key: value" lines)
//   <root>/start_transforms.txt         KITTI-12 line r = T_gt_robotstart of robot r (true start poses)
//   <root>/robot_<r>/velodyne/%06d.bin  scan of keyframe k in the sensor frame (float32 x y z intensity)
//   <root>/robot_<r>/poses.txt          KITTI-12 line k = odometry T_robotstart_sensor(k) (line 0 = identity)
//   <root>/robot_<r>/poses_gt.txt       KITTI-12 line k = true T_robotstart_sensor(k) (line 0 = identity)
//   <root>/robot_<r>/times.txt          keyframe time [s] from the robot's start
//   <root>/robot_<r>/T_gt_robotstart.txt   the robot's line of start_transforms.txt
//   <root>/robot_<r>/calib.txt          KITTI calibration with Tr = identity: poses are LiDAR poses
//
// p_gt = T_gt_robotstart * poses_gt[k] * p_scan for every point p_scan of scan k (gt = the simulation's common
// ground-truth frame, z up, ground z = 0). Older datasets name the per-robot file T_world_robotstart.txt (same
// content); the dataset reader accepts both names.
#pragma once

#include <cstddef>
#include <string>
#include <utility>

#include <Eigen/Geometry>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge::platform {

/// "robot_<r>".
std::string SimRobotDirName(int robot);
/// "%06zu.bin".
std::string KittiScanFileName(std::size_t k);

/// Writes KITTI times.txt (overwrites): one time per line, shortest text that reads back exactly.
/// A NaN/inf time is an invalid argument.
Status WriteTimes(const std::string& path, Span<const double> times_s);

class KittiDatasetWriter {
 public:
  KittiDatasetWriter() = default;  ///< an unusable writer (for Result); use Create()
  /// Prepares `root` for `robots` robots: creates root/robot_<r>/velodyne. A root that exists and is not
  /// empty is refused (already exists, naming it) unless `force`; with `force`, the files a dataset writes
  /// (sim_info.txt, start_transforms.txt and every robot_<n> folder) are removed first, nothing else.
  /// Errors name the path (cannot create, not a directory, ...).
  static Result<KittiDatasetWriter> Create(const std::string& root, int robots, bool force);

  const std::string& root() const { return root_; }
  std::string RobotDir(int robot) const;

  /// robot_<r>/velodyne/<k>.bin. Thread-safe for distinct (robot, k).
  Status WriteScan(int robot, std::size_t k, Span<const PointXYZI> points) const;

  /// poses.txt (odometry), poses_gt.txt, times.txt, T_gt_robotstart.txt and calib.txt of one robot.
  /// Errors: sizes differ (invalid argument), non-finite values, i/o.
  Status WriteTrajectory(int robot, Span<const Eigen::Isometry3d> odometry, Span<const Eigen::Isometry3d> ground_truth,
                         Span<const double> times_s, const Eigen::Isometry3d& T_gt_robotstart) const;

  /// start_transforms.txt: one KITTI-12 line per robot, in robot order.
  Status WriteStartTransforms(Span<const Eigen::Isometry3d> T_gt_robotstart) const;

  /// sim_info.txt.
  Status WriteInfo(const std::string& text) const;

 private:
  KittiDatasetWriter(std::string root, int robots) : root_(std::move(root)), robots_(robots) {}
  std::string root_;
  int robots_ = 0;
};

}  // namespace commerge::platform
