// SPDX-License-Identifier: BSD-3-Clause
// Helpers shared by the tests of the merge server's modules (test_keyframe_database.cpp, test_exchange_planner.cpp,
// test_pair_registrar.cpp, test_server_link.cpp): the paper's stage A, and a two-robot pair whose stage A cluster
// holds places alpha saw twice. The target compiles in unity batches: a helper used by one file stays in that file,
// under a name no other file of the target uses.
#pragma once

#include <doctest/doctest.h>

#include <cstdint>
#include <vector>

#include "core/agent/merge_server_params.hpp"
#include "core/agent/messages.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "tests/core/agent/keyframe_batch_fixtures.hpp"

namespace commerge::test {

// The paper's stage A (B_ij = [A_ij <= tau_inter]) at span area `tau_area`, every other server default.
inline MergeServerParams PaperStageA(std::uint64_t tau_area) {
  MergeServerParams params;
  params.cascade.stage_a = SequentialMatchParams{};
  params.cascade.stage_a.tau_area = tau_area;
  return params;
}

// ShiftedPairBatches(40, 5) with alpha's keyframes 30..39 made copies of 5..14 and moved 100 m on: stage A's
// cluster (alpha 5..29 with beta 0..24) then holds 10 places alpha saw twice, far apart, of 25.
inline std::vector<KeyframeBatch> AmbiguousShiftedPairBatches() {
  std::vector<KeyframeBatch> batches = ShiftedPairBatches(40, 5);
  std::vector<std::uint8_t>& records = batches[0].records;
  for (std::uint32_t k = 30; k < 40; ++k) {
    auto copy = DecodeKeyframeRecord(
        Span<const std::uint8_t>(records.data() + (k - 25) * kKeyframeRecordBytes, kKeyframeRecordBytes));
    auto moved_or = DecodeKeyframeRecord(
        Span<const std::uint8_t>(records.data() + k * kKeyframeRecordBytes, kKeyframeRecordBytes));
    REQUIRE(copy.ok());
    REQUIRE(moved_or.ok());
    KeyframeRecord moved = *moved_or;
    moved.descriptor = copy->descriptor;
    moved.T_map_sensor.translation().x() += 100.0;
    REQUIRE(EncodeKeyframeRecord(moved, Span<std::uint8_t>(records.data() + k * kKeyframeRecordBytes,
                                                          kKeyframeRecordBytes)).ok());
  }
  return batches;
}

}  // namespace commerge::test
