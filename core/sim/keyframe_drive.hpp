// SPDX-License-Identifier: BSD-3-Clause
// commerge: simulated keyframe streams for the server side: a robot drives a straight lane of a generated scene,
// one keyframe every `spacing_m`, SOLiD computed on the ray-cast raw scan. Gives what a robot sends the server
// (descriptors, keyframe positions in its own map frame, stored point counts) plus the ground truth (positions
// in the scene's ground-truth frame gt), for cascade tests and benchmarks.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/common/status.hpp"
#include "core/descriptor/solid.hpp"
#include "core/sim/synthetic_scan.hpp"

namespace commerge {

struct StraightDrive {
  float start_x_m = 0.0f;      ///< first keyframe at (start_x_m, lane_y_m)
  float lane_y_m = 0.0f;
  float yaw_rad = 0.0f;        ///< heading; the robot moves along (cos yaw, sin yaw)
  float spacing_m = 1.0f;      ///< keyframe spacing (the robot side's keyframer default)
  float sensor_height_m = 1.8f;
  int keyframes = 100;
  std::uint32_t seed = 1;      ///< range-noise seed of the first scan (+k for keyframe k)
};

struct SimulatedKeyframes {
  int dim = 0;                                ///< descriptor length (SolidParams::num_rings)
  std::vector<float> descriptors;             ///< keyframes x dim, unit-normalised R-SOLiD (zeros when invalid)
  std::vector<std::uint8_t> valid;            ///< 1 = valid descriptor
  std::vector<Eigen::Vector3d> gt_m;          ///< ground-truth keyframe positions (frame gt: the scene's)
  std::vector<Eigen::Vector3d> own_frame_m;   ///< positions in the robot's map frame (= its first keyframe pose)
  std::vector<std::uint32_t> raw_points;      ///< points of each raw scan
};

/// Ray-casts and describes every keyframe of `drive`. Errors: invalid SOLiD params, keyframes < 0.
Result<SimulatedKeyframes> SimulateStraightDrive(const BoxScene& scene, const SpinningLidar& lidar,
                                                 const SolidParams& solid, const StraightDrive& drive);

}  // namespace commerge
