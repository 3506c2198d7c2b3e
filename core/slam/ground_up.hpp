// SPDX-License-Identifier: BSD-3-Clause
// commerge: where "up" is in a robot's odometry frame, from the ground its keyframes see (ours, not in the paper).
//
// Why: the place descriptor is computed on the scan levelled by the odometry frame's z (DescriptorInputParams::
// level). That z is gravity only when the odometry frame is gravity-aligned (a LiDAR-inertial odometry that
// aligns its frame, a ground vehicle that starts level). A handheld sensor's odometry frame is the first
// keyframe's sensor frame, held pitched by several degrees, so every "levelled" scan leans by that much and two
// robots at one place compute different descriptors.
//
// How: each keyframe's ground is fitted in its levelled cloud (the points of [min_range_m, max_range_m) near the
// low percentile of z, then planes refitted to the points near the last plane); its normal, in the odometry
// frame, is summed over the keyframes. The sum's direction is the frame's up. Levelling uses it instead of the
// frame's z when it leans from z by more than min_frame_tilt_deg, so a frame that is level (within that angle)
// levels exactly as before.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

struct GroundUpParams {
  /// Use the ground's up once it leans from the odometry frame's z by more than this [deg]; 0 = never (the
  /// odometry frame's z is up).
  double min_frame_tilt_deg = 2.0;
  double min_range_m = 2.0;    ///< horizontal range of the ground points considered [m]
  double max_range_m = 15.0;
  double percentile = 5.0;     ///< the first plane is z = this percentile of their z
  double band_m = 0.25;        ///< points within this of a plane are its ground [m]
  int iterations = 4;          ///< plane refits
  std::size_t min_points = 50; ///< fewer ground points: no normal for this keyframe
  /// A keyframe's ground leaning more than this from the current up is not ground (a ramp, a wall) [deg].
  double max_lean_deg = 25.0;
  /// Smallest / middle eigenvalue of the ground points' covariance above this: not a plane.
  double max_flatness = 0.05;
};

/// OK, or invalid argument naming the field.
Status ValidateGroundUpParams(const GroundUpParams& params);

/// The unit normal (pointing up, z > 0) of the ground in `levelled` (a cloud whose z is roughly up, the sensor at
/// the origin), or false when there is none by `params`. `z_scratch` holds the z values (reserve it to the
/// cloud size to avoid allocation).
bool FitGroundNormal(Span<const PointXYZI> levelled, const GroundUpParams& params, std::vector<float>* z_scratch,
                     Eigen::Vector3d* normal);

/// The running estimate of a frame's up from ground normals given in that frame.
class GroundUpEstimate {
 public:
  void Add(const Eigen::Vector3d& normal) {
    sum_ += normal;
    ++count_;
  }
  std::size_t count() const { return count_; }
  /// The frame's z when nothing was added.
  Eigen::Vector3d up() const;
  /// Angle between up() and the frame's z [deg].
  double tilt_deg() const;

 private:
  Eigen::Vector3d sum_ = Eigen::Vector3d::Zero();
  std::size_t count_ = 0;
};

}  // namespace commerge
