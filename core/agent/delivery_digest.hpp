// SPDX-License-Identifier: BSD-3-Clause
// commerge: a digest of the keyframe descriptors one robot has delivered, computed the same way on both ends so
// two processes can prove "every descriptor arrived, bit for bit" by comparing two short lines of text.
//
//   robot  : RobotDeliveryDigest(mapper, bits) - what the server must end up holding: each valid descriptor as the
//            keyframe record codec transmits it (quantised, re-normalised), in keyframe order;
//   server : ServerDeliveryDigest(db)     - what the server holds.
// The digest is FNV-1a 64 over (keyframe index, descriptor float bits) of every keyframe with a valid
// descriptor. Counts come along so a mismatch says whether keyframes are missing or differ.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/common/status.hpp"

namespace commerge {

class RobotMapper;
struct RobotKeyframeDb;

struct DeliveryDigest {
  std::size_t keyframes = 0;        ///< keyframes known (robot: made; server: seen)
  std::size_t delivered = 0;        ///< robot: all of them; server: RobotKeyframeDb::delivered(k)
  std::size_t descriptors = 0;      ///< keyframes with a valid descriptor
  std::uint64_t digest = 0;         ///< FNV-1a 64 over (index, descriptor) of those
  /// "keyframes K, delivered D, descriptors N, digest 0123456789abcdef" (the form the fault tests compare).
  std::string ToText() const;
};

/// `record_descriptor_bits`: the robot's RobotAgentParams::record_descriptor_bits (what its batches carry).
Result<DeliveryDigest> RobotDeliveryDigest(const RobotMapper& mapper, int record_descriptor_bits);
DeliveryDigest ServerDeliveryDigest(const RobotKeyframeDb& db);

}  // namespace commerge
