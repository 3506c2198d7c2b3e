// SPDX-License-Identifier: BSD-3-Clause
// Point-cloud files chosen by extension (.bin KITTI, .pcd, .ply).
#pragma once

#include <cstdint>
#include <string>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "platform/io/kitti_bin.hpp"

namespace commerge::platform {

/// Reads a point cloud, choosing the reader by the (case-insensitive) extension: .bin (KITTI), .pcd, .ply.
/// An unknown extension is an invalid argument naming the path and the supported extensions.
Result<PointCloudFile> ReadPointCloud(const std::string& path);

/// Writes a point cloud by extension: .bin (KITTI; it has no robot field, so non-empty `robot_ids` is an
/// error), .pcd (binary) or .ply (binary little-endian). `robot_ids` is empty or one id per point.
Status WritePointCloud(const std::string& path, Span<const PointXYZI> points,
                       Span<const std::uint16_t> robot_ids = {});

}  // namespace commerge::platform
