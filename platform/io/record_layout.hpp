// SPDX-License-Identifier: BSD-3-Clause
// Binary and ascii point records as PCD and PLY headers declare them: scalar types, where x, y, z,
// intensity and robot sit in a record, and bounded decoding/encoding of whole clouds.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "platform/io/kitti_bin.hpp"

namespace commerge::platform::io_detail {

enum class ScalarType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kInt64, kUint64, kFloat32, kFloat64 };

std::size_t ScalarSize(ScalarType type);
/// Value of one little-endian scalar stored at `bytes`.
double DecodeScalar(ScalarType type, const unsigned char* bytes);

/// One field of a record as a file header declares it; `count` elements of `type`.
struct FieldSpec {
  std::string name;
  ScalarType type = ScalarType::kFloat32;
  std::size_t count = 1;
};

/// Where a field commerge uses sits in a record: byte offset (binary) and token index (ascii).
struct FieldSlot {
  ScalarType type = ScalarType::kFloat32;
  std::size_t byte_offset = 0;
  std::size_t token_index = 0;
};

/// The fields x, y, z (required), intensity and robot (optional) of a record; other fields are skipped.
struct RecordLayout {
  FieldSlot x, y, z;
  std::optional<FieldSlot> intensity;
  std::optional<FieldSlot> robot;
  std::size_t record_bytes = 0;         ///< binary stride
  std::vector<ScalarType> token_types;  ///< ascii: the type of each value on a line
};

/// Locates x, y, z, intensity and robot among `fields`. Intensity may also be called "scalar_intensity"
/// (CloudCompare) or "reflectance"; "intensity" wins when several are present. Errors name `path`: a
/// missing coordinate, a used field that appears twice or has a count other than 1, an implausibly large
/// record.
Result<RecordLayout> MakeRecordLayout(const std::string& path, const std::vector<FieldSpec>& fields);

/// Decodes `count` binary records from `f` (positioned at the first record). `bytes_available` is what the
/// file holds from there on; it is checked against `count` before anything is allocated.
Result<PointCloudFile> ReadBinaryRecords(std::FILE* f, const std::string& path, const RecordLayout& layout,
                                         std::uint64_t count, std::uint64_t bytes_available);

/// The `bytes` that remain in `f` from its current position, as text.
Result<std::string> ReadRemainingText(std::FILE* f, const std::string& path, std::uint64_t bytes);

/// Parses `count` ascii records, one per line, from `text`, whose first line is line `first_line` of the
/// file. `*rest` receives the text after the last record.
Result<PointCloudFile> ParseAsciiRecords(const std::string& path, const RecordLayout& layout,
                                         std::string_view text, std::size_t first_line, std::uint64_t count,
                                         std::string_view* rest);

/// Writes float32 x, y, z, intensity [, uint16 robot] records, packed little-endian.
Status WriteBinaryRecords(std::FILE* f, const std::string& path, Span<const PointXYZI> points,
                          Span<const std::uint16_t> robot_ids);

/// OK when `robot_ids` is empty or has one entry per point; else an invalid argument naming `path`.
Status CheckRobotIds(const std::string& path, std::size_t num_points, std::size_t num_robot_ids);

}  // namespace commerge::platform::io_detail
