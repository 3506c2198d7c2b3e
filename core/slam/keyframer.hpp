// SPDX-License-Identifier: BSD-3-Clause
// commerge: keyframe selection (paper Table "Parameter configuration": Delta d = 1.0 m). A scan becomes a
// keyframe when the sensor moved `keyframe_spacing_m` or turned `keyframe_rotation_deg` since the last one.
#pragma once

#include <Eigen/Geometry>

#include <cstdint>

#include "core/common/status.hpp"

namespace commerge {

struct KeyframerParams {
  double keyframe_spacing_m = 1.0;
  double keyframe_rotation_deg = 15.0;
};

Status ValidateKeyframerParams(const KeyframerParams& params);

class Keyframer {
 public:
  explicit Keyframer(const KeyframerParams& params) : params_(params) {}

  /// True when the scan at odometry pose `T_odom_sensor` is a new keyframe; the first finite pose always is.
  /// Records the pose as the last keyframe when it returns true. A non-finite pose is never a keyframe
  /// (counted in num_rejected_poses()).
  bool Offer(const Eigen::Isometry3d& T_odom_sensor);

  std::uint64_t num_offered() const noexcept { return num_offered_; }
  std::uint64_t num_keyframes() const noexcept { return num_keyframes_; }
  std::uint64_t num_rejected_poses() const noexcept { return num_rejected_poses_; }

 private:
  KeyframerParams params_;
  bool has_last_ = false;
  Eigen::Isometry3d T_odom_last_ = Eigen::Isometry3d::Identity();
  std::uint64_t num_offered_ = 0;
  std::uint64_t num_keyframes_ = 0;
  std::uint64_t num_rejected_poses_ = 0;
};

}  // namespace commerge
