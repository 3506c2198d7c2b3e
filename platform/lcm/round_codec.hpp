// SPDX-License-Identifier: BSD-3-Clause
// The merge round's step record (core/agent/messages.hpp: RoundStep) to and from its LCM encoding
// (lcmtypes/merge_round_t). Same guarantees as platform/lcm/message_codec.hpp: the bytes are exactly what
// lcm.publish() puts on the wire, and decoding is bounded (fingerprint first, then every count against its MAX_...
// and the buffer before anything is allocated).
#pragma once

#include <cstdint>
#include <vector>

#include "core/agent/messages.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge::platform {

/// "COMMERGE_ROUND": merge_round_t, server -> everyone (the recorder logs it; `commerge server --replay` reads it).
extern const char* const kRoundChannel;

/// Errors (InvalidArgument naming the field): a robot id outside 0..63 (robots and requests); robots not
/// ascending and unique; more than kMaxMergeRobots robots or kMaxRoundRequests requests, or more than
/// kMaxRoundKeyframes keyframes in all; request keyframes not ascending and unique; a counter, keyframe or step
/// that does not fit its int32 / int16 wire field; a negative step or round.
Status EncodeRoundStep(const RoundStep& message, std::vector<std::uint8_t>* out);

/// Errors (DataLoss naming what is wrong): a foreign fingerprint (checked first); truncated or trailing bytes;
/// a count outside [0, MAX] or beyond the buffer; request keyframe counts that do not add up to num_keyframes;
/// negative counters, keyframes or request keyframe counts; booleans other than 0/1; and everything the encoder
/// refuses.
Result<RoundStep> DecodeRoundStep(Span<const std::uint8_t> bytes);

}  // namespace commerge::platform
