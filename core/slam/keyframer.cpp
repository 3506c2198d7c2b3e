// SPDX-License-Identifier: BSD-3-Clause
#include "core/slam/keyframer.hpp"

#include <cmath>
#include <string>

#include "core/geometry/angles.hpp"

namespace commerge {

Status ValidateKeyframerParams(const KeyframerParams& p) {
  if (!(p.keyframe_spacing_m > 0.0) || !std::isfinite(p.keyframe_spacing_m)) {
    return InvalidArgument("keyframer: keyframe_spacing_m must be finite and > 0, got " +
                           std::to_string(p.keyframe_spacing_m));
  }
  if (!(p.keyframe_rotation_deg > 0.0) || !(p.keyframe_rotation_deg <= 180.0)) {
    return InvalidArgument("keyframer: keyframe_rotation_deg must be in (0, 180], got " +
                           std::to_string(p.keyframe_rotation_deg));
  }
  return Status::Ok();
}

bool Keyframer::Offer(const Eigen::Isometry3d& T_odom_sensor) {
  ++num_offered_;
  if (!T_odom_sensor.matrix().allFinite()) {
    ++num_rejected_poses_;
    return false;
  }
  bool is_keyframe = !has_last_;
  if (!is_keyframe) {
    const Eigen::Isometry3d delta = T_odom_last_.inverse() * T_odom_sensor;
    const double moved_m = delta.translation().norm();
    const double turned_deg = Eigen::AngleAxisd(delta.linear()).angle() * 180.0 / kPi;
    is_keyframe = moved_m >= params_.keyframe_spacing_m || turned_deg >= params_.keyframe_rotation_deg;
  }
  if (is_keyframe) {
    has_last_ = true;
    T_odom_last_ = T_odom_sensor;
    ++num_keyframes_;
  }
  return is_keyframe;
}

}  // namespace commerge
