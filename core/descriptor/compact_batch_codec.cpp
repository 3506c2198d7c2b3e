// SPDX-License-Identifier: BSD-3-Clause
#include "core/descriptor/compact_batch_codec.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/common/exp_golomb.hpp"

namespace commerge {
namespace {

/// The integers a keyframe is coded as (its quantisation).
struct Codes {
  std::uint32_t index = 0;
  CompactPoseCodes pose;
  std::array<std::uint32_t, kKeyframeDescriptorDim> d{};
  std::uint32_t points = 0;
};

std::string Who(std::uint32_t index) { return "compact keyframe batch: keyframe " + std::to_string(index) + ": "; }

/// Checks `k` as the 92-byte record would, then quantises it; `previous_q` (or nullptr) picks the quaternion sign.
Result<Codes> Quantise(const CompactKeyframe& k, int bits, const std::array<std::int64_t, 4>* previous_q) {
  std::array<std::uint8_t, kKeyframeRecordBytes> scratch{};
  if (Status st = EncodeRecordOfKind(KeyframeRecordKind::kUnit40, k.pose, Span<const float>(k.descriptor),
                                     Span<std::uint8_t>(scratch));
      !st.ok()) {
    return InvalidArgument("compact keyframe batch: " + st.message());
  }
  Codes c;
  c.index = k.pose.keyframe_index;
  if (k.stored_points > kCompactMaxStoredPoints) {
    return InvalidArgument(Who(c.index) + "stored point count " + std::to_string(k.stored_points) +
                           " is above 2^31 - 1");
  }
  c.points = k.stored_points;
  auto pose = QuantiseCompactPose(k.pose.T_map_sensor, previous_q, Who(c.index));
  if (!pose.ok()) return pose.status();
  c.pose = *pose;
  const double levels = static_cast<double>((1u << bits) - 1u);
  const float max_value = *std::max_element(k.descriptor.begin(), k.descriptor.end());
  for (std::size_t i = 0; i < kKeyframeDescriptorDim; ++i) {
    const double v = std::round(static_cast<double>(k.descriptor[i]) / static_cast<double>(max_value) * levels);
    c.d[i] = static_cast<std::uint32_t>(std::clamp(v, 0.0, levels));
  }
  return c;
}

/// The keyframe that codes `c` stand for (what the decoder gives).
CompactKeyframe Dequantise(const Codes& c) {
  CompactKeyframe k;
  k.pose.keyframe_index = c.index;
  k.stored_points = c.points;
  k.pose.T_map_sensor = DequantiseCompactPose(c.pose);
  double norm2 = 0.0;
  for (std::uint32_t v : c.d) norm2 += static_cast<double>(v) * static_cast<double>(v);
  const double norm = std::sqrt(norm2);
  for (std::size_t i = 0; i < kKeyframeDescriptorDim; ++i) {
    k.descriptor[i] = static_cast<float>(static_cast<double>(c.d[i]) / norm);
  }
  return k;
}

/// The residuals of record i >= 1, by stream: gap, pose, descriptor, stored points.
struct Residuals {
  std::uint64_t gap = 0;
  CompactPoseResiduals pose;
  std::array<std::uint64_t, kKeyframeDescriptorDim> d{};
  std::uint64_t points = 0;
};

Residuals ResidualsOf(const std::vector<Codes>& c, std::size_t i) {
  Residuals r;
  r.gap = c[i].index - c[i - 1].index - 1;
  r.pose = CompactPoseResidualsOf(c[i >= 2 ? i - 2 : i - 1].pose, c[i - 1].pose, c[i].pose, i);
  for (std::size_t a = 0; a < kKeyframeDescriptorDim; ++a) {
    r.d[a] = ZigZag(static_cast<std::int64_t>(c[i].d[a]) - static_cast<std::int64_t>(c[i - 1].d[a]));
  }
  r.points = ZigZag(static_cast<std::int64_t>(c[i].points) - static_cast<std::int64_t>(c[i - 1].points));
  return r;
}

Status Corrupt(std::size_t record, const std::string& what) {
  return DataLoss("compact keyframe batch: record " + std::to_string(record) + ": " + what);
}

}  // namespace

Status EncodeCompactBatch(Span<const CompactKeyframe> keyframes, int descriptor_bits, std::vector<std::uint8_t>* out) {
  if (descriptor_bits < kCompactMinDescriptorBits || descriptor_bits > kCompactMaxDescriptorBits) {
    return InvalidArgument("compact keyframe batch: descriptor_bits " + std::to_string(descriptor_bits) +
                           " is outside 4..14");
  }
  if (keyframes.empty() || keyframes.size() > kMaxCompactBatchRecords) {
    return InvalidArgument("compact keyframe batch: " + std::to_string(keyframes.size()) +
                           " keyframes, expected 1..512");
  }
  std::vector<Codes> codes;
  codes.reserve(keyframes.size());
  for (std::size_t i = 0; i < keyframes.size(); ++i) {
    auto c = Quantise(keyframes[i], descriptor_bits, i == 0 ? nullptr : &codes.back().pose.q);
    if (!c.ok()) return c.status();
    if (i > 0 && c->index <= codes.back().index) {
      return InvalidArgument(Who(c->index) + "keyframe indices must ascend (after " +
                             std::to_string(codes.back().index) + ")");
    }
    codes.push_back(*c);
  }
  std::vector<Residuals> residuals;
  residuals.reserve(codes.size());
  for (std::size_t i = 1; i < codes.size(); ++i) residuals.push_back(ResidualsOf(codes, i));
  std::vector<std::uint64_t> gaps, t, q, d, points;
  for (const Residuals& r : residuals) {
    gaps.push_back(r.gap);
    points.push_back(r.points);
    t.insert(t.end(), r.pose.t.begin(), r.pose.t.end());
    q.insert(q.end(), r.pose.q.begin(), r.pose.q.end());
    d.insert(d.end(), r.d.begin(), r.d.end());
  }
  const int k_gap = BestExpGolombOrder(gaps), k_t = BestExpGolombOrder(t), k_q = BestExpGolombOrder(q), k_d = BestExpGolombOrder(d),
            k_points = BestExpGolombOrder(points);

  out->clear();
  out->push_back(static_cast<std::uint8_t>(descriptor_bits));
  BitWriter w(out);
  for (int k : {k_gap, k_t, k_q, k_d, k_points}) w.Put(static_cast<std::uint64_t>(k), kExpGolombOrderBits);
  const Codes& first = codes.front();
  w.PutExpGolomb(first.index, 0);
  PutCompactPoseWhole(first.pose, &w);
  for (std::uint32_t v : first.d) w.Put(v, descriptor_bits);
  w.PutExpGolomb(first.points, 0);
  for (const Residuals& r : residuals) {
    w.PutExpGolomb(r.gap, k_gap);
    PutCompactPoseResiduals(r.pose, k_t, k_q, &w);
    for (std::uint64_t v : r.d) w.PutExpGolomb(v, k_d);
    w.PutExpGolomb(r.points, k_points);
  }
  return Status::Ok();
}

Status DecodeCompactBatch(Span<const std::uint8_t> bytes, std::size_t num_records, std::vector<CompactKeyframe>* out) {
  if (num_records == 0 || num_records > kMaxCompactBatchRecords) {
    return DataLoss("compact keyframe batch: " + std::to_string(num_records) + " records, expected 1..512");
  }
  if (bytes.empty()) return DataLoss("compact keyframe batch: no bytes");
  const int bits = bytes[0];
  if (bits < kCompactMinDescriptorBits || bits > kCompactMaxDescriptorBits) {
    return DataLoss("compact keyframe batch: descriptor_bits " + std::to_string(bits) + " is outside 4..14");
  }
  const std::uint32_t levels = (1u << bits) - 1u;
  BitReader r(bytes.subspan(1, bytes.size() - 1));
  std::uint64_t order[5] = {};
  for (std::uint64_t& k : order) {
    if (!r.Get(kExpGolombOrderBits, &k)) return Corrupt(0, "the stream ends in its header");
  }
  out->resize(num_records);
  Codes before, last;
  for (std::size_t i = 0; i < num_records; ++i) {
    Codes c;
    std::uint64_t v = 0;
    const auto ended = [i] { return Corrupt(i, CompactStreamEnded()); };
    if (i == 0) {
      if (!r.GetExpGolomb(0, &v)) return ended();
      if (v > std::numeric_limits<std::uint32_t>::max()) return Corrupt(i, "keyframe index beyond 2^32 - 1");
      c.index = static_cast<std::uint32_t>(v);
    } else {
      if (!r.GetExpGolomb(static_cast<int>(order[0]), &v)) return ended();
      if (v >= std::numeric_limits<std::uint32_t>::max() - last.index) {
        return Corrupt(i, "keyframe index beyond 2^32 - 1");
      }
      c.index = last.index + 1 + static_cast<std::uint32_t>(v);
    }
    if (const std::string error = GetCompactPose(&r, i, static_cast<int>(order[1]), static_cast<int>(order[2]),
                                                 before.pose, last.pose, &c.pose);
        !error.empty()) {
      return Corrupt(i, error);
    }
    if (i == 0) {
      for (std::uint32_t& d : c.d) {
        if (!r.Get(bits, &v)) return ended();
        d = static_cast<std::uint32_t>(v);
      }
      if (!r.GetExpGolomb(0, &v)) return ended();
      if (v > kCompactMaxStoredPoints) return Corrupt(i, "stored point count beyond 2^31 - 1");
      c.points = static_cast<std::uint32_t>(v);
    } else {
      for (std::size_t a = 0; a < kKeyframeDescriptorDim; ++a) {
        if (!r.GetExpGolomb(static_cast<int>(order[3]), &v)) return ended();
        if (v > 2u * levels) return Corrupt(i, "descriptor difference beyond the code range");
        const std::int64_t d = static_cast<std::int64_t>(last.d[a]) + UnZigZag(v);
        if (d < 0 || d > static_cast<std::int64_t>(levels)) {
          return Corrupt(i, "descriptor code " + std::to_string(d) + " outside 0.." + std::to_string(levels));
        }
        c.d[a] = static_cast<std::uint32_t>(d);
      }
      if (!r.GetExpGolomb(static_cast<int>(order[4]), &v)) return ended();
      if (v > 2u * std::uint64_t{kCompactMaxStoredPoints}) return Corrupt(i, "stored point difference beyond 2^31");
      const std::int64_t points = static_cast<std::int64_t>(last.points) + UnZigZag(v);
      if (points < 0 || points > static_cast<std::int64_t>(kCompactMaxStoredPoints)) {
        return Corrupt(i, "stored point count " + std::to_string(points) + " outside 0..2^31 - 1");
      }
      c.points = static_cast<std::uint32_t>(points);
    }
    if (*std::max_element(c.d.begin(), c.d.end()) != levels) {
      return Corrupt(i, "the descriptor's largest code is not " + std::to_string(levels) + " (corrupt or all zero)");
    }
    (*out)[i] = Dequantise(c);
    before = i == 0 ? c : last;
    last = c;
  }
  if (!r.AtCleanEnd()) return Corrupt(num_records - 1, "bytes or set padding bits after the last record");
  return Status::Ok();
}

Result<CompactKeyframe> QuantiseCompactKeyframe(const CompactKeyframe& keyframe, int descriptor_bits) {
  if (descriptor_bits < kCompactMinDescriptorBits || descriptor_bits > kCompactMaxDescriptorBits) {
    return InvalidArgument("compact keyframe batch: descriptor_bits " + std::to_string(descriptor_bits) +
                           " is outside 4..14");
  }
  auto c = Quantise(keyframe, descriptor_bits, nullptr);
  if (!c.ok()) return c.status();
  return Dequantise(*c);
}

}  // namespace commerge
