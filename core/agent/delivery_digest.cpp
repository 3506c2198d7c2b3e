// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/delivery_digest.hpp"

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <vector>

#include "core/agent/merge_server.hpp"
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

void MixKeyframe(std::uint64_t* h, std::uint32_t index, const float* descriptor) {
  Mix(h, &index, sizeof(index));
  Mix(h, descriptor, kKeyframeDescriptorDim * sizeof(float));
}

}  // namespace

std::string DeliveryDigest::ToText() const {
  char text[128];
  std::snprintf(text, sizeof(text), "keyframes %zu, delivered %zu, descriptors %zu, digest %016" PRIx64, keyframes,
                delivered, descriptors, digest);
  return text;
}

Result<DeliveryDigest> RobotDeliveryDigest(const RobotMapper& mapper) {
  DeliveryDigest d;
  d.digest = kFnvOffset;
  d.keyframes = mapper.num_keyframes();
  d.delivered = d.keyframes;
  std::vector<std::uint8_t> bytes(kKeyframeRecordBytes);
  for (std::size_t k = 0; k < mapper.num_keyframes(); ++k) {
    if (!mapper.descriptor_valid(k)) continue;
    KeyframeRecord record;
    record.keyframe_index = static_cast<std::uint32_t>(k);
    record.T_map_sensor = mapper.pose(k);
    const Span<const float> descriptor = mapper.descriptor(k);
    if (descriptor.size() < kKeyframeDescriptorDim) return InvalidArgument("keyframe " + std::to_string(k) + ": descriptor shorter than the record's");
    std::copy(descriptor.begin(), descriptor.begin() + static_cast<std::ptrdiff_t>(kKeyframeDescriptorDim),
              record.descriptor.begin());
    record.descriptor_valid = true;
    if (Status st = EncodeKeyframeRecord(record, Span<std::uint8_t>(bytes)); !st.ok()) return st;
    auto sent = DecodeKeyframeRecord(Span<const std::uint8_t>(bytes));
    if (!sent.ok()) return sent.status();
    MixKeyframe(&d.digest, record.keyframe_index, sent->descriptor.data());
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
    MixKeyframe(&d.digest, static_cast<std::uint32_t>(k), &db.descriptors[k * kKeyframeDescriptorDim]);
    ++d.descriptors;
  }
  return d;
}

}  // namespace commerge
