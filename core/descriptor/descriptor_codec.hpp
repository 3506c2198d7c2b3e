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
// 2. The Scan Context keyframe record (SOLID.md §6): the same 22-byte pose header (bytes 0 .. 21 above, one shared
//    encoder and decoder), then the descriptor in 8 bits per cell: ScanContextRecordBytes(N_r, N_s) =
//    22 + 4 + N_r x N_s bytes (1226 for 20 x 60, against 2400 as float16 and 9 600 as float64). The grid dims
//    are not on the wire: both ends know them from the descriptor parameters (ScanContextParams, whose
//    parameter id the robot announces), and the decoder is told them.
//
//      bytes  0 .. 21  pose header, as in the R-SOLiD record (index, translation, rotation, reserved bit 47)
//      bytes 22 .. 25  scale [m], IEEE-754 binary32: the largest cell value, finite and > 0
//      bytes 26 ..     N_r x N_s codes, uint8, row-major [ring][sector] like the descriptor:
//                        v == 0 -> 0 (empty stays empty);
//                        v > 0  -> max(1, round(255 v / scale)) (a non-empty cell never becomes empty, so the
//                                  column masks of the distance survive); the largest cell is exactly 255;
//                        v < 0  -> 1 (a cell whose points all lie below -lidar_height_m, rare: kept non-empty,
//                                  its sign is lost; decoded as scale / 255)
//                      decoded v' = code x scale / 255.
//
//    Cell error: |v' - v| <= scale / 510 for v >= scale / 510, < scale / 255 for 0 < v < scale / 510 (lifted
//    to code 1). Distance error: zero and non-zero cells keep their state, so every shift compares the same
//    columns C_s; a column x moves by the angle theta(x) <= asin(||e|| / ||x||) (e its error vector), each
//    cosine by at most theta_q + theta_c, so |D' - D| <= max_c theta(q_c) + max_c theta(c_c) for non-negative
//    Scan Contexts (a loose worst case: the measured changes stay below 4 % of it). Measured on 576 pairs of
//    ray-cast street scans (tests/core/descriptor/test_descriptor_codec.cpp): |D' - D| <= 2.1e-3, mean 4e-4,
//    far below the gaps that separate places (0.1 and more).
//
// 3. IEEE-754 binary16 (half) arrays for descriptors without a dedicated codec (Scan Context 20 x 60 ->
//    2400 bytes): 2 bytes per value, little-endian, round to nearest even.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/descriptor/place_descriptor.hpp"

namespace commerge {

/// Descriptor length the keyframe record carries (R-SOLiD with the paper's 40 rings).
constexpr std::size_t kKeyframeDescriptorDim = 40;
/// Encoded size of one keyframe record.
constexpr std::size_t kKeyframeRecordBytes = 92;
static_assert(kKeyframeRecordBytes <= 96, "the keyframe record must fit 96 bytes");

/// Bytes of the pose header every keyframe record starts with (index, translation, rotation).
constexpr std::size_t kKeyframePoseHeaderBytes = 22;

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

/// Largest code of a Scan Context cell (8 bits).
constexpr std::uint8_t kScanContextMaxCode = 255;

/// Encoded size of a Scan Context record of a num_rings x num_sectors grid (22 + 4 + num_rings x num_sectors;
/// 1226 for 20 x 60). Precondition: counts >= 0 (the codec refuses grids outside ValidateScanContextParams).
constexpr std::size_t ScanContextRecordBytes(int num_rings, int num_sectors) noexcept {
  return kKeyframePoseHeaderBytes + 4 + static_cast<std::size_t>(num_rings) * static_cast<std::size_t>(num_sectors);
}
static_assert(ScanContextRecordBytes(20, 60) == 1226, "Scan Context record of the default grid");

/// Index and pose of a keyframe: the header of a Scan Context record (the descriptor travels in a caller span).
struct KeyframePose {
  std::uint32_t keyframe_index = 0;
  /// Pose of the keyframe's sensor in the robot's own map frame (rotation part must be a rotation).
  Eigen::Isometry3d T_map_sensor = Eigen::Isometry3d::Identity();
};

/// Encodes one Scan Context record (layout 2 above) into exactly ScanContextRecordBytes(num_rings, num_sectors)
/// bytes of `out`. `descriptor`: num_rings x num_sectors cells, row-major (ComputeScanContext's output).
/// Errors (invalid argument, `out` unspecified): a grid outside ValidateScanContextParams' ranges, wrong
/// descriptor or out size, a value not finite, an all-zero descriptor (invalid descriptors are not sent), no
/// positive cell (scale <= 0), a bad pose (the R-SOLiD record's checks: non-finite, translation beyond float
/// range, rotation part not a rotation).
Status EncodeScanContextRecord(const KeyframePose& pose, Span<const float> descriptor, int num_rings,
                               int num_sectors, Span<std::uint8_t> out);

/// Decodes one Scan Context record of a num_rings x num_sectors grid; the cells go to `descriptor` (num_rings x
/// num_sectors floats, row-major; unspecified on error), no allocation. Decoded cells are >= 0.
/// Errors: invalid argument for a bad grid or descriptor size (the caller's); data loss for a size other than
/// ScanContextRecordBytes, the pose header's failures (non-finite translation, reserved bit set, a quaternion no
/// encoder writes), a scale not finite or <= 0, no non-zero code, a largest code other than 255.
Result<KeyframePose> DecodeScanContextRecord(Span<const std::uint8_t> bytes, int num_rings, int num_sectors,
                                             Span<float> descriptor);

/// What the records of a keyframe batch carry (keyframe_batch_t.record_kind). A robot sends one kind; the server
/// expects one (its --descriptor) and refuses batches of another.
enum class KeyframeRecordKind : std::uint8_t {
  kUnit40 = 1,       ///< the 92-byte record: 40 unit values (R-SOLiD, the ring-occupancy descriptor)
  kScanContext = 2,  ///< the Scan Context record of the kScanContextWireRings x kScanContextWireSectors grid
  /// A compact batch (compact_batch_codec.hpp): the keyframes of kUnit40 coded together, of variable length. A
  /// server of kUnit40 takes both.
  kCompact40 = 3,
};
/// Bytes of one compact batch at most: 512 records of at most 336 bytes each (the longest Exp-Golomb codes the
/// encoder can write: ~321 bytes a record, of which 8 for the stored point count).
constexpr std::size_t kMaxCompactBatchBytes = 512 * 336;
/// The one Scan Context grid on the wire (the paper's and Kim & Kim's 20 x 60): 1226-byte records.
constexpr int kScanContextWireRings = 20;
constexpr int kScanContextWireSectors = 60;
/// The record that carries a descriptor of `kind`: kScanContext for Scan Context, kUnit40 for SOLiD and the ring
/// descriptor (the one place that decides it, for RobotAgent and the delivery digest).
constexpr KeyframeRecordKind RecordKindOf(DescriptorKind kind) noexcept {
  return kind == DescriptorKind::kScanContext ? KeyframeRecordKind::kScanContext : KeyframeRecordKind::kUnit40;
}
/// What a robot sends for a descriptor of `kind`: compact batches (kCompact40) for the 40-value descriptors when
/// `record_descriptor_bits` > 0 (RobotAgentParams), else RecordKindOf(kind).
constexpr KeyframeRecordKind RobotRecordKind(DescriptorKind kind, int record_descriptor_bits) noexcept {
  return RecordKindOf(kind) == KeyframeRecordKind::kUnit40 && record_descriptor_bits > 0 ? KeyframeRecordKind::kCompact40
                                                                                         : RecordKindOf(kind);
}
/// "unit-40" / "scan-context" / "compact-40" ("unknown" otherwise).
const char* KeyframeRecordKindName(KeyframeRecordKind kind) noexcept;
/// A kind a decoder accepts (1, 2 or 3).
bool IsKeyframeRecordKind(std::uint8_t wire_value) noexcept;
/// The kind a server of `server_kind` holds `batch_kind`'s descriptors as: kUnit40 for kCompact40 (the same
/// descriptor), else the kind itself.
constexpr KeyframeRecordKind HeldRecordKind(KeyframeRecordKind batch_kind) noexcept {
  return batch_kind == KeyframeRecordKind::kCompact40 ? KeyframeRecordKind::kUnit40 : batch_kind;
}
/// Bytes of one record of `kind` (0 for kCompact40, whose batches have no fixed record size, and an unknown
/// kind), floats of its descriptor (0 for an unknown kind).
std::size_t KeyframeRecordBytesOf(KeyframeRecordKind kind) noexcept;
std::size_t KeyframeRecordDimOf(KeyframeRecordKind kind) noexcept;
/// Encodes one record of `kind` (`descriptor`: KeyframeRecordDimOf(kind) values, unit-normalised for kUnit40)
/// into exactly KeyframeRecordBytesOf(kind) bytes of `out`. Errors: those of EncodeKeyframeRecord /
/// EncodeScanContextRecord, an unknown kind, a descriptor of the wrong size.
Status EncodeRecordOfKind(KeyframeRecordKind kind, const KeyframePose& pose, Span<const float> descriptor,
                          Span<std::uint8_t> out);
/// Decodes one record of `kind`; the descriptor goes to `descriptor` (KeyframeRecordDimOf(kind) floats).
Result<KeyframePose> DecodeRecordOfKind(KeyframeRecordKind kind, Span<const std::uint8_t> bytes,
                                        Span<float> descriptor);

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
