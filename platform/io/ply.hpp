// SPDX-License-Identifier: BSD-3-Clause
// PLY point clouds: a text header ("ply", format, elements with properties, end_header), then data.
#pragma once

#include <cstdint>
#include <string>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "platform/io/kitti_bin.hpp"

namespace commerge::platform {

/// Reads the vertex element of a PLY file in format binary_little_endian 1.0 or ascii 1.0
/// (binary_big_endian is unimplemented). Vertex properties may have any scalar PLY type
/// (char/uchar/short/ushort/int/uint/float/double or int8/uint8/.../float32/float64) in any order; x, y, z
/// are required, intensity is optional (0 when absent), a "robot" property fills robot_ids, others are
/// skipped. The vertex element must come first; later elements (faces, ...) are ignored. List properties
/// on the vertex element are unimplemented. Points with a non-finite coordinate are dropped and counted.
/// Every error message starts with `path`.
Result<PointCloudFile> ReadPly(const std::string& path);

/// Writes binary_little_endian 1.0 with element vertex: float x, y, z, intensity [, ushort robot]
/// (overwrites). `robot_ids` is empty or has one id per point.
Status WritePly(const std::string& path, Span<const PointXYZI> points, Span<const std::uint16_t> robot_ids = {});

}  // namespace commerge::platform
