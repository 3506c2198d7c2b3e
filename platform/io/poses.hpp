// SPDX-License-Identifier: BSD-3-Clause
// Trajectory files: KITTI-12 poses (row-major 3x4 [R|t] per line), TUM (t tx ty tz qx qy qz qw per line),
// and KITTI times.txt (one time [s] per line).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge::platform {

struct StampedPose {
  double time_s = 0.0;
  /// Sensor pose in the file's frame (a robot's map, the world or the ground-truth frame, whichever the
  /// trajectory is expressed in).
  Eigen::Isometry3d T_frame_sensor = Eigen::Isometry3d::Identity();
};

/// Reads KITTI-12 poses: one line per pose with 12 numbers, the row-major 3x4 [R|t] of T_frame_sensor.
/// Trailing blank lines are allowed, nothing else is skipped. Errors (data loss) name the file and the
/// 1-based line: wrong number of values, a token that is not a number, NaN/inf, a rotation that is not
/// orthonormal (max |R^T R - I| > 1e-2 or det R <= 0). Rotations within that tolerance are replaced by the
/// nearest rotation matrix (SVD), so every returned pose is a proper SE(3) transform.
Result<std::vector<Eigen::Isometry3d>> ReadKittiPoses(const std::string& path);

/// Writes KITTI-12 poses (overwrites), each number in the shortest form that reads back exactly.
/// A pose with a NaN/inf entry is an invalid argument.
Status WriteKittiPoses(const std::string& path, Span<const Eigen::Isometry3d> poses);

/// Reads TUM poses: "t tx ty tz qx qy qz qw" per line; '#' comment lines and blank lines are skipped.
/// Errors name the file and line as for KITTI; a quaternion with norm < 1e-6 or |norm - 1| > 1e-2 is an
/// error, otherwise it is normalised.
Result<std::vector<StampedPose>> ReadTumPoses(const std::string& path);

/// Writes TUM poses (overwrites), numbers in the shortest form that reads back exactly. The rotation
/// part of each pose must be a rotation matrix; a NaN/inf entry is an invalid argument.
Status WriteTumPoses(const std::string& path, Span<const StampedPose> poses);

/// Reads KITTI times.txt: one finite number [s] per line; trailing blank lines are allowed.
Result<std::vector<double>> ReadTimes(const std::string& path);

}  // namespace commerge::platform
