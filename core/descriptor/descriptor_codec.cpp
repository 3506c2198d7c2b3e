// SPDX-License-Identifier: BSD-3-Clause
#include "core/descriptor/descriptor_codec.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>

#include "core/common/little_endian.hpp"
#include "core/common/number_text.hpp"
#include "core/descriptor/scan_context.hpp"

namespace commerge {
namespace {

constexpr std::size_t kTranslationOffset = 4;
constexpr std::size_t kRotationOffset = 16;
constexpr std::size_t kRotationBytes = 6;
constexpr std::size_t kPoseHeaderBytes = kRotationOffset + kRotationBytes;  // 22
static_assert(kPoseHeaderBytes == kKeyframePoseHeaderBytes, "pose header layout");
constexpr std::size_t kDescriptorOffset = kPoseHeaderBytes;
constexpr std::size_t kDescriptorBytes =
    (kKeyframeDescriptorDim * kKeyframeDescriptorBits + 7) / 8;  // 70
static_assert(kDescriptorOffset + kDescriptorBytes == kKeyframeRecordBytes, "record layout");
constexpr int kQuatComponentBits = 15;
constexpr double kSqrt2 = 1.4142135623730951;

std::uint32_t FloatBits(float f) noexcept {
  std::uint32_t u = 0;
  static_assert(sizeof(u) == sizeof(f), "IEEE-754 binary32 expected");
  std::memcpy(&u, &f, sizeof(u));
  return u;
}

float BitsToFloat(std::uint32_t u) noexcept {
  float f = 0.0f;
  std::memcpy(&f, &u, sizeof(f));
  return f;
}

// LSB-first bit field writer / reader over a zero-initialised byte range.
void PutBits(std::uint8_t* base, std::size_t bit_offset, int bits, std::uint32_t value) noexcept {
  for (int b = 0; b < bits; ++b, ++bit_offset) {
    if ((value >> b) & 1u) base[bit_offset / 8] |= static_cast<std::uint8_t>(1u << (bit_offset % 8));
  }
}

std::uint32_t GetBits(const std::uint8_t* base, std::size_t bit_offset, int bits) noexcept {
  std::uint32_t value = 0;
  for (int b = 0; b < bits; ++b, ++bit_offset) {
    value |= static_cast<std::uint32_t>((base[bit_offset / 8] >> (bit_offset % 8)) & 1u) << b;
  }
  return value;
}

std::int32_t SignExtend15(std::uint32_t v) noexcept {
  return (v & 0x4000u) ? static_cast<std::int32_t>(v) - 0x8000 : static_cast<std::int32_t>(v);
}

std::string RecordName(const char* kind, std::uint32_t index) {
  return std::string(kind) + " " + std::to_string(index) + ": ";
}

// The 22-byte pose header shared by the keyframe records (bytes 0 .. 21 of the layout in the header): validates
// T_map_sensor and writes index, float32 translation and the smallest-three rotation into p (zeroed by the
// caller). `kind` names the record in messages.
Status EncodePoseHeader(const char* kind, std::uint32_t index, const Eigen::Isometry3d& T_map_sensor,
                        std::uint8_t* p) {
  const auto who = [kind, index] { return RecordName(kind, index); };  // built only on error
  const Eigen::Matrix4d& M = T_map_sensor.matrix();
  if (!M.allFinite()) return InvalidArgument(who() + "pose has a NaN/inf entry");
  const Eigen::Matrix3d R = T_map_sensor.linear();
  const double ortho_error = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(ortho_error <= 1e-3) || !(R.determinant() > 0.0)) {
    return InvalidArgument(who() + "pose rotation is not a rotation matrix (max |R^T R - I| = " +
                           FormatNumber(ortho_error, 9) + ", det = " + FormatNumber(R.determinant(), 9) + ")");
  }
  const Eigen::Vector3d t = T_map_sensor.translation();
  float tf[3];
  for (int i = 0; i < 3; ++i) {
    tf[i] = static_cast<float>(t[i]);
    if (!std::isfinite(tf[i])) {
      return InvalidArgument(who() + "translation " + FormatNumber(t[i], 9) + " m is beyond the float32 range");
    }
  }

  PutU32Le(p, index);
  for (int i = 0; i < 3; ++i) PutU32Le(p + kTranslationOffset + 4 * i, FloatBits(tf[i]));

  // Smallest three: components in the order w, x, y, z.
  Eigen::Quaterniond q(R);
  q.normalize();
  double c[4] = {q.w(), q.x(), q.y(), q.z()};
  int largest = 0;
  for (int i = 1; i < 4; ++i) {
    if (std::fabs(c[i]) > std::fabs(c[largest])) largest = i;
  }
  if (c[largest] < 0.0) {
    for (double& v : c) v = -v;
  }
  std::uint8_t* const rot = p + kRotationOffset;
  PutBits(rot, 0, 2, static_cast<std::uint32_t>(largest));
  std::size_t bit = 2;
  for (int i = 0; i < 4; ++i) {
    if (i == largest) continue;
    const double scaled = std::clamp(c[i] * kSqrt2, -1.0, 1.0) * kKeyframeQuaternionMaxCode;
    const auto code = static_cast<std::int32_t>(std::lround(scaled));
    PutBits(rot, bit, kQuatComponentBits, static_cast<std::uint32_t>(code) & 0x7fffu);
    bit += kQuatComponentBits;
  }
  // bit 47 stays 0 (reserved)
  return Status::Ok();
}

// Reads the pose header of p (at least kKeyframePoseHeaderBytes bytes). Errors (data loss): non-finite
// translation, reserved bit set, a quaternion that no encoder writes.
Status DecodePoseHeader(const char* kind, const std::uint8_t* p, std::uint32_t* index, Eigen::Isometry3d* T_map_sensor) {
  *index = GetU32Le(p);
  const auto who = [kind, index] { return RecordName(kind, *index); };  // built only on error

  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i) {
    const float f = BitsToFloat(GetU32Le(p + kTranslationOffset + 4 * i));
    if (!std::isfinite(f)) return DataLoss(who() + "translation component " + std::to_string(i) + " is not finite");
    t[i] = static_cast<double>(f);
  }

  const std::uint8_t* const rot = p + kRotationOffset;
  if (GetBits(rot, 47, 1) != 0) return DataLoss(who() + "reserved rotation bit is set");
  const int largest = static_cast<int>(GetBits(rot, 0, 2));
  double c[4] = {0.0, 0.0, 0.0, 0.0};
  double sum_sq = 0.0, max_kept = 0.0;
  std::size_t bit = 2;
  for (int i = 0; i < 4; ++i) {
    if (i == largest) continue;
    const std::int32_t code = SignExtend15(GetBits(rot, bit, kQuatComponentBits));
    bit += kQuatComponentBits;
    if (code < -kKeyframeQuaternionMaxCode) {
      return DataLoss(who() + "rotation component code " + std::to_string(code) + " is never written");
    }
    c[i] = static_cast<double>(code) / kKeyframeQuaternionMaxCode / kSqrt2;
    sum_sq += c[i] * c[i];
    max_kept = std::max(max_kept, std::fabs(c[i]));
  }
  // An encoder drops the largest component, so the kept ones satisfy sum c^2 <= 3/4 and |c| <= dropped
  // (slack: quantisation moves each component by <= 2.2e-5).
  constexpr double kSlack = 1e-3;
  if (sum_sq > 0.75 + kSlack) {
    return DataLoss(who() + "rotation is not a smallest-three quaternion (sum of squares " + FormatNumber(sum_sq, 9) +
                    " > 3/4)");
  }
  c[largest] = std::sqrt(std::max(0.0, 1.0 - sum_sq));
  if (max_kept > c[largest] + kSlack) {
    return DataLoss(who() + "rotation is not a smallest-three quaternion (dropped component " +
                    FormatNumber(c[largest], 9) + " is not the largest)");
  }
  Eigen::Quaterniond q(c[0], c[1], c[2], c[3]);
  q.normalize();
  *T_map_sensor = Eigen::Isometry3d::Identity();
  T_map_sensor->linear() = q.toRotationMatrix();
  T_map_sensor->translation() = t;
  return Status::Ok();
}

constexpr const char* kSolidRecordKind = "keyframe record";
constexpr const char* kScanContextRecordKind = "Scan Context record";

// Grid dims the Scan Context record accepts (those of ValidateScanContextParams).
Status CheckScanContextGrid(int num_rings, int num_sectors) {
  if (num_rings < 1 || num_rings > kScanContextMaxRings || num_sectors < 1 || num_sectors > kScanContextMaxSectors ||
      360 % num_sectors != 0) {
    return InvalidArgument("Scan Context record: grid " + std::to_string(num_rings) + " x " +
                           std::to_string(num_sectors) + " is outside num_rings in [1, " +
                           std::to_string(kScanContextMaxRings) + "], num_sectors in [1, 360] dividing 360");
  }
  return Status::Ok();
}

}  // namespace

Status EncodeKeyframeRecord(const KeyframeRecord& record, Span<std::uint8_t> out) {
  const auto who = [&record] { return RecordName(kSolidRecordKind, record.keyframe_index); };  // built only on error
  if (out.size() != kKeyframeRecordBytes) {
    return InvalidArgument(who() + "output buffer holds " + std::to_string(out.size()) + " bytes, expected " +
                           std::to_string(kKeyframeRecordBytes));
  }
  if (!record.descriptor_valid) return InvalidArgument(who() + "descriptor is invalid; invalid descriptors are not sent");

  // Descriptor: non-negative, finite, unit norm.
  double norm2 = 0.0, max_value = 0.0;
  for (std::size_t i = 0; i < kKeyframeDescriptorDim; ++i) {
    const double v = static_cast<double>(record.descriptor[i]);
    if (!std::isfinite(v) || v < 0.0) {
      return InvalidArgument(who() + "descriptor value " + std::to_string(i) + " is " + FormatNumber(v, 9) +
                             " (R-SOLiD is finite and >= 0)");
    }
    norm2 += v * v;
    max_value = std::max(max_value, v);
  }
  const double norm = std::sqrt(norm2);
  if (!(std::fabs(norm - 1.0) <= 1e-3)) {
    return InvalidArgument(who() + "descriptor norm is " + FormatNumber(norm, 9) +
                           ", expected 1 (send the unit-normalised R-SOLiD; an all-zero descriptor is invalid)");
  }

  std::fill(out.begin(), out.end(), std::uint8_t{0});
  std::uint8_t* const p = out.data();
  if (Status s = EncodePoseHeader(kSolidRecordKind, record.keyframe_index, record.T_map_sensor, p); !s.ok()) return s;

  // Descriptor, scaled by its largest element.
  std::uint8_t* const desc = p + kDescriptorOffset;
  for (std::size_t i = 0; i < kKeyframeDescriptorDim; ++i) {
    const double v = static_cast<double>(record.descriptor[i]) / max_value * kKeyframeDescriptorMaxCode;
    const auto code = static_cast<std::uint32_t>(
        std::clamp<long>(std::lround(v), 0L, static_cast<long>(kKeyframeDescriptorMaxCode)));
    PutBits(desc, i * kKeyframeDescriptorBits, kKeyframeDescriptorBits, code);
  }
  return Status::Ok();
}

Result<KeyframeRecord> DecodeKeyframeRecord(Span<const std::uint8_t> bytes) {
  if (bytes.size() != kKeyframeRecordBytes) {
    return DataLoss("keyframe record: " + std::to_string(bytes.size()) + " bytes, expected " +
                    std::to_string(kKeyframeRecordBytes));
  }
  const std::uint8_t* const p = bytes.data();
  KeyframeRecord rec;
  if (Status s = DecodePoseHeader(kSolidRecordKind, p, &rec.keyframe_index, &rec.T_map_sensor); !s.ok()) return s;
  const auto who = [&rec] { return RecordName(kSolidRecordKind, rec.keyframe_index); };  // built only on error

  const std::uint8_t* const desc = p + kDescriptorOffset;
  std::uint32_t codes[kKeyframeDescriptorDim];
  std::uint32_t max_code = 0;
  double norm2 = 0.0;
  for (std::size_t i = 0; i < kKeyframeDescriptorDim; ++i) {
    codes[i] = GetBits(desc, i * kKeyframeDescriptorBits, kKeyframeDescriptorBits);
    max_code = std::max(max_code, codes[i]);
    norm2 += static_cast<double>(codes[i]) * static_cast<double>(codes[i]);
  }
  if (max_code != kKeyframeDescriptorMaxCode) {
    return DataLoss(who() + "descriptor's largest code is " + std::to_string(max_code) + ", expected " +
                    std::to_string(kKeyframeDescriptorMaxCode) + " (corrupt or all-zero descriptor)");
  }
  const double norm = std::sqrt(norm2);
  for (std::size_t i = 0; i < kKeyframeDescriptorDim; ++i) {
    rec.descriptor[i] = static_cast<float>(static_cast<double>(codes[i]) / norm);
  }
  rec.descriptor_valid = true;
  return rec;
}

Status EncodeScanContextRecord(const KeyframePose& pose, Span<const float> descriptor, int num_rings,
                               int num_sectors, Span<std::uint8_t> out) {
  if (Status s = CheckScanContextGrid(num_rings, num_sectors); !s.ok()) return s;
  const auto who = [&pose] { return RecordName(kScanContextRecordKind, pose.keyframe_index); };  // on error only
  const std::size_t cells = static_cast<std::size_t>(num_rings) * static_cast<std::size_t>(num_sectors);
  if (descriptor.size() != cells) {
    return InvalidArgument(who() + "descriptor holds " + std::to_string(descriptor.size()) + " values, expected " +
                           std::to_string(num_rings) + " x " + std::to_string(num_sectors) + " = " +
                           std::to_string(cells));
  }
  if (out.size() != ScanContextRecordBytes(num_rings, num_sectors)) {
    return InvalidArgument(who() + "output buffer holds " + std::to_string(out.size()) + " bytes, expected " +
                           std::to_string(ScanContextRecordBytes(num_rings, num_sectors)));
  }
  float scale = 0.0f;
  bool any_nonzero = false;
  for (std::size_t i = 0; i < cells; ++i) {
    const float v = descriptor[i];
    if (!std::isfinite(v)) {
      return InvalidArgument(who() + "descriptor value " + std::to_string(i) + " is " +
                             FormatNumber(static_cast<double>(v), 9) + " (Scan Context cells are finite)");
    }
    scale = std::max(scale, v);
    any_nonzero = any_nonzero || v != 0.0f;
  }
  if (!any_nonzero) return InvalidArgument(who() + "descriptor is all zero (invalid descriptors are not sent)");
  if (!(scale > 0.0f)) {
    return InvalidArgument(who() + "descriptor has no positive cell (every non-zero cell is negative: the record's "
                           "scale is the largest cell value and must be > 0)");
  }

  std::fill(out.begin(), out.end(), std::uint8_t{0});
  std::uint8_t* const p = out.data();
  if (Status s = EncodePoseHeader(kScanContextRecordKind, pose.keyframe_index, pose.T_map_sensor, p); !s.ok()) {
    return s;
  }
  PutU32Le(p + kPoseHeaderBytes, FloatBits(scale));
  std::uint8_t* const codes = p + kPoseHeaderBytes + 4;
  const double to_code = static_cast<double>(kScanContextMaxCode) / static_cast<double>(scale);
  for (std::size_t i = 0; i < cells; ++i) {
    const double v = static_cast<double>(descriptor[i]);
    if (v == 0.0) continue;  // empty stays empty (code 0)
    // v > 0: round(255 v / scale), at least 1 so that the cell stays non-empty; v < 0: 1 (see the header).
    const long code = v > 0.0 ? std::lround(v * to_code) : 1L;
    codes[i] = static_cast<std::uint8_t>(std::clamp<long>(code, 1L, static_cast<long>(kScanContextMaxCode)));
  }
  return Status::Ok();
}

Result<KeyframePose> DecodeScanContextRecord(Span<const std::uint8_t> bytes, int num_rings, int num_sectors,
                                             Span<float> descriptor) {
  if (Status s = CheckScanContextGrid(num_rings, num_sectors); !s.ok()) return s;
  const std::size_t cells = static_cast<std::size_t>(num_rings) * static_cast<std::size_t>(num_sectors);
  if (descriptor.size() != cells) {
    return InvalidArgument("Scan Context record: output holds " + std::to_string(descriptor.size()) +
                           " values, expected " + std::to_string(num_rings) + " x " + std::to_string(num_sectors) +
                           " = " + std::to_string(cells));
  }
  if (bytes.size() != ScanContextRecordBytes(num_rings, num_sectors)) {
    return DataLoss("Scan Context record: " + std::to_string(bytes.size()) + " bytes, expected " +
                    std::to_string(ScanContextRecordBytes(num_rings, num_sectors)) + " for a " +
                    std::to_string(num_rings) + " x " + std::to_string(num_sectors) + " grid");
  }
  const std::uint8_t* const p = bytes.data();
  KeyframePose pose;
  if (Status s = DecodePoseHeader(kScanContextRecordKind, p, &pose.keyframe_index, &pose.T_map_sensor); !s.ok()) {
    return s;
  }
  const auto who = [&pose] { return RecordName(kScanContextRecordKind, pose.keyframe_index); };  // on error only
  const float scale = BitsToFloat(GetU32Le(p + kPoseHeaderBytes));
  if (!(std::isfinite(scale) && scale > 0.0f)) {
    return DataLoss(who() + "scale " + FormatNumber(static_cast<double>(scale), 9) + " is not finite and > 0");
  }
  const std::uint8_t* const codes = p + kPoseHeaderBytes + 4;
  std::uint8_t max_code = 0;
  for (std::size_t i = 0; i < cells; ++i) max_code = std::max(max_code, codes[i]);
  if (max_code == 0) return DataLoss(who() + "no non-zero code (corrupt or all-zero descriptor)");
  if (max_code != kScanContextMaxCode) {
    return DataLoss(who() + "largest code is " + std::to_string(max_code) + ", expected " +
                    std::to_string(kScanContextMaxCode) + " (the scale is the largest cell; corrupt record)");
  }
  const double step = static_cast<double>(scale) / static_cast<double>(kScanContextMaxCode);
  for (std::size_t i = 0; i < cells; ++i) descriptor[i] = static_cast<float>(codes[i] * step);
  return pose;
}

std::uint16_t FloatToHalf(float value) noexcept {
  std::uint32_t u = FloatBits(value);
  const auto sign = static_cast<std::uint16_t>((u >> 16) & 0x8000u);
  u &= 0x7fffffffu;
  if (u > 0x7f800000u) return static_cast<std::uint16_t>(sign | 0x7e00u);  // NaN (payload dropped)
  if (u >= 0x47800000u) return static_cast<std::uint16_t>(sign | 0x7c00u);  // >= 65536 or inf
  if (u >= 0x38800000u) {  // normal half (>= 2^-14): rebias, round the 13 dropped bits to nearest even
    const std::uint32_t mant_odd = (u >> 13) & 1u;
    u += 0xc8000000u + 0xfffu + mant_odd;  // (15 - 127) << 23 modulo 2^32; may carry into inf
    return static_cast<std::uint16_t>(sign | (u >> 13));
  }
  if (u < 0x33000000u) return sign;  // below 2^-25: rounds to zero
  // Subnormal half: value / 2^-24 = significand >> (126 - exponent), rounded to nearest even.
  const std::uint32_t exponent = u >> 23;                     // 102 .. 112
  const std::uint32_t significand = (u & 0x7fffffu) | 0x800000u;
  const std::uint32_t shift = 126u - exponent;                 // 14 .. 24
  std::uint32_t q = significand >> shift;
  const std::uint32_t rem = significand & ((1u << shift) - 1u);
  const std::uint32_t half = 1u << (shift - 1u);
  if (rem > half || (rem == half && (q & 1u))) ++q;  // may become 0x400, the smallest normal: still right
  return static_cast<std::uint16_t>(sign | q);
}

float HalfToFloat(std::uint16_t bits) noexcept {
  const std::uint32_t sign = static_cast<std::uint32_t>(bits & 0x8000u) << 16;
  std::uint32_t exponent = (bits >> 10) & 0x1fu;
  std::uint32_t mant = bits & 0x3ffu;
  if (exponent == 0x1fu) return BitsToFloat(sign | 0x7f800000u | (mant << 13));  // inf / NaN
  if (exponent == 0) {
    if (mant == 0) return BitsToFloat(sign);
    // Subnormal: normalise the significand.
    int e = 1;
    while ((mant & 0x400u) == 0) {
      mant <<= 1;
      --e;
    }
    mant &= 0x3ffu;
    return BitsToFloat(sign | (static_cast<std::uint32_t>(e + 112) << 23) | (mant << 13));
  }
  return BitsToFloat(sign | ((exponent + 112u) << 23) | (mant << 13));
}

Status EncodeFloat16(Span<const float> values, Span<std::uint8_t> out) {
  if (out.size() != Float16EncodedBytes(values.size())) {
    return InvalidArgument("float16: output holds " + std::to_string(out.size()) + " bytes, " +
                           std::to_string(values.size()) + " values need " +
                           std::to_string(Float16EncodedBytes(values.size())));
  }
  for (std::size_t i = 0; i < values.size(); ++i) {
    const std::uint16_t h = FloatToHalf(values[i]);
    if ((h & 0x7c00u) == 0x7c00u) {
      return InvalidArgument("float16: value " + std::to_string(i) + " (" +
                             FormatNumber(static_cast<double>(values[i]), 9) +
                             ") is not finite or beyond the half range (|v| < 65520)");
    }
    out[2 * i] = static_cast<std::uint8_t>(h & 0xffu);
    out[2 * i + 1] = static_cast<std::uint8_t>(h >> 8);
  }
  return Status::Ok();
}

Status DecodeFloat16(Span<const std::uint8_t> bytes, Span<float> out) {
  if (bytes.size() != Float16EncodedBytes(out.size())) {
    return DataLoss("float16: " + std::to_string(bytes.size()) + " bytes for " + std::to_string(out.size()) +
                    " values, expected " + std::to_string(Float16EncodedBytes(out.size())));
  }
  for (std::size_t i = 0; i < out.size(); ++i) {
    const auto h = static_cast<std::uint16_t>(bytes[2 * i] | (bytes[2 * i + 1] << 8));
    if ((h & 0x7c00u) == 0x7c00u) {
      return DataLoss("float16: value " + std::to_string(i) + " is inf or NaN (corrupt data)");
    }
    out[i] = HalfToFloat(h);
  }
  return Status::Ok();
}

const char* KeyframeRecordKindName(KeyframeRecordKind kind) noexcept {
  switch (kind) {
    case KeyframeRecordKind::kUnit40: return "unit-40";
    case KeyframeRecordKind::kScanContext: return "scan-context";
    case KeyframeRecordKind::kCompact40: return "compact-40";
  }
  return "unknown";
}

bool IsKeyframeRecordKind(std::uint8_t wire_value) noexcept {
  return wire_value == static_cast<std::uint8_t>(KeyframeRecordKind::kUnit40) ||
         wire_value == static_cast<std::uint8_t>(KeyframeRecordKind::kScanContext) ||
         wire_value == static_cast<std::uint8_t>(KeyframeRecordKind::kCompact40);
}

std::size_t KeyframeRecordBytesOf(KeyframeRecordKind kind) noexcept {
  switch (kind) {
    case KeyframeRecordKind::kUnit40: return kKeyframeRecordBytes;
    case KeyframeRecordKind::kScanContext: return ScanContextRecordBytes(kScanContextWireRings, kScanContextWireSectors);
    case KeyframeRecordKind::kCompact40: return 0;
  }
  return 0;
}

std::size_t KeyframeRecordDimOf(KeyframeRecordKind kind) noexcept {
  switch (kind) {
    case KeyframeRecordKind::kUnit40:
    case KeyframeRecordKind::kCompact40: return kKeyframeDescriptorDim;
    case KeyframeRecordKind::kScanContext:
      return static_cast<std::size_t>(kScanContextWireRings) * static_cast<std::size_t>(kScanContextWireSectors);
  }
  return 0;
}

namespace {

// An unknown kind, or a descriptor span of another size than the kind's record carries.
Status CheckRecordDescriptorSize(KeyframeRecordKind kind, std::size_t size) {
  const std::size_t dim = KeyframeRecordDimOf(kind);
  if (dim == 0 || KeyframeRecordBytesOf(kind) == 0) {
    return InvalidArgument("keyframe record: kind " + std::to_string(static_cast<int>(kind)) +
                           " is not a kind of single records");
  }
  if (size != dim) {
    return InvalidArgument(std::string("keyframe record (") + KeyframeRecordKindName(kind) + "): descriptor of " +
                           std::to_string(size) + " values, expected " + std::to_string(dim));
  }
  return Status::Ok();
}

}  // namespace

Status EncodeRecordOfKind(KeyframeRecordKind kind, const KeyframePose& pose, Span<const float> descriptor,
                          Span<std::uint8_t> out) {
  if (Status st = CheckRecordDescriptorSize(kind, descriptor.size()); !st.ok()) return st;
  if (kind == KeyframeRecordKind::kScanContext) {
    return EncodeScanContextRecord(pose, descriptor, kScanContextWireRings, kScanContextWireSectors, out);
  }
  KeyframeRecord record;
  record.keyframe_index = pose.keyframe_index;
  record.T_map_sensor = pose.T_map_sensor;
  std::copy(descriptor.begin(), descriptor.end(), record.descriptor.begin());
  record.descriptor_valid = true;
  return EncodeKeyframeRecord(record, out);
}

Result<KeyframePose> DecodeRecordOfKind(KeyframeRecordKind kind, Span<const std::uint8_t> bytes,
                                        Span<float> descriptor) {
  if (Status st = CheckRecordDescriptorSize(kind, descriptor.size()); !st.ok()) return st;
  if (kind == KeyframeRecordKind::kScanContext) {
    return DecodeScanContextRecord(bytes, kScanContextWireRings, kScanContextWireSectors, descriptor);
  }
  auto record = DecodeKeyframeRecord(bytes);
  if (!record.ok()) return record.status();
  std::copy(record->descriptor.begin(), record->descriptor.end(), descriptor.begin());
  return KeyframePose{record->keyframe_index, record->T_map_sensor};
}

}  // namespace commerge
