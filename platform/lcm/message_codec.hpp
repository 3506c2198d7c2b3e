// SPDX-License-Identifier: BSD-3-Clause
// The robot <-> server messages (core/agent/messages.hpp) to and from their LCM encoding (lcmtypes/). The bytes
// are exactly what lcm.publish() puts on the wire for that channel (fingerprint + fields), so a byte ledger that
// counts these buffers counts the wire. Decoding is bounded: the fingerprint is checked (a foreign type is
// refused by name), and every array length is read and checked against its MAX_... constant and the buffer
// size before anything is allocated.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/agent/messages.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge::platform {

/// Channel names (lcm-spy shows them): COMMERGE_KEYFRAMES, COMMERGE_POSES, COMMERGE_POLICY, COMMERGE_SCANS. The
/// status, merge-result and health channels are in platform/lcm/status_codec.hpp.
extern const char* const kKeyframesChannel;
extern const char* const kPosesChannel;
extern const char* const kPolicyChannel;
extern const char* const kScansChannel;

/// Encoders replace `*out` with the message's wire bytes. Errors (InvalidArgument naming the field): a robot id
/// outside 0..63, an array beyond its MAX_..., inconsistent sizes, a non-finite pose. PoseUpdate::no_descriptor
/// may be empty (sent as all 0) or hold one 0/1 flag per keyframe.
Status EncodeKeyframeBatch(const KeyframeBatch& message, std::vector<std::uint8_t>* out);
Status EncodePoseUpdate(const PoseUpdate& message, std::vector<std::uint8_t>* out);
Status EncodeScanRequest(const ScanRequest& message, std::vector<std::uint8_t>* out);
Status EncodeScanChunk(const ScanChunk& message, std::vector<std::uint8_t>* out);

/// Decoders. Errors (DataLoss): foreign fingerprint (another message type), truncated or trailing bytes, a count
/// outside [0, MAX], negative ids or indices, sizes that contradict each other, non-finite values, flags other
/// than 0/1, a compact pose list that does not decode (core/descriptor/compact_pose_codec.hpp). A decoded
/// PoseUpdate always has one no_descriptor flag per keyframe, its poses on the compact pose grid.
Result<KeyframeBatch> DecodeKeyframeBatch(Span<const std::uint8_t> bytes);
Result<PoseUpdate> DecodePoseUpdate(Span<const std::uint8_t> bytes);
Result<ScanRequest> DecodeScanRequest(Span<const std::uint8_t> bytes);
Result<ScanChunk> DecodeScanChunk(Span<const std::uint8_t> bytes);

}  // namespace commerge::platform
