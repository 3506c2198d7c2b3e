// SPDX-License-Identifier: BSD-3-Clause
// PCD point clouds (PCL's format, v0.7): a text header, then DATA ascii, binary or binary_compressed records.
#pragma once

#include <cstdint>
#include <string>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "platform/io/kitti_bin.hpp"

namespace commerge::platform {

/// Reads a PCD file with DATA ascii, binary or binary_compressed. Header keys VERSION,
/// FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT, POINTS, DATA in any order ('#' comments allowed);
/// fields in any order with TYPE F (SIZE 4/8), U or I (SIZE 1/2/4/8). x, y, z are required, intensity is
/// optional (0 when absent), a "robot" field fills robot_ids; other fields are skipped. Points with a
/// non-finite coordinate are dropped and counted. Every error message starts with `path`.
/// binary_compressed (PCL's): uint32 compressed size, uint32 uncompressed size, then LZF data (platform/io/lzf.hpp)
/// holding the fields in column order (all points' field 1, then field 2, ...). The uncompressed size must equal
/// POINTS x record bytes and be at most kLzfMaxExpansion x the compressed size, which must fit in the file: all
/// checked before allocating (a lying size is data loss, never a huge allocation). Bytes after the block are
/// ignored (PCL pads the file to a page).
Result<PointCloudFile> ReadPcd(const std::string& path);

enum class PcdEncoding { kAscii, kBinary };

/// Writes FIELDS x y z intensity (float32) [robot (uint16)], HEIGHT 1 (overwrites). `robot_ids` is empty
/// or has one id per point. Ascii values are written in the shortest form that reads back exactly.
Status WritePcd(const std::string& path, Span<const PointXYZI> points, PcdEncoding encoding,
                Span<const std::uint16_t> robot_ids = {});

}  // namespace commerge::platform
