// SPDX-License-Identifier: BSD-3-Clause
// commerge: poses on the compact wire (pose_update_t, and the poses of the compact keyframe batch,
// compact_batch_codec.hpp): one quantisation, and a list of keyframe poses coded as residuals against their
// predecessors in the list.
//
// The quantisation (the resolution every pose on the wire has):
//   translation a 1 mm grid per axis (kCompactTranslationStepM): error <= 0.5 mm per axis, the float32 of the
//               92-byte record far from the origin; beyond +-2^43 steps (8.8e9 m) a pose is refused.
//   rotation    the unit quaternion (w, x, y, z), each component round(c * 32767) (kCompactQuaternionScale),
//               sign chosen continuous along a list (q and -q are one rotation); decoded as the normalised codes:
//               angle error <= ~1.2e-4 rad (0.007 deg).
// Why this resolution: the finest use of a streamed pose is the pose a robot sends before the scans the server
// requested, when it moved 1 cm / 0.05 deg (RobotAgentParams::request_pose_min_...): the grid is 20x and the
// rotation codes 7x below it, so quantising never triggers a resend or moves a submap point by more than a
// millimetre per 10 m of range; one step coarser (1 cm) would be as large as that threshold.
//
// The pose list (pose_update_t.poses): bits LSB-first in each byte, zero-padded to a byte, integers as EG(k)
// (core/common/exp_golomb.hpp).
//   3 x 4 bits: k_index, k_translation, k_rotation (the encoder's choice per list: the orders that make it shortest);
//   pose 0:     keyframe index EG(0); translation EG(0) of the 3 zig-zagged grid values; rotation 4 x 16-bit two's
//               complement codes; no_descriptor 1 bit;
//   pose i >= 1: keyframe index EG(k_index) of the zig-zagged index_i - index_{i-1} - 1 (any order, usually 0:
//               the next keyframe); translation and rotation EG(k_translation), EG(k_rotation) of each zig-zagged
//               residual against the linear prediction 2 p_{i-1} - p_{i-2} (p_{i-1} for i = 1); no_descriptor 1 bit.
// A loop closure moves neighbouring keyframes alike, so a corrected stretch codes in about 5-8 bytes a pose
// (33 as float32 arrays). Each list decodes alone: no state of earlier updates is needed.
//
// The decoder refuses (data loss, naming the pose): a stream that ends early or has bytes or set padding bits
// left, an EG code with more than 48 leading zeros, an index outside 0..2^31 - 1, a grid value beyond +-2^43, a
// quaternion code outside +-32767 or an all-zero quaternion.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/common/exp_golomb.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

/// Translation grid [m] and quaternion code scale of the compact codecs.
constexpr double kCompactTranslationStepM = 1e-3;
constexpr int kCompactQuaternionScale = 32767;
/// Bits of a quaternion component coded whole (two's complement).
constexpr int kCompactQuaternionCodeBits = 16;
/// Grid values a compact pose may hold: |value| < 2^43 (8.8e9 m).
constexpr std::int64_t kCompactMaxGridValue = std::int64_t{1} << 43;

/// A pose as the compact codecs code it.
struct CompactPoseCodes {
  std::array<std::int64_t, 3> t{};  ///< translation in kCompactTranslationStepM steps
  std::array<std::int64_t, 4> q{};  ///< w, x, y, z in 1 / kCompactQuaternionScale
};

/// Quantises `T` (finite; its rotation as the normalised quaternion of T.linear()); `previous_q` (or nullptr:
/// w >= 0) picks the quaternion's sign closest to it. InvalidArgument starting with `who` for a non-finite pose
/// or a translation beyond the grid.
Result<CompactPoseCodes> QuantiseCompactPose(const Eigen::Isometry3d& T, const std::array<std::int64_t, 4>* previous_q,
                                             const std::string& who);
/// The pose the codes stand for (what a decoder gives).
Eigen::Isometry3d DequantiseCompactPose(const CompactPoseCodes& codes);
/// Decoded codes a decoder must refuse: "" if none, else what is wrong (grid, quaternion range, zero quaternion).
std::string CompactPoseCodesError(const CompactPoseCodes& codes);
/// The linear prediction of element i of a list from the two before it (the one before for i = 1).
inline std::int64_t PredictCompact(std::int64_t before_last, std::int64_t last, std::size_t i) {
  return i >= 2 ? 2 * last - before_last : last;
}

/// The pose part of one element of a compact list, shared by both codecs: element 0 whole (EG(0) of the 3
/// zig-zagged grid values, 4 x 16-bit quaternion codes), element i >= 1 as the zig-zagged residuals against the
/// linear prediction from `before` (element i - 2; i - 1 for i = 1) and `last` (element i - 1).
struct CompactPoseResiduals {
  std::array<std::uint64_t, 3> t{};
  std::array<std::uint64_t, 4> q{};
};
CompactPoseResiduals CompactPoseResidualsOf(const CompactPoseCodes& before, const CompactPoseCodes& last,
                                            const CompactPoseCodes& codes, std::size_t i);
void PutCompactPoseWhole(const CompactPoseCodes& codes, BitWriter* w);
void PutCompactPoseResiduals(const CompactPoseResiduals& r, int k_translation, int k_rotation, BitWriter* w);
/// Reads element i's pose (whole for i = 0) and checks it (CompactPoseCodesError): "" or what is wrong.
std::string GetCompactPose(BitReader* r, std::size_t i, int k_translation, int k_rotation,
                           const CompactPoseCodes& before, const CompactPoseCodes& last, CompactPoseCodes* codes);
/// What GetCompactPose and the codecs say when the stream ends early.
inline const char* CompactStreamEnded() {
  return "the stream ends early, or an Exp-Golomb code has more than 48 leading zeros";
}

/// Poses of one pose list at most (pose_update_t.MAX_POSES).
constexpr std::size_t kMaxCompactPoses = 4096;
/// Bytes of one pose list at most: kMaxCompactPoses poses of at most 64 bytes each (the longest codes the encoder
/// can write: ~62 bytes a pose).
constexpr std::size_t kMaxCompactPoseBytes = kMaxCompactPoses * 64;

/// Codes `keyframes[i]`, `poses[i]` and `no_descriptor[i]` (0 or 1; empty = all 0) into `out` (replaced). Errors
/// (invalid argument, naming the pose): sizes that differ or exceed kMaxCompactPoses, an index above 2^31 - 1, a
/// flag other than 0 / 1, the quantisation's.
Status EncodeCompactPoses(Span<const std::uint32_t> keyframes, Span<const Eigen::Isometry3d> poses,
                          Span<const std::uint8_t> no_descriptor, std::vector<std::uint8_t>* out);

/// Decodes a list of `num_poses` poses (0..kMaxCompactPoses; 0 poses is 0 bytes) into the three vectors (resized
/// to num_poses). Errors: data loss as listed above; the outputs unspecified then.
Status DecodeCompactPoses(Span<const std::uint8_t> bytes, std::size_t num_poses, std::vector<std::uint32_t>* keyframes,
                          std::vector<Eigen::Isometry3d>* poses, std::vector<std::uint8_t>* no_descriptor);

}  // namespace commerge
