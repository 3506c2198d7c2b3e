// SPDX-License-Identifier: BSD-3-Clause
#include "core/descriptor/compact_batch_codec.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace commerge {
namespace {

constexpr std::int64_t kMaxGridValue = std::int64_t{1} << 43;  // 8.8e9 m at 1 mm
constexpr int kMaxExpGolombZeros = 48;                         // leading zeros of one code at most
constexpr int kOrderBits = 4;                                  // each k in the stream header
constexpr int kMaxOrder = (1 << kOrderBits) - 1;
constexpr int kQuaternionCodeBits = 16;

std::uint64_t ZigZag(std::int64_t s) noexcept {
  return s >= 0 ? static_cast<std::uint64_t>(s) << 1 : (static_cast<std::uint64_t>(-(s + 1)) << 1) | 1u;
}
std::int64_t UnZigZag(std::uint64_t v) noexcept {
  return (v & 1u) ? -static_cast<std::int64_t>(v >> 1) - 1 : static_cast<std::int64_t>(v >> 1);
}

int BitLength(std::uint64_t u) noexcept {
  int n = 0;
  while (u != 0) {
    ++n;
    u >>= 1;
  }
  return n;
}

/// Bits of EG(k) for v.
int ExpGolombBits(std::uint64_t v, int k) noexcept { return 2 * BitLength((v >> k) + 1) - 1 + k; }

class BitWriter {
 public:
  explicit BitWriter(std::vector<std::uint8_t>* out) : out_(out) {}
  void Put(std::uint64_t value, int bits) {
    for (int b = 0; b < bits; ++b, ++bit_) {
      if (bit_ % 8 == 0) out_->push_back(0);
      if ((value >> b) & 1u) out_->back() |= static_cast<std::uint8_t>(1u << (bit_ % 8));
    }
  }
  void PutExpGolomb(std::uint64_t v, int k) {
    const std::uint64_t u = (v >> k) + 1;
    const int n = BitLength(u);
    Put(0, n - 1);
    for (int b = n - 1; b >= 0; --b) Put((u >> b) & 1u, 1);
    Put(v & ((std::uint64_t{1} << k) - 1), k);
  }

 private:
  std::vector<std::uint8_t>* out_;
  std::size_t bit_ = 0;
};

class BitReader {
 public:
  explicit BitReader(Span<const std::uint8_t> bytes) : bytes_(bytes) {}
  bool Get(int bits, std::uint64_t* value) {
    if (bits > 0 && bit_ + static_cast<std::size_t>(bits) > bytes_.size() * 8) return false;
    std::uint64_t v = 0;
    for (int b = 0; b < bits; ++b, ++bit_) v |= static_cast<std::uint64_t>((bytes_[bit_ / 8] >> (bit_ % 8)) & 1u) << b;
    *value = v;
    return true;
  }
  bool GetExpGolomb(int k, std::uint64_t* value) {
    int zeros = 0;
    std::uint64_t bit = 0;
    while (true) {
      if (!Get(1, &bit)) return false;
      if (bit != 0) break;
      if (++zeros > kMaxExpGolombZeros) return false;
    }
    std::uint64_t u = 1;
    for (int i = 0; i < zeros; ++i) {
      if (!Get(1, &bit)) return false;
      u = (u << 1) | bit;
    }
    std::uint64_t low = 0;
    if (!Get(k, &low)) return false;
    *value = ((u - 1) << k) | low;
    return true;
  }
  /// Every byte read and the padding bits of the last one zero.
  bool AtCleanEnd() const {
    if ((bit_ + 7) / 8 != bytes_.size()) return false;
    return bit_ % 8 == 0 || (bytes_[bit_ / 8] >> (bit_ % 8)) == 0;
  }

 private:
  Span<const std::uint8_t> bytes_;
  std::size_t bit_ = 0;
};

/// The integers a keyframe is coded as (its quantisation).
struct Codes {
  std::uint32_t index = 0;
  std::array<std::int64_t, 3> t{};
  std::array<std::int64_t, 4> q{};
  std::array<std::uint32_t, kKeyframeDescriptorDim> d{};
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
  const Eigen::Vector3d t = k.pose.T_map_sensor.translation();
  for (int i = 0; i < 3; ++i) {
    const double grid = std::round(t[i] / kCompactTranslationStepM);
    if (!(std::fabs(grid) < static_cast<double>(kMaxGridValue))) {
      return InvalidArgument(Who(c.index) + "translation " + std::to_string(t[i]) + " m is beyond +-8.8e9 m");
    }
    c.t[static_cast<std::size_t>(i)] = static_cast<std::int64_t>(grid);
  }
  Eigen::Quaterniond q(k.pose.T_map_sensor.linear());
  q.normalize();
  const double comp[4] = {q.w(), q.x(), q.y(), q.z()};
  double dot = 0.0;
  for (int i = 0; i < 4; ++i) {
    dot += previous_q == nullptr ? (i == 0 ? comp[0] : 0.0) : comp[i] * static_cast<double>((*previous_q)[i]);
  }
  const double sign = dot < 0.0 ? -1.0 : 1.0;
  for (int i = 0; i < 4; ++i) {
    c.q[static_cast<std::size_t>(i)] = std::lround(std::clamp(sign * comp[i], -1.0, 1.0) * kCompactQuaternionScale);
  }
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
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i) t[i] = static_cast<double>(c.t[static_cast<std::size_t>(i)]) * kCompactTranslationStepM;
  Eigen::Quaterniond q(static_cast<double>(c.q[0]), static_cast<double>(c.q[1]), static_cast<double>(c.q[2]),
                       static_cast<double>(c.q[3]));
  q.normalize();
  k.pose.T_map_sensor = Eigen::Isometry3d::Identity();
  k.pose.T_map_sensor.linear() = q.toRotationMatrix();
  k.pose.T_map_sensor.translation() = t;
  double norm2 = 0.0;
  for (std::uint32_t v : c.d) norm2 += static_cast<double>(v) * static_cast<double>(v);
  const double norm = std::sqrt(norm2);
  for (std::size_t i = 0; i < kKeyframeDescriptorDim; ++i) {
    k.descriptor[i] = static_cast<float>(static_cast<double>(c.d[i]) / norm);
  }
  return k;
}

std::int64_t Predict(std::int64_t before_last, std::int64_t last, std::size_t i) {
  return i >= 2 ? 2 * last - before_last : last;
}

/// The residuals of record i >= 1, by stream: gap, translation, rotation, descriptor.
struct Residuals {
  std::uint64_t gap = 0;
  std::array<std::uint64_t, 3> t{};
  std::array<std::uint64_t, 4> q{};
  std::array<std::uint64_t, kKeyframeDescriptorDim> d{};
};

Residuals ResidualsOf(const std::vector<Codes>& c, std::size_t i) {
  Residuals r;
  r.gap = c[i].index - c[i - 1].index - 1;
  const Codes& before = c[i >= 2 ? i - 2 : i - 1];
  for (std::size_t a = 0; a < 3; ++a) r.t[a] = ZigZag(c[i].t[a] - Predict(before.t[a], c[i - 1].t[a], i));
  for (std::size_t a = 0; a < 4; ++a) r.q[a] = ZigZag(c[i].q[a] - Predict(before.q[a], c[i - 1].q[a], i));
  for (std::size_t a = 0; a < kKeyframeDescriptorDim; ++a) {
    r.d[a] = ZigZag(static_cast<std::int64_t>(c[i].d[a]) - static_cast<std::int64_t>(c[i - 1].d[a]));
  }
  return r;
}

/// The order 0..15 that codes `values` in the fewest bits.
template <typename Container>
int BestOrder(const Container& values) {
  int best = 0;
  std::uint64_t best_bits = std::numeric_limits<std::uint64_t>::max();
  for (int k = 0; k <= kMaxOrder; ++k) {
    std::uint64_t bits = 0;
    for (std::uint64_t v : values) bits += static_cast<std::uint64_t>(ExpGolombBits(v, k));
    if (bits < best_bits) {
      best_bits = bits;
      best = k;
    }
  }
  return best;
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
    auto c = Quantise(keyframes[i], descriptor_bits, i == 0 ? nullptr : &codes.back().q);
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
  std::vector<std::uint64_t> gaps, t, q, d;
  for (const Residuals& r : residuals) {
    gaps.push_back(r.gap);
    t.insert(t.end(), r.t.begin(), r.t.end());
    q.insert(q.end(), r.q.begin(), r.q.end());
    d.insert(d.end(), r.d.begin(), r.d.end());
  }
  const int k_gap = BestOrder(gaps), k_t = BestOrder(t), k_q = BestOrder(q), k_d = BestOrder(d);

  out->clear();
  out->push_back(static_cast<std::uint8_t>(descriptor_bits));
  BitWriter w(out);
  for (int k : {k_gap, k_t, k_q, k_d}) w.Put(static_cast<std::uint64_t>(k), kOrderBits);
  const Codes& first = codes.front();
  w.PutExpGolomb(first.index, 0);
  for (std::int64_t v : first.t) w.PutExpGolomb(ZigZag(v), 0);
  for (std::int64_t v : first.q) w.Put(static_cast<std::uint64_t>(v) & 0xFFFFu, kQuaternionCodeBits);
  for (std::uint32_t v : first.d) w.Put(v, descriptor_bits);
  for (const Residuals& r : residuals) {
    w.PutExpGolomb(r.gap, k_gap);
    for (std::uint64_t v : r.t) w.PutExpGolomb(v, k_t);
    for (std::uint64_t v : r.q) w.PutExpGolomb(v, k_q);
    for (std::uint64_t v : r.d) w.PutExpGolomb(v, k_d);
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
  std::uint64_t order[4] = {};
  for (std::uint64_t& k : order) {
    if (!r.Get(kOrderBits, &k)) return Corrupt(0, "the stream ends in its header");
  }
  out->resize(num_records);
  Codes before, last;
  for (std::size_t i = 0; i < num_records; ++i) {
    Codes c;
    std::uint64_t v = 0;
    const auto ended = [i] {
      return Corrupt(i, "the stream ends early, or an Exp-Golomb code has more than 48 leading zeros");
    };
    if (i == 0) {
      if (!r.GetExpGolomb(0, &v)) return ended();
      if (v > std::numeric_limits<std::uint32_t>::max()) return Corrupt(i, "keyframe index beyond 2^32 - 1");
      c.index = static_cast<std::uint32_t>(v);
      for (std::int64_t& t : c.t) {
        if (!r.GetExpGolomb(0, &v)) return ended();
        t = UnZigZag(v);
      }
      for (std::int64_t& q : c.q) {
        if (!r.Get(kQuaternionCodeBits, &v)) return ended();
        q = static_cast<std::int16_t>(static_cast<std::uint16_t>(v));
      }
      for (std::uint32_t& d : c.d) {
        if (!r.Get(bits, &v)) return ended();
        d = static_cast<std::uint32_t>(v);
      }
    } else {
      if (!r.GetExpGolomb(static_cast<int>(order[0]), &v)) return ended();
      if (v >= std::numeric_limits<std::uint32_t>::max() - last.index) {
        return Corrupt(i, "keyframe index beyond 2^32 - 1");
      }
      c.index = last.index + 1 + static_cast<std::uint32_t>(v);
      for (std::size_t a = 0; a < 3; ++a) {
        if (!r.GetExpGolomb(static_cast<int>(order[1]), &v)) return ended();
        if (v >= (std::uint64_t{1} << 46)) return Corrupt(i, "translation residual beyond the grid");
        c.t[a] = Predict(before.t[a], last.t[a], i) + UnZigZag(v);
      }
      for (std::size_t a = 0; a < 4; ++a) {
        if (!r.GetExpGolomb(static_cast<int>(order[2]), &v)) return ended();
        if (v >= (std::uint64_t{1} << 20)) return Corrupt(i, "quaternion residual beyond the code range");
        c.q[a] = Predict(before.q[a], last.q[a], i) + UnZigZag(v);
      }
      for (std::size_t a = 0; a < kKeyframeDescriptorDim; ++a) {
        if (!r.GetExpGolomb(static_cast<int>(order[3]), &v)) return ended();
        if (v > 2u * levels) return Corrupt(i, "descriptor difference beyond the code range");
        const std::int64_t d = static_cast<std::int64_t>(last.d[a]) + UnZigZag(v);
        if (d < 0 || d > static_cast<std::int64_t>(levels)) {
          return Corrupt(i, "descriptor code " + std::to_string(d) + " outside 0.." + std::to_string(levels));
        }
        c.d[a] = static_cast<std::uint32_t>(d);
      }
    }
    for (std::int64_t t : c.t) {
      if (t <= -kMaxGridValue || t >= kMaxGridValue) return Corrupt(i, "translation beyond +-8.8e9 m");
    }
    bool any = false;
    for (std::int64_t q : c.q) {
      if (q < -kCompactQuaternionScale || q > kCompactQuaternionScale) {
        return Corrupt(i, "quaternion code " + std::to_string(q) + " outside +-32767");
      }
      any = any || q != 0;
    }
    if (!any) return Corrupt(i, "all-zero quaternion");
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
