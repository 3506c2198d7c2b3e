// SPDX-License-Identifier: BSD-3-Clause
// Compact keyframe batch (core/descriptor/compact_batch_codec.hpp): round trips of smooth and jumpy trajectories
// within the stated quantisation (1 mm grid, quaternion codes, b-bit descriptor against its derived angle bound),
// each decoded keyframe equal to its quantisation alone (what the robot's delivery digest uses), the size per
// keyframe, and refusals: bad arguments to the encoder, every cut, extra bytes, set padding, a wrong record count
// and flipped bits of the decoder (an error or a batch of valid records, never a crash).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <vector>

#include "core/descriptor/compact_batch_codec.hpp"
#include "tests/support/pose_errors.hpp"

namespace commerge {
namespace {

/// A ground robot's keyframes: 1 m steps, a slowly changing heading, descriptors drifting from one to the next,
/// stored scans of 1 500-3 500 points (every ninth keyframe without one).
std::vector<CompactKeyframe> Trajectory(std::size_t n, std::uint32_t first_index, std::uint32_t seed,
                                        double jump_m = 0.0) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<CompactKeyframe> out(n);
  double yaw = 0.3, x = 120.25, y = -47.5, z = 1.8;
  std::array<double, kKeyframeDescriptorDim> d{};
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = 0.2 + 0.8 * std::abs(std::sin(0.37 * static_cast<double>(i)));
  std::uint32_t index = first_index;
  for (std::size_t k = 0; k < n; ++k) {
    yaw += 0.05 * noise(rng);
    x += std::cos(yaw) + jump_m * noise(rng);
    y += std::sin(yaw) + jump_m * noise(rng);
    z += 0.01 * noise(rng);
    CompactKeyframe& f = out[k];
    f.pose.keyframe_index = index;
    index += 1 + (k % 7 == 3 ? 2u : 0u);  // a few keyframes without a descriptor in between
    f.pose.T_map_sensor = Eigen::Isometry3d::Identity();
    f.pose.T_map_sensor.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(0.02 * noise(rng), Eigen::Vector3d::UnitX()) *
                                    Eigen::AngleAxisd(0.02 * noise(rng), Eigen::Vector3d::UnitY()))
                                       .toRotationMatrix();
    f.pose.T_map_sensor.translation() = Eigen::Vector3d(x, y, z);
    double norm2 = 0.0;
    for (double& v : d) {
      v = std::max(0.0, v + 0.03 * noise(rng));
      norm2 += v * v;
    }
    if (norm2 == 0.0) d[0] = norm2 = 1.0;
    for (std::size_t i = 0; i < d.size(); ++i) f.descriptor[i] = static_cast<float>(d[i] / std::sqrt(norm2));
    f.stored_points = k % 9 == 5 ? 0u : 1500u + static_cast<std::uint32_t>(rng() % 2001u);
  }
  return out;
}

/// The angle between two descriptors [rad].
double DescriptorAngle(const std::array<float, kKeyframeDescriptorDim>& a,
                       const std::array<float, kKeyframeDescriptorDim>& b) {
  double dot = 0.0, na = 0.0, nb = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double x = static_cast<double>(a[i]), y = static_cast<double>(b[i]);
    dot += x * y;
    na += x * x;
    nb += y * y;
  }
  return std::acos(std::clamp(dot / std::sqrt(na * nb), -1.0, 1.0));
}

void CheckRoundTrip(const std::vector<CompactKeyframe>& in, int bits, double* bytes_per_keyframe) {
  std::vector<std::uint8_t> wire;
  REQUIRE(EncodeCompactBatch(Span<const CompactKeyframe>(in), bits, &wire).ok());
  std::vector<CompactKeyframe> out;
  const Status st = DecodeCompactBatch(Span<const std::uint8_t>(wire), in.size(), &out);
  REQUIRE_MESSAGE(st.ok(), st.ToString());
  REQUIRE(out.size() == in.size());
  const double levels = static_cast<double>((1 << bits) - 1);
  for (std::size_t i = 0; i < in.size(); ++i) {
    CAPTURE(i);
    CHECK(out[i].pose.keyframe_index == in[i].pose.keyframe_index);
    CHECK(out[i].stored_points == in[i].stored_points);
    const Eigen::Vector3d dt = out[i].pose.T_map_sensor.translation() - in[i].pose.T_map_sensor.translation();
    CHECK(dt.cwiseAbs().maxCoeff() <= 0.5e-3 + 1e-9);
    CHECK(test::RotationErrorRad(out[i].pose.T_map_sensor.linear(), in[i].pose.T_map_sensor.linear()) <= 1.3e-4);
    // Max-scaled codes move by at most 0.5 each: the angle is at most asin(max_j d_j sqrt(40) / (2 L)).
    const double max_value = static_cast<double>(*std::max_element(in[i].descriptor.begin(), in[i].descriptor.end()));
    const double bound = std::asin(std::min(1.0, max_value * std::sqrt(40.0) / (2.0 * levels)));
    CHECK(DescriptorAngle(out[i].descriptor, in[i].descriptor) <= bound + 1e-6);
    // The same as the keyframe quantised alone, bit for bit.
    auto alone = QuantiseCompactKeyframe(in[i], bits);
    REQUIRE(alone.ok());
    CHECK(std::equal(alone->descriptor.begin(), alone->descriptor.end(), out[i].descriptor.begin()));
    CHECK(alone->pose.T_map_sensor.matrix() == out[i].pose.T_map_sensor.matrix());
    CHECK(alone->stored_points == out[i].stored_points);
  }
  *bytes_per_keyframe = static_cast<double>(wire.size()) / static_cast<double>(in.size());
}

TEST_CASE("compact batch: round trips within the stated quantisation, each keyframe as if quantised alone") {
  for (int bits : {4, 6, 8, 10, 14}) {
    for (std::size_t n : {std::size_t{1}, std::size_t{2}, std::size_t{3}, std::size_t{64}, std::size_t{512}}) {
      CAPTURE(bits);
      CAPTURE(n);
      double smooth = 0.0, jumpy = 0.0;
      CheckRoundTrip(Trajectory(n, 1000, 7 + static_cast<std::uint32_t>(n)), bits, &smooth);
      CheckRoundTrip(Trajectory(n, 0, 11, 25.0), bits, &jumpy);
      if (n == 512) {
        // Far below the 92-byte record: a smooth path codes its poses in a few bytes, the descriptor in about
        // b - 3 bits per value at these steps.
        CHECK(smooth < 92.0 * (bits + 4) / 18.0);
        std::printf("compact batch of 512: %d descriptor bits, %.1f B per keyframe (smooth), %.1f (jumpy)\n", bits,
                    smooth, jumpy);
      }
    }
  }
}

TEST_CASE("compact batch: a quaternion near -q of its predecessor, positions near the grid's end and large index gaps") {
  std::vector<CompactKeyframe> in = Trajectory(5, 0, 3);
  in[2].pose.T_map_sensor.linear() = Eigen::AngleAxisd(3.14159, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  in[3].pose.T_map_sensor.linear() = Eigen::AngleAxisd(-3.14159, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  in[3].pose.T_map_sensor.translation() = Eigen::Vector3d(-8.7e9, 4e6, -2.5e3);  // near the grid's +-8.8e9 m
  in[4].pose.keyframe_index = 0xFFFFFFF0u;
  // Point counts jumping across their whole range.
  in[0].stored_points = kCompactMaxStoredPoints;
  in[1].stored_points = 0;
  in[2].stored_points = kCompactMaxStoredPoints;
  double unused = 0.0;
  CheckRoundTrip(in, 8, &unused);
  // The first keyframe, coded whole, at the grid's end.
  in[0].pose.T_map_sensor.translation() = Eigen::Vector3d(8.79e9, -8.79e9, 1.0);
  CheckRoundTrip(in, 8, &unused);
}

TEST_CASE("compact batch: the encoder refuses bad arguments naming them") {
  std::vector<CompactKeyframe> in = Trajectory(3, 10, 5);
  std::vector<std::uint8_t> wire;
  CHECK(EncodeCompactBatch(Span<const CompactKeyframe>(in), 3, &wire).message().find("descriptor_bits 3") !=
        std::string::npos);
  CHECK(EncodeCompactBatch(Span<const CompactKeyframe>(in), 15, &wire).code() == StatusCode::kInvalidArgument);
  CHECK(EncodeCompactBatch(Span<const CompactKeyframe>(), 8, &wire).code() == StatusCode::kInvalidArgument);
  std::vector<CompactKeyframe> bad = in;
  bad[2].pose.keyframe_index = bad[1].pose.keyframe_index;
  CHECK(EncodeCompactBatch(Span<const CompactKeyframe>(bad), 8, &wire).message().find("must ascend") !=
        std::string::npos);
  bad = in;
  bad[1].descriptor[4] = -0.5f;
  CHECK(EncodeCompactBatch(Span<const CompactKeyframe>(bad), 8, &wire).code() == StatusCode::kInvalidArgument);
  bad = in;
  bad[0].pose.T_map_sensor.translation().x() = std::nan("");
  CHECK(EncodeCompactBatch(Span<const CompactKeyframe>(bad), 8, &wire).code() == StatusCode::kInvalidArgument);
  bad = in;
  bad[0].pose.T_map_sensor.translation().x() = 1e10;
  CHECK(EncodeCompactBatch(Span<const CompactKeyframe>(bad), 8, &wire).message().find("8.8e9") != std::string::npos);
  bad = in;
  bad[1].stored_points = kCompactMaxStoredPoints + 1u;
  CHECK(EncodeCompactBatch(Span<const CompactKeyframe>(bad), 8, &wire).message().find("stored point count") !=
        std::string::npos);
  std::vector<CompactKeyframe> many(kMaxCompactBatchRecords + 1, in[0]);
  CHECK(EncodeCompactBatch(Span<const CompactKeyframe>(many), 8, &wire).code() == StatusCode::kInvalidArgument);
}

TEST_CASE("compact batch: cuts, extra bytes, set padding, a wrong count and flipped bits are refused or decode "
          "to valid keyframes") {
  const std::vector<CompactKeyframe> in = Trajectory(40, 77, 9);
  std::vector<std::uint8_t> wire;
  REQUIRE(EncodeCompactBatch(Span<const CompactKeyframe>(in), 6, &wire).ok());
  std::vector<CompactKeyframe> out;
  for (std::size_t cut = 0; cut < wire.size(); ++cut) {
    CAPTURE(cut);
    CHECK(DecodeCompactBatch(Span<const std::uint8_t>(wire.data(), cut), in.size(), &out).code() ==
          StatusCode::kDataLoss);
  }
  std::vector<std::uint8_t> longer = wire;
  longer.push_back(0);
  CHECK(DecodeCompactBatch(Span<const std::uint8_t>(longer), in.size(), &out).message().find("after the last") !=
        std::string::npos);
  CHECK(DecodeCompactBatch(Span<const std::uint8_t>(wire), in.size() - 1, &out).code() == StatusCode::kDataLoss);
  CHECK(DecodeCompactBatch(Span<const std::uint8_t>(wire), in.size() + 1, &out).code() == StatusCode::kDataLoss);
  CHECK(DecodeCompactBatch(Span<const std::uint8_t>(wire), 0, &out).code() == StatusCode::kDataLoss);
  CHECK(DecodeCompactBatch(Span<const std::uint8_t>(wire), kMaxCompactBatchRecords + 1, &out).code() ==
        StatusCode::kDataLoss);
  std::vector<std::uint8_t> bad_bits = wire;
  bad_bits[0] = 15;
  CHECK(DecodeCompactBatch(Span<const std::uint8_t>(bad_bits), in.size(), &out).message().find("descriptor_bits 15") !=
        std::string::npos);
  // Flipped bits: a clean error, or keyframes every decoder check accepts (ascending, unit descriptors).
  std::mt19937 rng(1);
  int refused = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    std::vector<std::uint8_t> flipped = wire;
    const int flips = 1 + trial % 4;
    for (int f = 0; f < flips; ++f) {
      const std::size_t bit = 8 + rng() % ((wire.size() - 1) * 8);  // not the header byte
      flipped[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    }
    const Status st = DecodeCompactBatch(Span<const std::uint8_t>(flipped), in.size(), &out);
    if (!st.ok()) {
      CHECK(st.code() == StatusCode::kDataLoss);
      CHECK(st.message().find("compact keyframe batch: record ") != std::string::npos);
      ++refused;
      continue;
    }
    for (std::size_t i = 0; i < out.size(); ++i) {
      if (i > 0) CHECK(out[i].pose.keyframe_index > out[i - 1].pose.keyframe_index);
      CHECK(out[i].pose.T_map_sensor.matrix().allFinite());
      CHECK(out[i].stored_points <= kCompactMaxStoredPoints);
      double norm2 = 0.0;
      for (float v : out[i].descriptor) norm2 += static_cast<double>(v) * static_cast<double>(v);
      CHECK(std::abs(norm2 - 1.0) < 1e-5);
    }
  }
  CHECK(refused > 1500);
}

}  // namespace
}  // namespace commerge
