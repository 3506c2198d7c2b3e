// SPDX-License-Identifier: BSD-3-Clause
// commerge: the point type shared by every layer (the KITTI .bin record: x, y, z, intensity).
#pragma once

#include <cmath>
#include <cstdint>

namespace commerge {

/// One LiDAR return in its scan's sensor frame [m]; intensity is sensor-specific (KITTI: 0..1).
struct PointXYZI {
  float x = 0.0f;
  float y = 0.0f;
  float z = 0.0f;
  float intensity = 0.0f;
};
static_assert(sizeof(PointXYZI) == 16, "PointXYZI must match the 16-byte KITTI record");

/// True when all three coordinates are finite (intensity is not checked).
inline bool IsFinite(const PointXYZI& p) noexcept {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

}  // namespace commerge
