// SPDX-License-Identifier: BSD-3-Clause
// The keyframes a keyframe batch of the 40-value kinds carries (a compact batch, or 92-byte records with their
// point counts beside), decoded the way the server does: for the tests and the fuzz seed corpus.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/agent/messages.hpp"
#include "core/descriptor/compact_batch_codec.hpp"
#include "core/descriptor/descriptor_codec.hpp"

namespace commerge::test {

inline Result<std::vector<CompactKeyframe>> BatchKeyframes(const KeyframeBatch& batch) {
  std::vector<CompactKeyframe> out;
  if (batch.record_kind == KeyframeRecordKind::kCompact40) {
    if (Status st = DecodeCompactBatch(Span<const std::uint8_t>(batch.records), batch.num_records(), &out); !st.ok()) {
      return st;
    }
    return out;
  }
  if (batch.record_kind != KeyframeRecordKind::kUnit40 || !batch.RecordArraysConsistent()) {
    return InvalidArgument("BatchKeyframes: not a consistent batch of 92-byte records or a compact batch");
  }
  for (std::size_t i = 0; i < batch.num_records(); ++i) {
    auto record = DecodeKeyframeRecord(
        Span<const std::uint8_t>(batch.records.data() + i * kKeyframeRecordBytes, kKeyframeRecordBytes));
    if (!record.ok()) return record.status();
    CompactKeyframe k;
    k.pose = KeyframePose{record->keyframe_index, record->T_map_sensor};
    k.descriptor = record->descriptor;
    k.stored_points = batch.stored_points[i];
    out.push_back(k);
  }
  return out;
}

}  // namespace commerge::test
