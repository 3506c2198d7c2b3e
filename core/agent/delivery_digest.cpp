// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/delivery_digest.hpp"

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <vector>

#include "core/agent/merge_server.hpp"
#include "core/descriptor/compact_batch_codec.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "core/slam/robot_mapper.hpp"

namespace commerge {

namespace {

constexpr std::uint64_t kFnvOffset = 1469598103934665603ull;
constexpr std::uint64_t kFnvPrime = 1099511628211ull;

void Mix(std::uint64_t* h, const void* data, std::size_t n) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) {
    *h ^= p[i];
    *h *= kFnvPrime;
  }
}

void MixKeyframe(std::uint64_t* h, std::uint32_t index, const float* descriptor, std::size_t dim) {
  Mix(h, &index, sizeof(index));
  Mix(h, descriptor, dim * sizeof(float));
}

}  // namespace

std::string DeliveryDigest::ToText() const {
  char text[128];
  std::snprintf(text, sizeof(text), "keyframes %zu, delivered %zu, descriptors %zu, digest %016" PRIx64, keyframes,
                delivered, descriptors, digest);
  return text;
}

Result<DeliveryDigest> RobotDeliveryDigest(const RobotMapper& mapper, int record_descriptor_bits) {
  DeliveryDigest d;
  d.digest = kFnvOffset;
  d.keyframes = mapper.num_keyframes();
  d.delivered = d.keyframes;
  // The record kind RobotAgent sends for this mapper's descriptor.
  const KeyframeRecordKind kind = RobotRecordKind(mapper.descriptor_kind(), record_descriptor_bits);
  std::vector<std::uint8_t> bytes(KeyframeRecordBytesOf(kind));
  std::vector<float> sent(KeyframeRecordDimOf(kind));
  for (std::size_t k = 0; k < mapper.num_keyframes(); ++k) {
    if (!mapper.descriptor_valid(k)) continue;
    const KeyframePose pose{static_cast<std::uint32_t>(k), mapper.pose(k)};
    if (kind == KeyframeRecordKind::kCompact40) {
      // A compact batch decodes each keyframe as its quantisation alone.
      auto quantised = QuantiseCompactKeyframe(MakeCompactKeyframe(pose, mapper.descriptor(k), 0), record_descriptor_bits);
      if (!quantised.ok()) return quantised.status();
      std::copy(quantised->descriptor.begin(), quantised->descriptor.end(), sent.begin());
    } else {
      if (Status st = EncodeRecordOfKind(kind, pose, mapper.descriptor(k), Span<std::uint8_t>(bytes)); !st.ok()) {
        return st;
      }
      auto decoded = DecodeRecordOfKind(kind, Span<const std::uint8_t>(bytes), Span<float>(sent));
      if (!decoded.ok()) return decoded.status();
    }
    MixKeyframe(&d.digest, pose.keyframe_index, sent.data(), sent.size());
    ++d.descriptors;
  }
  return d;
}

DeliveryDigest ServerDeliveryDigest(const RobotKeyframeDb& db) {
  DeliveryDigest d;
  d.digest = kFnvOffset;
  d.keyframes = db.size();
  for (std::size_t k = 0; k < db.size(); ++k) {
    if (db.delivered(k)) ++d.delivered;
    if (!db.valid[k]) continue;
    MixKeyframe(&d.digest, static_cast<std::uint32_t>(k), &db.descriptors[k * db.dim], db.dim);
    ++d.descriptors;
  }
  return d;
}

}  // namespace commerge
