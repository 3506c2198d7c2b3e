// SPDX-License-Identifier: BSD-3-Clause
// `commerge sim` as a function (also used by `commerge demo`).
#pragma once

#include <cstdint>
#include <string>

namespace commerge::app {

struct SimOptions {
  std::string world = "urban";
  std::string overlap = "moderate";
  std::string lidar = "vlp16";
  int robots = 2;
  int keyframes = 500;
  std::uint64_t seed = 1;
  double drift = 1.0;
  double wobble_deg = 0.5;
  std::string direction = "alternate";
  std::string out_dir = "out/sim";
  bool force = false;
  bool poses_only = false;
  int threads = 1;
  int azimuth_steps = 0;  // 0 = the model's
  int livox_points = 0;   // 0 = the model's
  float detection_reflectivity = 0.0f;  // LidarModel::detection_reference_reflectivity (0 = off)
  std::string tag = "commerge sim";
};

/// Writes the dataset; returns an exit code (apps/app_common.hpp).
int RunSim(const SimOptions& options);

}  // namespace commerge::app
