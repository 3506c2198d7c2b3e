// SPDX-License-Identifier: BSD-3-Clause
// commerge: wire encodings of descriptors.
//
// 1. The keyframe record a robot sends to the server: keyframe index, pose T_map_sensor and the
//    unit-normalised R-SOLiD (40 values) in kKeyframeRecordBytes = 92 bytes (the paper's ledger counts
//    448 B for the descriptor alone). Layout, little-endian, bit fields packed LSB-first (bit k of a field
//    is bit k % 8 of its byte k / 8):
//
//      bytes  0 ..  3  keyframe index, uint32
//      bytes  4 .. 15  translation x, y, z [m], IEEE-754 binary32 (error <= 0.49 mm below 16 km)
//      bytes 16 .. 21  rotation, 48-bit "smallest three" unit quaternion:
//                        bits  0 ..  1  index i of the dropped component (0 = w, 1 = x, 2 = y, 3 = z), the
//                                       one of largest magnitude, made positive (q and -q are one rotation)
//                        bits  2 .. 46  the other three components in ascending index order, each
//                                       round(c * sqrt(2) * 16383) as 15-bit two's complement in
//                                       [-16383, 16383] (|c| <= 1/sqrt(2)); -16384 is never written
//                        bit  47        reserved, 0
//                      the dropped component is recovered as sqrt(1 - sum c^2); angle error <= ~1e-4 rad
//      bytes 22 .. 91  descriptor, 40 x 14-bit unsigned codes, value k at bits 14 k .. 14 k + 13:
//                        code_k = round(d_k / max_j d_j * 16383), so the largest element is exactly 16383
//                        (scale-free: the decoder re-normalises to unit length; R-SOLiD is >= 0)
//
//    Descriptor error: the decoded unit vector is within asin(m r) of the original, m = max_j d_j <= 1,
//    r = sqrt(40) / (2 * 16383) = 1.93e-4, so a pair distance moves by at most asin(m_a r) + asin(m_b r)
//    <= 3.9e-4 (plus float rounding, ~1e-6): 25x below the smallest threshold tau = 0.01.
//
// 2. IEEE-754 binary16 (half) arrays for descriptors without a dedicated codec (Scan Context 20 x 60 ->
//    2400 bytes): 2 bytes per value, little-endian, round to nearest even.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

/// Descriptor length the keyframe record carries (R-SOLiD with the paper's 40 rings).
constexpr std::size_t kKeyframeDescriptorDim = 40;
/// Encoded size of one keyframe record.
constexpr std::size_t kKeyframeRecordBytes = 92;
static_assert(kKeyframeRecordBytes <= 96, "the keyframe record must fit 96 bytes");

/// Bits and largest code of one descriptor element.
constexpr int kKeyframeDescriptorBits = 14;
constexpr std::uint32_t kKeyframeDescriptorMaxCode = (1u << kKeyframeDescriptorBits) - 1;  // 16383
/// Largest code magnitude of a quaternion component (15-bit two's complement, symmetric).
constexpr std::int32_t kKeyframeQuaternionMaxCode = (1 << 14) - 1;  // 16383

/// The record, decoded or to encode.
struct KeyframeRecord {
  std::uint32_t keyframe_index = 0;
  /// Pose of the keyframe's sensor in the robot's own map frame (rotation part must be a rotation).
  Eigen::Isometry3d T_map_sensor = Eigen::Isometry3d::Identity();
  /// Unit-normalised R-SOLiD (SolidDescriptor::Compute output). Decoded: re-normalised to unit length.
  std::array<float, kKeyframeDescriptorDim> descriptor{};
  /// Explicit validity (SolidDescriptor's DescriptorInfo::valid). Invalid descriptors are never encoded;
  /// a decoded record is always valid.
  bool descriptor_valid = false;
};

/// Encodes `record` into exactly kKeyframeRecordBytes bytes of `out` (layout above).
/// Errors (invalid argument, `out` unspecified): out.size() != kKeyframeRecordBytes; descriptor_valid
/// false; a descriptor value not finite or negative; descriptor norm not within 1e-3 of 1 (includes the
/// all-zero descriptor); non-finite pose; translation beyond float range; rotation part not a rotation
/// (max |R^T R - I| > 1e-3 or det R <= 0).
Status EncodeKeyframeRecord(const KeyframeRecord& record, Span<std::uint8_t> out);

/// Decodes one record. The quaternion and the descriptor are re-normalised.
/// Errors (data loss): size != kKeyframeRecordBytes; non-finite translation; reserved bit set; a
/// quaternion that no encoder writes (component code -16384, sum of squares > 3/4, or a kept component
/// larger than the dropped one); a descriptor whose largest code is not 16383 (includes all zeros).
Result<KeyframeRecord> DecodeKeyframeRecord(Span<const std::uint8_t> bytes);

/// IEEE-754 binary16 bits of `value`, rounded to nearest even; overflow gives +-inf, NaN a quiet NaN.
std::uint16_t FloatToHalf(float value) noexcept;
/// The float that half `bits` represents (exact).
float HalfToFloat(std::uint16_t bits) noexcept;

/// Bytes of `count` values encoded as float16.
constexpr std::size_t Float16EncodedBytes(std::size_t count) noexcept { return 2 * count; }

/// Encodes `values` as little-endian float16 into `out` (exactly Float16EncodedBytes(values.size())).
/// Errors (invalid argument): wrong out size; a value that is not finite or rounds beyond the half range
/// (|v| >= 65520); the message names the index.
Status EncodeFloat16(Span<const float> values, Span<std::uint8_t> out);

/// Decodes little-endian float16 `bytes` into `out` (bytes.size() must be 2 * out.size()).
/// Errors (data loss): wrong sizes; an inf/NaN half (no encoder writes one), naming the index.
Status DecodeFloat16(Span<const std::uint8_t> bytes, Span<float> out);

}  // namespace commerge
