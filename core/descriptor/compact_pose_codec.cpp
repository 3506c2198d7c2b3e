// SPDX-License-Identifier: BSD-3-Clause
#include "core/descriptor/compact_pose_codec.hpp"

#include <algorithm>
#include <cmath>

namespace commerge {
namespace {

constexpr std::uint32_t kMaxPoseIndex = 2147483647u;
// The shortest codes: the first pose's index, 3 grid values, 4 x 16 bits and its flag; a later pose's 8 EG codes
// of 1 bit and its flag.
constexpr std::size_t kMinFirstPoseBits = 1 + 3 + 4 * kCompactQuaternionCodeBits + 1;
constexpr std::size_t kMinPoseBits = 1 + 3 + 4 + 1;

std::string PoseWho(std::size_t i, std::uint32_t keyframe) {
  return "compact pose list: pose " + std::to_string(i) + " (keyframe " + std::to_string(keyframe) + "): ";
}

Status CorruptPose(std::size_t pose, const std::string& what) {
  return DataLoss("compact pose list: pose " + std::to_string(pose) + ": " + what);
}

}  // namespace

Result<CompactPoseCodes> QuantiseCompactPose(const Eigen::Isometry3d& T, const std::array<std::int64_t, 4>* previous_q,
                                             const std::string& who) {
  if (!T.matrix().allFinite()) return InvalidArgument(who + "the pose is not finite");
  CompactPoseCodes c;
  const Eigen::Vector3d t = T.translation();
  for (int i = 0; i < 3; ++i) {
    const double grid = std::round(t[i] / kCompactTranslationStepM);
    if (!(std::fabs(grid) < static_cast<double>(kCompactMaxGridValue))) {
      return InvalidArgument(who + "translation " + std::to_string(t[i]) + " m is beyond +-8.8e9 m");
    }
    c.t[static_cast<std::size_t>(i)] = static_cast<std::int64_t>(grid);
  }
  Eigen::Quaterniond q(T.linear());
  if (!(q.norm() > 0.0)) return InvalidArgument(who + "the rotation has no quaternion");
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
  return c;
}

Eigen::Isometry3d DequantiseCompactPose(const CompactPoseCodes& c) {
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i) t[i] = static_cast<double>(c.t[static_cast<std::size_t>(i)]) * kCompactTranslationStepM;
  Eigen::Quaterniond q(static_cast<double>(c.q[0]), static_cast<double>(c.q[1]), static_cast<double>(c.q[2]),
                       static_cast<double>(c.q[3]));
  q.normalize();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = t;
  return T;
}

std::string CompactPoseCodesError(const CompactPoseCodes& c) {
  for (std::int64_t t : c.t) {
    if (t <= -kCompactMaxGridValue || t >= kCompactMaxGridValue) return "translation beyond +-8.8e9 m";
  }
  bool any = false;
  for (std::int64_t q : c.q) {
    if (q < -kCompactQuaternionScale || q > kCompactQuaternionScale) {
      return "quaternion code " + std::to_string(q) + " outside +-32767";
    }
    any = any || q != 0;
  }
  return any ? std::string() : std::string("all-zero quaternion");
}

CompactPoseResiduals CompactPoseResidualsOf(const CompactPoseCodes& before, const CompactPoseCodes& last,
                                            const CompactPoseCodes& codes, std::size_t i) {
  CompactPoseResiduals r;
  for (std::size_t a = 0; a < 3; ++a) r.t[a] = ZigZag(codes.t[a] - PredictCompact(before.t[a], last.t[a], i));
  for (std::size_t a = 0; a < 4; ++a) r.q[a] = ZigZag(codes.q[a] - PredictCompact(before.q[a], last.q[a], i));
  return r;
}

void PutCompactPoseWhole(const CompactPoseCodes& codes, BitWriter* w) {
  for (std::int64_t v : codes.t) w->PutExpGolomb(ZigZag(v), 0);
  for (std::int64_t v : codes.q) w->Put(static_cast<std::uint64_t>(v) & 0xFFFFu, kCompactQuaternionCodeBits);
}

void PutCompactPoseResiduals(const CompactPoseResiduals& r, int k_translation, int k_rotation, BitWriter* w) {
  for (std::uint64_t v : r.t) w->PutExpGolomb(v, k_translation);
  for (std::uint64_t v : r.q) w->PutExpGolomb(v, k_rotation);
}

std::string GetCompactPose(BitReader* r, std::size_t i, int k_translation, int k_rotation,
                           const CompactPoseCodes& before, const CompactPoseCodes& last, CompactPoseCodes* codes) {
  std::uint64_t v = 0;
  for (std::size_t a = 0; a < 3; ++a) {
    if (!r->GetExpGolomb(i == 0 ? 0 : k_translation, &v)) return CompactStreamEnded();
    if (v >= (std::uint64_t{1} << 47)) return "translation residual beyond the grid";
    codes->t[a] = (i == 0 ? 0 : PredictCompact(before.t[a], last.t[a], i)) + UnZigZag(v);
  }
  for (std::size_t a = 0; a < 4; ++a) {
    if (i == 0) {
      if (!r->Get(kCompactQuaternionCodeBits, &v)) return CompactStreamEnded();
      codes->q[a] = static_cast<std::int16_t>(static_cast<std::uint16_t>(v));
      continue;
    }
    if (!r->GetExpGolomb(k_rotation, &v)) return CompactStreamEnded();
    if (v >= (std::uint64_t{1} << 20)) return "quaternion residual beyond the code range";
    codes->q[a] = PredictCompact(before.q[a], last.q[a], i) + UnZigZag(v);
  }
  return CompactPoseCodesError(*codes);
}

Status EncodeCompactPoses(Span<const std::uint32_t> keyframes, Span<const Eigen::Isometry3d> poses,
                          Span<const std::uint8_t> no_descriptor, std::vector<std::uint8_t>* out) {
  const std::size_t n = keyframes.size();
  if (poses.size() != n || (!no_descriptor.empty() && no_descriptor.size() != n) || n > kMaxCompactPoses) {
    return InvalidArgument("compact pose list: " + std::to_string(n) + " keyframes, " + std::to_string(poses.size()) +
                           " poses and " + std::to_string(no_descriptor.size()) +
                           " no_descriptor flags (equal or no flags, at most " + std::to_string(kMaxCompactPoses) +
                           ")");
  }
  out->clear();
  if (n == 0) return Status::Ok();
  std::vector<CompactPoseCodes> codes;
  codes.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::string who = PoseWho(i, keyframes[i]);
    if (keyframes[i] > kMaxPoseIndex) return InvalidArgument(who + "keyframe index above 2^31 - 1");
    if (!no_descriptor.empty() && no_descriptor[i] > 1) {
      return InvalidArgument(who + "no_descriptor = " + std::to_string(no_descriptor[i]) + " is not 0 or 1");
    }
    auto c = QuantiseCompactPose(poses[i], i == 0 ? nullptr : &codes.back().q, who);
    if (!c.ok()) return c.status();
    codes.push_back(*c);
  }
  std::vector<std::uint64_t> gaps, t, q;
  std::vector<CompactPoseResiduals> residuals;
  gaps.reserve(n);
  t.reserve(3 * n);
  q.reserve(4 * n);
  residuals.reserve(n);
  for (std::size_t i = 1; i < n; ++i) {
    gaps.push_back(ZigZag(static_cast<std::int64_t>(keyframes[i]) - static_cast<std::int64_t>(keyframes[i - 1]) - 1));
    residuals.push_back(CompactPoseResidualsOf(codes[i >= 2 ? i - 2 : i - 1], codes[i - 1], codes[i], i));
    t.insert(t.end(), residuals.back().t.begin(), residuals.back().t.end());
    q.insert(q.end(), residuals.back().q.begin(), residuals.back().q.end());
  }
  const int k_gap = BestExpGolombOrder(gaps), k_t = BestExpGolombOrder(t), k_q = BestExpGolombOrder(q);
  BitWriter w(out);
  for (int k : {k_gap, k_t, k_q}) w.Put(static_cast<std::uint64_t>(k), kExpGolombOrderBits);
  for (std::size_t i = 0; i < n; ++i) {
    if (i == 0) {
      w.PutExpGolomb(keyframes[0], 0);
      PutCompactPoseWhole(codes[0], &w);
    } else {
      w.PutExpGolomb(gaps[i - 1], k_gap);
      PutCompactPoseResiduals(residuals[i - 1], k_t, k_q, &w);
    }
    w.Put(no_descriptor.empty() ? 0u : no_descriptor[i], 1);
  }
  return Status::Ok();
}

Status DecodeCompactPoses(Span<const std::uint8_t> bytes, std::size_t num_poses, std::vector<std::uint32_t>* keyframes,
                          std::vector<Eigen::Isometry3d>* poses, std::vector<std::uint8_t>* no_descriptor) {
  if (num_poses > kMaxCompactPoses) {
    return DataLoss("compact pose list: " + std::to_string(num_poses) + " poses, at most " +
                    std::to_string(kMaxCompactPoses));
  }
  keyframes->clear();
  poses->clear();
  no_descriptor->clear();
  if (num_poses == 0) {
    if (!bytes.empty()) return DataLoss("compact pose list: bytes for no pose");
    return Status::Ok();
  }
  if (bytes.size() > kMaxCompactPoseBytes) {
    return DataLoss("compact pose list: " + std::to_string(bytes.size()) + " bytes, at most " +
                    std::to_string(kMaxCompactPoseBytes));
  }
  // Each pose takes at least 9 bits (the first one 69): a count the bytes cannot hold is refused before the
  // outputs are sized for it.
  const std::size_t min_bits = 3 * kExpGolombOrderBits + kMinFirstPoseBits + kMinPoseBits * (num_poses - 1);
  if (bytes.size() * 8 < min_bits) {
    return DataLoss("compact pose list: " + std::to_string(bytes.size()) + " bytes cannot hold " +
                    std::to_string(num_poses) + " poses");
  }
  BitReader r(bytes);
  std::uint64_t order[3] = {};
  for (std::uint64_t& k : order) {
    if (!r.Get(kExpGolombOrderBits, &k)) return CorruptPose(0, "the stream ends in its header");
  }
  keyframes->resize(num_poses);
  poses->resize(num_poses);
  no_descriptor->resize(num_poses);
  CompactPoseCodes before, last;
  std::int64_t last_index = 0;
  for (std::size_t i = 0; i < num_poses; ++i) {
    const auto ended = [i] { return CorruptPose(i, CompactStreamEnded()); };
    CompactPoseCodes c;
    std::uint64_t v = 0;
    std::int64_t index = 0;
    if (i == 0) {
      if (!r.GetExpGolomb(0, &v)) return ended();
      if (v > kMaxPoseIndex) return CorruptPose(i, "keyframe index beyond 2^31 - 1");
      index = static_cast<std::int64_t>(v);
    } else {
      if (!r.GetExpGolomb(static_cast<int>(order[0]), &v)) return ended();
      if (v >= (std::uint64_t{1} << 34)) return CorruptPose(i, "keyframe index step beyond 2^33");
      index = last_index + 1 + UnZigZag(v);
      if (index < 0 || index > static_cast<std::int64_t>(kMaxPoseIndex)) {
        return CorruptPose(i, "keyframe index " + std::to_string(index) + " outside 0..2^31 - 1");
      }
    }
    if (const std::string error =
            GetCompactPose(&r, i, static_cast<int>(order[1]), static_cast<int>(order[2]), before, last, &c);
        !error.empty()) {
      return CorruptPose(i, error);
    }
    if (!r.Get(1, &v)) return ended();
    (*keyframes)[i] = static_cast<std::uint32_t>(index);
    (*poses)[i] = DequantiseCompactPose(c);
    (*no_descriptor)[i] = static_cast<std::uint8_t>(v);
    before = i == 0 ? c : last;
    last = c;
    last_index = index;
  }
  if (!r.AtCleanEnd()) return CorruptPose(num_poses - 1, "bytes or set padding bits after the last pose");
  return Status::Ok();
}

}  // namespace commerge
