// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/record_layout.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>

#include "platform/io/file_util.hpp"
#include "platform/io/text_io.hpp"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the binary readers and writers in platform/io assume a little-endian host");

namespace commerge::platform::io_detail {

namespace {

constexpr std::size_t kMaxFieldCount = std::size_t{1} << 16;
constexpr std::size_t kMaxRecordBytes = std::size_t{1} << 20;
constexpr std::size_t kReadChunkBytes = std::size_t{1} << 20;
constexpr std::size_t kWriteChunkPoints = 4096;

template <class T>
double Load(const unsigned char* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return static_cast<double>(value);
}

/// Values of one record, before conversion to a point.
struct RecordValues {
  double x = 0.0, y = 0.0, z = 0.0, intensity = 0.0;
  std::optional<double> robot;
};

std::optional<std::uint16_t> RobotId(double value) {
  if (!(value >= 0.0 && value <= 65535.0) || std::floor(value) != value) return std::nullopt;
  return static_cast<std::uint16_t>(value);
}

std::string BadRobotId(double value) {
  return "robot id " + NumberText(value) + " is not an integer in 0..65535";
}

/// `value` rounded to float; beyond the float range it becomes +-inf (a plain cast would be undefined).
float ToFloat(double value) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  if (std::abs(value) > static_cast<double>(std::numeric_limits<float>::max())) return value > 0.0 ? kInf : -kInf;
  return static_cast<float>(value);
}

/// Stores `values` as point `index` of `out` (sized by the caller); false when the robot id is invalid.
bool Store(const RecordValues& values, std::size_t index, PointCloudFile* out) {
  out->points[index] = PointXYZI{ToFloat(values.x), ToFloat(values.y), ToFloat(values.z), ToFloat(values.intensity)};
  if (!values.robot) return true;
  const std::optional<std::uint16_t> id = RobotId(*values.robot);
  if (!id) return false;
  out->robot_ids[index] = *id;
  return true;
}

PointCloudFile SizedCloud(const RecordLayout& layout, std::size_t count) {
  PointCloudFile out;
  out.records_in_file = count;
  out.points.resize(count);
  if (layout.robot) out.robot_ids.resize(count);
  return out;
}

/// The used fields of one record, each read by `value_of(slot)`.
template <class ValueOf>
RecordValues GatherValues(const RecordLayout& layout, ValueOf value_of) {
  RecordValues values{value_of(layout.x), value_of(layout.y), value_of(layout.z), 0.0, std::nullopt};
  if (layout.intensity) values.intensity = value_of(*layout.intensity);
  if (layout.robot) values.robot = value_of(*layout.robot);
  return values;
}

Status CheckBinarySize(const std::string& path, std::size_t record_bytes, std::uint64_t count,
                       std::uint64_t bytes_available) {
  if (count <= bytes_available / record_bytes) return Status::Ok();
  const std::string announced = count <= UINT64_MAX / record_bytes ? std::to_string(count * record_bytes)
                                                                    : std::string("more than 2^64");
  return DataLoss(path + ": truncated: header announces " + std::to_string(count) + " points = " + announced +
                  " bytes, file has " + std::to_string(bytes_available) + " bytes after the header");
}

/// Which used field a name denotes; intensity aliases rank after "intensity" itself.
enum UsedField { kX, kY, kZ, kIntensity, kRobot, kNumUsedFields };
struct NameRule {
  const char* name;
  UsedField field;
  int rank;
};
constexpr NameRule kNameRules[] = {{"x", kX, 0},         {"y", kY, 0},
                                   {"z", kZ, 0},         {"intensity", kIntensity, 0},
                                   {"robot", kRobot, 0}, {"scalar_intensity", kIntensity, 1},
                                   {"reflectance", kIntensity, 2}};

const NameRule* FindRule(const std::string& name) {
  for (const NameRule& rule : kNameRules) {
    if (name == rule.name) return &rule;
  }
  return nullptr;
}

/// The slots found so far for x, y, z, intensity and robot.
struct UsedSlots {
  std::optional<FieldSlot> slots[kNumUsedFields];
  int intensity_rank = 0;  ///< rank of the intensity alias in slots[kIntensity]
};

/// Records `slot` when `field` is one commerge uses. Errors: a used name twice, a count other than 1.
Status AssignUsedField(const std::string& path, const FieldSpec& field, const FieldSlot& slot, UsedSlots* used) {
  const NameRule* rule = FindRule(field.name);
  if (!rule) return Status::Ok();
  if (field.count != 1) {
    return InvalidArgument(path + ": field '" + field.name + "' has count " + std::to_string(field.count) +
                           ", expected 1");
  }
  std::optional<FieldSlot>& target = used->slots[rule->field];
  if (target && (rule->field != kIntensity || rule->rank == used->intensity_rank)) {
    return DataLoss(path + ": field '" + field.name + "' appears twice");
  }
  if (!target || rule->rank < used->intensity_rank) {
    target = slot;
    if (rule->field == kIntensity) used->intensity_rank = rule->rank;
  }
  return Status::Ok();
}

/// Parses each token by the type of its field into `values`; returns the index of a bad token, or npos.
std::size_t ParseTokens(const std::vector<ScalarType>& types, const std::vector<std::string_view>& tokens,
                        std::vector<double>* values) {
  for (std::size_t t = 0; t < tokens.size(); ++t) {
    float as_float = 0.0f;
    if (types[t] != ScalarType::kFloat32) {
      if (!ParseNumber(tokens[t], &(*values)[t])) return t;
    } else {
      if (!ParseNumber(tokens[t], &as_float)) return t;  // float fields parse as float: exact round trips
      (*values)[t] = static_cast<double>(as_float);
    }
  }
  return std::string_view::npos;
}

std::string FieldNames(const std::vector<FieldSpec>& fields) {
  std::string names;
  for (const FieldSpec& field : fields) names += (names.empty() ? "" : " ") + field.name;
  return names.empty() ? std::string("none") : names;
}

}  // namespace

std::size_t ScalarSize(ScalarType type) {
  switch (type) {
    case ScalarType::kInt8:
    case ScalarType::kUint8: return 1;
    case ScalarType::kInt16:
    case ScalarType::kUint16: return 2;
    case ScalarType::kInt32:
    case ScalarType::kUint32:
    case ScalarType::kFloat32: return 4;
    case ScalarType::kInt64:
    case ScalarType::kUint64:
    case ScalarType::kFloat64: return 8;
  }
  return 0;
}

double DecodeScalar(ScalarType type, const unsigned char* bytes) {
  switch (type) {
    case ScalarType::kInt8: return Load<std::int8_t>(bytes);
    case ScalarType::kUint8: return Load<std::uint8_t>(bytes);
    case ScalarType::kInt16: return Load<std::int16_t>(bytes);
    case ScalarType::kUint16: return Load<std::uint16_t>(bytes);
    case ScalarType::kInt32: return Load<std::int32_t>(bytes);
    case ScalarType::kUint32: return Load<std::uint32_t>(bytes);
    case ScalarType::kInt64: return Load<std::int64_t>(bytes);
    case ScalarType::kUint64: return Load<std::uint64_t>(bytes);
    case ScalarType::kFloat32: return Load<float>(bytes);
    case ScalarType::kFloat64: return Load<double>(bytes);
  }
  return 0.0;
}

Result<RecordLayout> MakeRecordLayout(const std::string& path, const std::vector<FieldSpec>& fields) {
  RecordLayout layout;
  UsedSlots used;
  for (const FieldSpec& field : fields) {
    if (field.count == 0 || field.count > kMaxFieldCount) {
      return DataLoss(path + ": field '" + field.name + "' has count " + std::to_string(field.count) +
                      ", expected 1.." + std::to_string(kMaxFieldCount));
    }
    const FieldSlot slot{field.type, layout.record_bytes, layout.token_types.size()};
    if (Status s = AssignUsedField(path, field, slot, &used); !s.ok()) return s;
    layout.record_bytes += ScalarSize(field.type) * field.count;
    layout.token_types.insert(layout.token_types.end(), field.count, field.type);
    if (layout.record_bytes > kMaxRecordBytes) {
      return DataLoss(path + ": records of more than " + std::to_string(kMaxRecordBytes) + " bytes are implausible");
    }
  }
  static const char* const kCoordinates[] = {"x", "y", "z"};
  const auto& slots = used.slots;
  for (int i = kX; i <= kZ; ++i) {
    if (!slots[i]) {
      return InvalidArgument(path + ": no field '" + kCoordinates[i] + "' (x, y and z are required; fields: " +
                             FieldNames(fields) + ")");
    }
  }
  layout.x = *slots[kX];
  layout.y = *slots[kY];
  layout.z = *slots[kZ];
  layout.intensity = slots[kIntensity];
  layout.robot = slots[kRobot];
  return layout;
}

Result<PointCloudFile> ReadBinaryRecords(std::FILE* f, const std::string& path, const RecordLayout& layout,
                                         std::uint64_t count, std::uint64_t bytes_available) {
  const std::size_t stride = layout.record_bytes;
  if (Status s = CheckBinarySize(path, stride, count, bytes_available); !s.ok()) return s;
  PointCloudFile out = SizedCloud(layout, static_cast<std::size_t>(count));
  const std::size_t chunk_records =
      std::min<std::size_t>(out.records_in_file, std::max<std::size_t>(1, kReadChunkBytes / stride));
  std::vector<unsigned char> chunk(chunk_records * stride);
  for (std::size_t done = 0; done < out.records_in_file;) {
    const std::size_t n = std::min(chunk_records, out.records_in_file - done);
    if (std::fread(chunk.data(), stride, n, f) != n) {
      return IoError(path + ": read failed at point " + std::to_string(done) + ": " + ShortReadReason(f));
    }
    for (std::size_t i = 0; i < n; ++i) {
      const unsigned char* record = chunk.data() + i * stride;
      const RecordValues values = GatherValues(
          layout, [record](const FieldSlot& slot) { return DecodeScalar(slot.type, record + slot.byte_offset); });
      if (!Store(values, done + i, &out)) {
        return DataLoss(path + ": point " + std::to_string(done + i) + ": " + BadRobotId(*values.robot));
      }
    }
    done += n;
  }
  out.dropped_nonfinite = DropNonFinite(&out.points, &out.robot_ids);
  return out;
}

Result<std::string> ReadRemainingText(std::FILE* f, const std::string& path, std::uint64_t bytes) {
  std::string text(static_cast<std::size_t>(bytes), '\0');
  if (!text.empty() && std::fread(&text[0], 1, text.size(), f) != text.size()) {
    return IoError(path + ": read failed: " + ShortReadReason(f));
  }
  return text;
}

Result<PointCloudFile> ParseAsciiRecords(const std::string& path, const RecordLayout& layout,
                                         std::string_view text, std::size_t first_line, std::uint64_t count,
                                         std::string_view* rest) {
  // Bounds the allocation by the file size: every row needs at least one character and a line break. (A
  // tighter bound would report "truncated" where the row-by-row parse can name the offending line.)
  if (count > (text.size() + 1) / 2) {
    return DataLoss(path + ": truncated: header announces " + std::to_string(count) + " points, the ascii data " +
                    "after the header has only " + std::to_string(text.size()) + " bytes");
  }
  PointCloudFile out = SizedCloud(layout, static_cast<std::size_t>(count));
  LineCursor lines(text, first_line);
  std::vector<std::string_view> tokens;
  std::vector<double> values(layout.token_types.size());
  for (std::size_t i = 0; i < out.records_in_file; ++i) {
    std::string_view line;
    if (!lines.Next(&line)) {
      return DataLoss(path + ": truncated: header announces " + std::to_string(count) + " points, the data has " +
                      std::to_string(i) + " rows");
    }
    SplitTokens(line, &tokens);
    if (tokens.size() != values.size()) {
      return DataLoss(LineError(path, lines.line_number(), WrongValueCount(values.size(), tokens.size())));
    }
    const std::size_t bad = ParseTokens(layout.token_types, tokens, &values);
    if (bad != std::string_view::npos) {
      return DataLoss(LineError(path, lines.line_number(), NotANumber(bad, tokens[bad])));
    }
    const RecordValues record =
        GatherValues(layout, [&values](const FieldSlot& slot) { return values[slot.token_index]; });
    if (!Store(record, i, &out)) return DataLoss(LineError(path, lines.line_number(), BadRobotId(*record.robot)));
  }
  *rest = lines.rest();
  out.dropped_nonfinite = DropNonFinite(&out.points, &out.robot_ids);
  return out;
}

Status WriteBinaryRecords(std::FILE* f, const std::string& path, Span<const PointXYZI> points,
                          Span<const std::uint16_t> robot_ids) {
  if (robot_ids.empty()) return WriteBytes(f, path, points.data(), points.size() * sizeof(PointXYZI));
  constexpr std::size_t kRecordBytes = sizeof(PointXYZI) + sizeof(std::uint16_t);
  std::vector<unsigned char> buffer;
  for (std::size_t begin = 0; begin < points.size(); begin += kWriteChunkPoints) {
    const std::size_t n = std::min(kWriteChunkPoints, points.size() - begin);
    buffer.resize(n * kRecordBytes);
    for (std::size_t i = 0; i < n; ++i) {
      std::memcpy(&buffer[i * kRecordBytes], &points[begin + i], sizeof(PointXYZI));
      std::memcpy(&buffer[i * kRecordBytes + sizeof(PointXYZI)], &robot_ids[begin + i], sizeof(std::uint16_t));
    }
    if (Status s = WriteBytes(f, path, buffer.data(), buffer.size()); !s.ok()) return s;
  }
  return Status::Ok();
}

Status CheckRobotIds(const std::string& path, std::size_t num_points, std::size_t num_robot_ids) {
  if (num_robot_ids == 0 || num_robot_ids == num_points) return Status::Ok();
  return InvalidArgument(path + ": " + std::to_string(num_robot_ids) + " robot ids for " + std::to_string(num_points) +
                         " points; pass none or one per point");
}

}  // namespace commerge::platform::io_detail
