// SPDX-License-Identifier: BSD-3-Clause
// Test fixtures shared by the agent tests: random SOLiD-like descriptors, keyframe batches as a robot encodes
// them, and a two-robot pair whose stage A loops are known in advance.
#pragma once

#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "core/agent/messages.hpp"
#include "core/descriptor/compact_batch_codec.hpp"
#include "core/descriptor/descriptor_codec.hpp"

namespace commerge::test {

/// A random unit descriptor with non-negative entries (as SOLiD's).
inline std::array<float, kKeyframeDescriptorDim> RandomDescriptor(std::mt19937* rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::array<float, kKeyframeDescriptorDim> d{};
  double n = 0.0;
  for (float& v : d) {
    v = u(*rng);
    n += static_cast<double>(v) * static_cast<double>(v);
  }
  for (float& v : d) v = static_cast<float>(static_cast<double>(v) / std::sqrt(n));
  return d;
}

/// Keyframes first, first + 1, ... of `robot` with the given descriptors (all valid) and positions, each
/// reporting `points` stored points.
inline KeyframeBatch MakeBatch(int robot, std::uint32_t first,
                               const std::vector<std::array<float, kKeyframeDescriptorDim>>& descriptors,
                               const std::vector<Eigen::Vector3d>& positions, std::uint32_t points) {
  KeyframeBatch b;
  b.robot_id = robot;
  for (std::size_t k = 0; k < descriptors.size(); ++k) {
    KeyframeRecord r;
    r.keyframe_index = first + static_cast<std::uint32_t>(k);
    r.T_map_sensor.translation() = positions[k];
    r.descriptor = descriptors[k];
    r.descriptor_valid = true;
    const std::size_t at = b.records.size();
    b.records.resize(at + kKeyframeRecordBytes);
    REQUIRE(EncodeKeyframeRecord(r, Span<std::uint8_t>(b.records.data() + at, kKeyframeRecordBytes)).ok());
    b.stored_points.push_back(points);
  }
  return b;
}

/// The same keyframes as one compact batch with `bits` per descriptor value; keyframe k of the batch reports
/// points + 37 k stored points (the counts travel in the stream and differ from keyframe to keyframe).
inline KeyframeBatch MakeCompactBatch(int robot, std::uint32_t first,
                                      const std::vector<std::array<float, kKeyframeDescriptorDim>>& descriptors,
                                      const std::vector<Eigen::Vector3d>& positions, std::uint32_t points, int bits) {
  KeyframeBatch b;
  b.robot_id = robot;
  b.record_kind = KeyframeRecordKind::kCompact40;
  std::vector<CompactKeyframe> keyframes(descriptors.size());
  for (std::size_t k = 0; k < descriptors.size(); ++k) {
    keyframes[k].pose.keyframe_index = first + static_cast<std::uint32_t>(k);
    keyframes[k].pose.T_map_sensor.translation() = positions[k];
    keyframes[k].descriptor = descriptors[k];
    keyframes[k].stored_points = points + 37 * static_cast<std::uint32_t>(k);
  }
  b.num_compact_records = keyframes.size();
  REQUIRE(EncodeCompactBatch(Span<const CompactKeyframe>(keyframes), bits, &b.records).ok());
  return b;
}

/// Two robots of n keyframes: beta's keyframe j sees alpha's place j + shift (its own frame is shifted and
/// rotated), so stage A's loops are (j + shift, j). Alpha reports 2 000 stored points a scan, beta 3 000.
/// session > 0: robot r's batch carries session + r.
inline std::vector<KeyframeBatch> ShiftedPairBatches(int n, int shift, std::int64_t session = 0) {
  std::mt19937 rng(7);
  std::vector<std::array<float, kKeyframeDescriptorDim>> da, db;
  std::vector<Eigen::Vector3d> pa, pb;
  for (int i = 0; i < n; ++i) {
    da.push_back(RandomDescriptor(&rng));
    pa.emplace_back(i, 0.0, 0.0);
  }
  for (int j = 0; j < n; ++j) {
    db.push_back(j + shift < n ? da[static_cast<std::size_t>(j + shift)] : RandomDescriptor(&rng));
    pb.emplace_back(-static_cast<double>(j), 3.0, 0.0);
  }
  std::vector<KeyframeBatch> out = {MakeBatch(0, 0, da, pa, 2000), MakeBatch(1, 0, db, pb, 3000)};
  for (KeyframeBatch& b : out) b.session = session > 0 ? session + b.robot_id : 0;
  return out;
}

/// The reference widening (WidenPlan's rule): `selected` plus the keyframes of `pool` nearest in index to any of
/// `selected` (ties: the lower index) until there are `target` of them, by brute force over the pool; sorted.
inline std::vector<std::uint32_t> BruteForceWiden(const std::vector<std::uint32_t>& selected,
                                                  const std::vector<std::uint32_t>& pool, std::size_t target) {
  std::vector<std::pair<long, std::uint32_t>> ranked;
  for (std::uint32_t k : pool) {
    if (std::find(selected.begin(), selected.end(), k) != selected.end()) continue;
    long d = 1L << 40;
    for (std::uint32_t s : selected) d = std::min(d, std::labs(static_cast<long>(k) - static_cast<long>(s)));
    ranked.emplace_back(d, k);
  }
  std::sort(ranked.begin(), ranked.end());
  std::vector<std::uint32_t> out = selected;
  for (std::size_t i = 0; i < ranked.size() && out.size() < target; ++i) out.push_back(ranked[i].second);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace commerge::test
