// SPDX-License-Identifier: BSD-3-Clause
// commerge: a small ray-cast LiDAR scan generator (ground plane + box buildings), seeded and deterministic.
// Used by the demo, benchmarks and tests when real scans are absent. The multi-robot simulator (`commerge sim`)
// lives beside it: world.hpp (accelerated ray casting, more primitive kinds; WorldFromBoxScene converts a
// BoxScene), lidar_models.hpp, multi_robot_mission.hpp, procedural_world.hpp.
#pragma once

#include <cstdint>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"

namespace commerge {

/// Axis-aligned box [min, max] in the scene's frame gt [m].
struct Box {
  float min_x, min_y, min_z;
  float max_x, max_y, max_z;
};

struct BoxScene {
  float ground_z_m = 0.0f;  ///< ground plane height in the scene's frame gt
  std::vector<Box> boxes;
};

/// A street scene: buildings on both sides of a straight road along x, poles and parked cars.
/// `length_m` of road, deterministic in `seed`.
BoxScene MakeStreetScene(std::uint32_t seed, float length_m = 200.0f);

/// A closed loop road around a city block: the road is the rectangle [0, width_m] x [0, height_m] (the sensor
/// drives on it), buildings stand 6-12 m outside it and inside the block, with poles along the kerbs.
/// Deterministic in `seed`. For loop-closure tests and benchmarks.
BoxScene MakeBlockLoopScene(std::uint32_t seed, float width_m = 40.0f, float height_m = 30.0f);

/// Spinning LiDAR model: `beams` rings evenly spaced in [min_elevation_deg, max_elevation_deg],
/// `azimuth_steps` columns per revolution (HDL-64E: 64 beams, -24.8..+2.0 deg, ~2000 columns, 120 m).
struct SpinningLidar {
  int beams = 64;
  int azimuth_steps = 2048;
  float min_elevation_deg = -24.8f;
  float max_elevation_deg = 2.0f;
  float max_range_m = 120.0f;
  float range_noise_std_m = 0.01f;
};

/// Casts every ray of `lidar` from the sensor at (x, y, z) with heading `yaw_rad` (scene frame gt), returns the
/// hits in the sensor frame (x forward, y left, z up). Rays that hit nothing within range give no point.
/// Intensity = 1 / (1 + range), a stand-in. Range noise is seeded by `seed`.
void CastScan(const BoxScene& scene, const SpinningLidar& lidar, float x_m, float y_m, float z_m, float yaw_rad,
              std::uint32_t seed, std::vector<PointXYZI>* out);

}  // namespace commerge
