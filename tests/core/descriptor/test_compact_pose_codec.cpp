// SPDX-License-Identifier: BSD-3-Clause
// Compact pose list (core/descriptor/compact_pose_codec.hpp), the pose_update_t payload: round trips within the
// stated quantisation (1 mm grid, quaternion codes), each pose equal to its quantisation alone, indices in any
// order, the size of a corrected stretch against the 33 bytes of float32 arrays, the longest list within
// kMaxCompactPoseBytes, and refusals: bad arguments to the encoder; cuts, extra bytes, set padding, a wrong count
// and flipped bits of the decoder (an error or valid poses, never a crash).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include "core/descriptor/compact_pose_codec.hpp"
#include "tests/support/pose_errors.hpp"

namespace commerge {
namespace {

struct PoseList {
  std::vector<std::uint32_t> keyframes;
  std::vector<Eigen::Isometry3d> poses;
  std::vector<std::uint8_t> no_descriptor;
};

/// A loop closure's correction of keyframes first .. first + n - 1 (every `step`-th): a ground path of 1 m steps,
/// bent by a correction that grows along it (what a pose-graph optimisation does to a drifted stretch).
PoseList CorrectedStretch(std::size_t n, std::uint32_t first, std::uint32_t step, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  PoseList out;
  double yaw = 0.7, x = -350.125, y = 812.5, z = 3.25;
  for (std::size_t i = 0; i < n; ++i) {
    yaw += 0.04 * noise(rng);
    x += step * std::cos(yaw);
    y += step * std::sin(yaw);
    z += 0.01 * noise(rng);
    const double s = static_cast<double>(i) / static_cast<double>(n);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(yaw + 0.02 * s, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(0.01 * noise(rng), Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(x + 0.8 * s, y - 0.5 * s, z);
    out.keyframes.push_back(first + step * static_cast<std::uint32_t>(i));
    out.poses.push_back(T);
    out.no_descriptor.push_back(i % 11 == 4 ? 1 : 0);
  }
  return out;
}

std::vector<std::uint8_t> Encode(const PoseList& in) {
  std::vector<std::uint8_t> wire;
  const Status st = EncodeCompactPoses(Span<const std::uint32_t>(in.keyframes), Span<const Eigen::Isometry3d>(in.poses),
                                       Span<const std::uint8_t>(in.no_descriptor), &wire);
  REQUIRE_MESSAGE(st.ok(), st.ToString());
  return wire;
}

Status Decode(const std::vector<std::uint8_t>& wire, std::size_t n, PoseList* out) {
  return DecodeCompactPoses(Span<const std::uint8_t>(wire), n, &out->keyframes, &out->poses, &out->no_descriptor);
}

/// Round trip of `in`; returns bytes per pose.
double CheckRoundTrip(const PoseList& in) {
  const std::vector<std::uint8_t> wire = Encode(in);
  PoseList out;
  const Status st = Decode(wire, in.keyframes.size(), &out);
  REQUIRE_MESSAGE(st.ok(), st.ToString());
  CHECK(out.keyframes == in.keyframes);
  CHECK(out.no_descriptor == in.no_descriptor);
  REQUIRE(out.poses.size() == in.poses.size());
  for (std::size_t i = 0; i < in.poses.size(); ++i) {
    CAPTURE(i);
    const Eigen::Vector3d dt = out.poses[i].translation() - in.poses[i].translation();
    CHECK(dt.cwiseAbs().maxCoeff() <= 0.5 * kCompactTranslationStepM + 1e-9);
    CHECK(test::RotationErrorRad(out.poses[i].linear(), in.poses[i].linear()) <= 1.3e-4);
    // The pose quantised alone gives the same matrix bit for bit (q and -q give one rotation matrix exactly).
    auto alone = QuantiseCompactPose(in.poses[i], nullptr, "");
    REQUIRE(alone.ok());
    CHECK(DequantiseCompactPose(*alone).matrix() == out.poses[i].matrix());
  }
  return in.keyframes.empty() ? 0.0 : static_cast<double>(wire.size()) / static_cast<double>(in.keyframes.size());
}

TEST_CASE("compact pose list: round trips within the stated quantisation, and a corrected stretch codes in a few bytes") {
  for (std::size_t n : {std::size_t{1}, std::size_t{2}, std::size_t{3}, std::size_t{128}, std::size_t{4096}}) {
    CAPTURE(n);
    const double consecutive = CheckRoundTrip(CorrectedStretch(n, 500, 1, 3 + static_cast<std::uint32_t>(n)));
    const double sparse = CheckRoundTrip(CorrectedStretch(n, 7, 9, 5));
    if (n >= 128) {
      // 1 m steps on a 1 mm grid, headings that turn by 0.04 rad (1 sigma) a step: the linear prediction leaves
      // residuals of millimetres and a few hundred quaternion codes; the float32 arrays take 33 bytes a pose.
      CHECK(consecutive < 33.0 / 3.0);
      CHECK(sparse < 33.0 / 2.5);
      std::printf("compact pose list of %zu: %.1f B a pose (consecutive keyframes), %.1f (every 9th)\n", n,
                  consecutive, sparse);
    }
  }
  CHECK(CheckRoundTrip(PoseList{}) == 0.0);
}

TEST_CASE("compact pose list: indices in any order, half turns, the grid's end and the index range") {
  PoseList in = CorrectedStretch(6, 100, 1, 2);
  in.keyframes = {100, 3, 2147483647u, 0, 55, 54};
  in.poses[1].linear() = Eigen::AngleAxisd(3.14159, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  in.poses[2].linear() = Eigen::AngleAxisd(-3.14159, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  in.poses[3].translation() = Eigen::Vector3d(-8.79e9, 8.79e9, 0.0);
  in.poses[0].translation() = Eigen::Vector3d(8.79e9, -1.0, 2.0);
  CheckRoundTrip(in);
}

TEST_CASE("compact pose list: the encoder refuses bad arguments naming them") {
  const PoseList good = CorrectedStretch(4, 10, 1, 4);
  std::vector<std::uint8_t> wire;
  auto encode = [&wire](const PoseList& in) {
    return EncodeCompactPoses(Span<const std::uint32_t>(in.keyframes), Span<const Eigen::Isometry3d>(in.poses),
                              Span<const std::uint8_t>(in.no_descriptor), &wire);
  };
  PoseList bad = good;
  bad.poses.pop_back();
  CHECK(encode(bad).code() == StatusCode::kInvalidArgument);
  bad = good;
  bad.no_descriptor.pop_back();
  CHECK(encode(bad).code() == StatusCode::kInvalidArgument);
  bad = good;
  bad.no_descriptor.clear();  // no flags: all 0
  CHECK(encode(bad).ok());
  bad = good;
  bad.no_descriptor[2] = 2;
  CHECK(encode(bad).message().find("pose 2 (keyframe 12): no_descriptor = 2") != std::string::npos);
  bad = good;
  bad.keyframes[1] = 2147483648u;
  CHECK(encode(bad).message().find("keyframe index above 2^31 - 1") != std::string::npos);
  bad = good;
  bad.poses[3].translation().z() = std::nan("");
  CHECK(encode(bad).message().find("pose 3 (keyframe 13): the pose is not finite") != std::string::npos);
  bad = good;
  bad.poses[0].translation().x() = 1e10;
  CHECK(encode(bad).message().find("beyond +-8.8e9 m") != std::string::npos);
  const PoseList many = CorrectedStretch(kMaxCompactPoses + 1, 0, 1, 1);
  CHECK(encode(many).code() == StatusCode::kInvalidArgument);
}

TEST_CASE("compact pose list: the longest list the encoder can write fits kMaxCompactPoseBytes") {
  // Indices jumping across their range and poses across the grid: no prediction helps.
  std::mt19937_64 rng(17);
  PoseList in;
  for (std::size_t i = 0; i < kMaxCompactPoses; ++i) {
    in.keyframes.push_back(i % 2 == 0 ? 0u : 2147483647u);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    const double sign = i % 2 == 0 ? 1.0 : -1.0;
    T.translation() = Eigen::Vector3d(sign * 8.79e9, -sign * 8.79e9, sign * 8.79e9);
    T.linear() = Eigen::AngleAxisd(static_cast<double>(rng() % 6283) * 1e-3,
                                   Eigen::Vector3d(1.0, static_cast<double>(rng() % 7), -2.0).normalized())
                     .toRotationMatrix();
    in.poses.push_back(T);
    in.no_descriptor.push_back(1);
  }
  const std::vector<std::uint8_t> wire = Encode(in);
  std::printf("the longest compact pose list: %zu B, %.1f B a pose (limit %zu)\n", wire.size(),
              static_cast<double>(wire.size()) / static_cast<double>(kMaxCompactPoses), kMaxCompactPoseBytes);
  CHECK(wire.size() <= kMaxCompactPoseBytes);
  CHECK(wire.size() > kMaxCompactPoseBytes / 2);  // it is long: the bound is not loose by orders of magnitude
  PoseList out;
  CHECK(Decode(wire, in.keyframes.size(), &out).ok());
}

TEST_CASE("compact pose list: cuts, extra bytes, set padding, a wrong count and flipped bits are refused or decode "
          "to valid poses") {
  const PoseList in = CorrectedStretch(40, 77, 1, 9);
  const std::vector<std::uint8_t> wire = Encode(in);
  PoseList out;
  for (std::size_t cut = 0; cut < wire.size(); ++cut) {
    CAPTURE(cut);
    std::vector<std::uint8_t> shorter(wire.begin(), wire.begin() + static_cast<std::ptrdiff_t>(cut));
    CHECK(Decode(shorter, in.keyframes.size(), &out).code() == StatusCode::kDataLoss);
  }
  std::vector<std::uint8_t> longer = wire;
  longer.push_back(0);
  CHECK(Decode(longer, in.keyframes.size(), &out).message().find("after the last pose") != std::string::npos);
  CHECK(Decode(wire, in.keyframes.size() - 1, &out).code() == StatusCode::kDataLoss);
  CHECK(Decode(wire, in.keyframes.size() + 1, &out).code() == StatusCode::kDataLoss);
  CHECK(Decode(wire, 0, &out).message().find("bytes for no pose") != std::string::npos);
  CHECK(Decode(wire, kMaxCompactPoses + 1, &out).code() == StatusCode::kDataLoss);
  CHECK(Decode(std::vector<std::uint8_t>(kMaxCompactPoseBytes + 1, 0xff), 10, &out).code() == StatusCode::kDataLoss);
  std::mt19937 rng(1);
  int refused = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    std::vector<std::uint8_t> flipped = wire;
    const int flips = 1 + trial % 4;
    for (int f = 0; f < flips; ++f) {
      const std::size_t bit = rng() % (wire.size() * 8);
      flipped[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    }
    const Status st = Decode(flipped, in.keyframes.size(), &out);
    if (!st.ok()) {
      CHECK(st.code() == StatusCode::kDataLoss);
      CHECK(st.message().find("compact pose list: pose ") != std::string::npos);
      ++refused;
      continue;
    }
    REQUIRE(out.poses.size() == in.poses.size());
    for (std::size_t i = 0; i < out.poses.size(); ++i) {
      CHECK(out.keyframes[i] <= 2147483647u);
      CHECK(out.no_descriptor[i] <= 1);
      CHECK(out.poses[i].matrix().allFinite());
      CHECK(std::abs(out.poses[i].linear().determinant() - 1.0) < 1e-9);
    }
  }
  CHECK(refused > 1000);
}

}  // namespace
}  // namespace commerge
