// SPDX-License-Identifier: BSD-3-Clause
// KITTI velodyne .bin scans: little-endian float32 x, y, z, intensity; 16 bytes per point; no header.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge::platform {

/// What a point-cloud reader found. Points with a NaN/inf coordinate are dropped and counted, never passed on.
struct PointCloudFile {
  std::vector<PointXYZI> points;
  /// Per-point robot id when the file has a "robot" field (PCD/PLY written by commerge), else empty.
  std::vector<std::uint16_t> robot_ids;
  std::size_t records_in_file = 0;    ///< points stored in the file, finite or not
  std::size_t dropped_nonfinite = 0;  ///< records dropped because x, y or z was NaN or inf
};

/// Reads a KITTI .bin scan. Errors name the file: missing (not found), size not a multiple of 16 bytes
/// (data loss: truncated), read failure (i/o error). An empty file is a valid scan with no points.
Result<PointCloudFile> ReadKittiBin(const std::string& path);

/// Points of a KITTI .bin scan by its size, without reading it (sizing pools before the work). Errors as
/// ReadKittiBin's: missing, size not a multiple of 16 bytes.
Result<std::size_t> KittiBinPointCount(const std::string& path);

/// Writes points as a KITTI .bin scan (overwrites). Non-finite points are written as they are.
Status WriteKittiBin(const std::string& path, Span<const PointXYZI> points);

}  // namespace commerge::platform
