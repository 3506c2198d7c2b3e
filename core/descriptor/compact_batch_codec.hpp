// SPDX-License-Identifier: BSD-3-Clause
// commerge: the compact keyframe batch (keyframe_batch_t.record_kind = RECORD_COMPACT40): the keyframes of one
// batch -- index, pose T_map_sensor, 40 unit values (R-SOLiD or the ring descriptor), the points of its stored
// scan -- coded together, so that what neighbouring keyframes share is sent once. Each batch decodes on its own
// (a lost batch costs only itself).
//
// What is kept (the quantisation; the coding after it is lossless):
//   descriptor  code_k = round(d_k / max_j d_j * L), L = 2^b - 1 (b = descriptor_bits, 4..14, in the batch
//               header): the largest element is exactly L; decoded d'_k = code_k / ||code|| (unit length). A
//               keyframe's decoded descriptor depends on its own values only, never on the batch around it.
//   pose        the compact pose quantisation (core/descriptor/compact_pose_codec.hpp: a 1 mm grid, 16-bit
//               quaternion codes with the sign continuous along the batch; <= 0.5 mm per axis, ~1.2e-4 rad).
//   stored points exactly.
//
// Layout (bytes): [0] descriptor_bits b; [1..] the bit stream, LSB-first in each byte, zero-padded to a byte,
// every integer an Exp-Golomb code EG(k) (core/common/exp_golomb.hpp; signed values zig-zagged).
//   4 bits each: k_gap, k_translation, k_rotation, k_descriptor, k_points (the encoder's choice per batch: the
//   order that makes the batch shortest);
//   record 0:  keyframe index  EG(0) of the index;
//              translation     EG(0) of the 3 zig-zagged grid values;
//              rotation        4 x 16-bit two's complement codes;
//              descriptor      40 x b-bit codes;
//              stored points   EG(0) of the count;
//   record i >= 1:
//              keyframe index  EG(k_gap) of index_i - index_{i-1} - 1 (indices ascend);
//              translation     EG(k_translation) of each axis' zig-zagged residual against the linear
//                              prediction 2 t_{i-1} - t_{i-2} (t_{i-1} for i = 1) on the grid;
//              rotation        EG(k_rotation) of each component's zig-zagged residual, predicted the same way;
//              descriptor      EG(k_descriptor) of each code's zig-zagged difference from record i-1's;
//              stored points   EG(k_points) of the zig-zagged difference from record i-1's count.
// The record count is the batch's num_records (keyframe_batch_t carries no separate point counts for this kind).
//
// Decoders refuse (data loss, naming the record): b outside 4..14, a stream that ends early or has bytes or set
// padding bits left, an EG code with more than 48 leading zeros (the encoder writes at most 46), an index that
// does not ascend or passes 2^32 - 1, a grid value beyond +-2^43 (8.8e9 m), a quaternion code outside +-32767 or an all-zero quaternion, a descriptor code
// above L or a descriptor whose largest code is not L, a point count outside 0..2^31 - 1.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/descriptor/compact_pose_codec.hpp"
#include "core/descriptor/descriptor_codec.hpp"

namespace commerge {

/// Descriptor bits a compact batch may carry (its header byte).
constexpr int kCompactMinDescriptorBits = 4;
constexpr int kCompactMaxDescriptorBits = 14;
/// The largest stored point count a compact batch carries (keyframe_batch_t's int32 bound).
constexpr std::uint32_t kCompactMaxStoredPoints = 2147483647u;

/// One keyframe of a compact batch, to encode or decoded.
struct CompactKeyframe {
  KeyframePose pose;
  /// Unit-normalised, >= 0 (encode); decoded: unit length, quantised to the batch's descriptor bits.
  std::array<float, kKeyframeDescriptorDim> descriptor{};
  /// Points of the keyframe's stored scan (0 = not stored), 0..kCompactMaxStoredPoints; kept exactly.
  std::uint32_t stored_points = 0;
};

/// The keyframe of `pose`, `descriptor` (its first kKeyframeDescriptorDim values; a 40-value descriptor's) and
/// `stored_points`.
inline CompactKeyframe MakeCompactKeyframe(const KeyframePose& pose, Span<const float> descriptor,
                                           std::uint32_t stored_points) {
  CompactKeyframe k;
  k.pose = pose;
  k.stored_points = stored_points;
  for (std::size_t i = 0; i < kKeyframeDescriptorDim && i < descriptor.size(); ++i) k.descriptor[i] = descriptor[i];
  return k;
}

/// Encodes `keyframes` (1..kMaxCompactBatchRecords, ascending keyframe indices) with `descriptor_bits` per
/// descriptor value into `out` (replaced). Errors (invalid argument, naming the keyframe): bits outside 4..14, no
/// or too many keyframes, indices not ascending, the 92-byte record's checks of pose and descriptor (finite,
/// rotation, >= 0, unit norm), a translation beyond 8.8e9 m, a point count above kCompactMaxStoredPoints.
Status EncodeCompactBatch(Span<const CompactKeyframe> keyframes, int descriptor_bits, std::vector<std::uint8_t>* out);

/// Decodes a compact batch of `num_records` records (1..kMaxCompactBatchRecords) into `out` (resized to
/// num_records). Errors: data loss as listed in the header comment; `out` unspecified then.
Status DecodeCompactBatch(Span<const std::uint8_t> bytes, std::size_t num_records, std::vector<CompactKeyframe>* out);

/// What DecodeCompactBatch gives for one keyframe (the descriptor and pose the server will hold), without a
/// batch: the robot's delivery digest uses it. Errors: those of EncodeCompactBatch.
Result<CompactKeyframe> QuantiseCompactKeyframe(const CompactKeyframe& keyframe, int descriptor_bits);

/// Records of one compact batch at most (keyframe_batch_t.MAX_RECORDS).
constexpr std::size_t kMaxCompactBatchRecords = 512;

}  // namespace commerge
