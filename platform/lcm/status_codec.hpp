// SPDX-License-Identifier: BSD-3-Clause
// The acknowledgement, merge-result and health messages (core/agent/messages.hpp: TransferStatus,
// MergeResultMessage, RobotStatus, ServerStatus) to and from their LCM encoding (lcmtypes/transfer_status_t,
// merge_result_t, robot_status_t, server_status_t). Same guarantees as platform/lcm/message_codec.hpp: the bytes
// are exactly what lcm.publish() puts on the wire, and decoding is bounded (fingerprint first, then every count
// against its MAX_... and the buffer, and every string length against kMaxStatusTextBytes and the buffer, before
// anything is allocated).
#pragma once

#include <cstdint>
#include <vector>

#include "core/agent/messages.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge::platform {

/// Channel names (lcm-spy shows them).
extern const char* const kStatusChannel;       ///< "COMMERGE_TRANSFER_STATUS": transfer_status_t, server -> robot
extern const char* const kMergeResultChannel;  ///< "COMMERGE_MERGE_RESULT": merge_result_t, server -> everyone
extern const char* const kRobotStatusChannel;  ///< "COMMERGE_ROBOT_STATUS": robot_status_t
extern const char* const kServerStatusChannel; ///< "COMMERGE_SERVER_STATUS": server_status_t

/// Encoders replace `*out` with the message's wire bytes (on error it is left as it was). Errors (InvalidArgument
/// naming the field): a robot id outside 0..63; an array beyond its MAX_...; per-robot or per-pair arrays of
/// different sizes; a non-finite transform or overlap; a string longer than kMaxStatusTextBytes or holding a
/// NUL; a value that does not fit its int32 / int16 wire field; flags other than 0/1; TransferStatus gaps that
/// are empty, not ascending and disjoint, or outside [keyframes_contiguous, keyframes_seen) (which needs
/// keyframes_contiguous <= keyframes_seen); missing chunk ranges not ascending by keyframe (ranges of one
/// keyframe ascending and disjoint, count 0 only alone) or beyond chunk kMaxChunksPerScan; MergeResultMessage
/// robot ids not ascending and unique.
Status EncodeTransferStatus(const TransferStatus& message, std::vector<std::uint8_t>* out);
Status EncodeMergeResult(const MergeResultMessage& message, std::vector<std::uint8_t>* out);
Status EncodeRobotStatus(const RobotStatus& message, std::vector<std::uint8_t>* out);
Status EncodeServerStatus(const ServerStatus& message, std::vector<std::uint8_t>* out);

/// Decoders. Errors (DataLoss naming what is wrong): a foreign fingerprint (checked first); truncated or
/// trailing bytes; a count outside [0, MAX] or beyond the buffer; a string length outside 1..257 or beyond the
/// buffer; non-finite values; quaternions whose norm is off 1 by more than 1e-3; robot ids outside 0..63;
/// negative keyframes, chunk indices and counters; booleans other than 0/1; and everything the encoder refuses.
Result<TransferStatus> DecodeTransferStatus(Span<const std::uint8_t> bytes);
Result<MergeResultMessage> DecodeMergeResult(Span<const std::uint8_t> bytes);
Result<RobotStatus> DecodeRobotStatus(Span<const std::uint8_t> bytes);
Result<ServerStatus> DecodeServerStatus(Span<const std::uint8_t> bytes);

}  // namespace commerge::platform
