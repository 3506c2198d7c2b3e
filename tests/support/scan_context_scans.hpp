// SPDX-License-Identifier: BSD-3-Clause
// Test helper shared by the Scan Context suites (descriptor codec, Scan Context affinity): the Scan Context
// (ScanContextParams{}: 20 x 60 to 80 m) of a ray-cast scan of a generated scene.
#pragma once

#include <doctest/doctest.h>

#include <cstdint>
#include <vector>

#include "core/descriptor/scan_context.hpp"
#include "core/sim/synthetic_scan.hpp"

namespace commerge::test {

/// Scan Context of a 16-beam, 720-column ray-cast scan of `scene` from (x, y), sensor 1.73 m up, heading yaw.
inline std::vector<float> RayCastScanContext(const BoxScene& scene, float x_m, float y_m, float yaw_rad,
                                             std::uint32_t seed) {
  SpinningLidar lidar;
  lidar.beams = 16;
  lidar.azimuth_steps = 720;
  lidar.max_range_m = 90.0f;
  std::vector<PointXYZI> pts;
  CastScan(scene, lidar, x_m, y_m, 1.73f, yaw_rad, seed, &pts);
  const ScanContextParams params;
  std::vector<float> sc(static_cast<std::size_t>(params.num_rings) * static_cast<std::size_t>(params.num_sectors));
  const auto info = ComputeScanContext(pts, params, sc);
  REQUIRE(info.ok());
  REQUIRE(info->valid);
  return sc;
}

}  // namespace commerge::test
