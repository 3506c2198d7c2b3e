// SPDX-License-Identifier: BSD-3-Clause
#include "core/eval/mission_traffic.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/common/number_text.hpp"

namespace commerge {

namespace {

constexpr std::size_t kMinSamples = 16, kMaxSamples = 65536, kMaxTrafficRobots = 64;

double SafeInterval(double s) { return s > 0.0 && std::isfinite(s) ? s : 1.0; }

}  // namespace

const char* TrafficKindName(TrafficKind kind) noexcept {
  switch (kind) {
    case TrafficKind::kKeyframeRecords: return "keyframe_records";
    case TrafficKind::kPoseUpdates: return "pose_updates";
    case TrafficKind::kScans: return "scans";
    case TrafficKind::kResends: return "resends";
    case TrafficKind::kRobotStatus: return "robot_status";
  }
  return "invalid";
}

Status ValidateMissionTrafficParams(const MissionTrafficParams& params) {
  if (params.max_robots < 1 || params.max_robots > kMaxTrafficRobots) {
    return InvalidArgument("mission traffic: max_robots = " + std::to_string(params.max_robots) + " is outside 1.." +
                           std::to_string(kMaxTrafficRobots));
  }
  if (params.max_samples < kMinSamples || params.max_samples > kMaxSamples) {
    return InvalidArgument("mission traffic: max_samples = " + std::to_string(params.max_samples) +
                           " is outside " + std::to_string(kMinSamples) + ".." + std::to_string(kMaxSamples));
  }
  if (!(params.sample_interval_s > 0.0) || !std::isfinite(params.sample_interval_s)) {
    return InvalidArgument("mission traffic: sample_interval_s = " + FormatNumber(params.sample_interval_s, 6) +
                           " must be finite and > 0");
  }
  return Status::Ok();
}

MissionTraffic::MissionTraffic(const MissionTrafficParams& params)
    : max_robots_(std::clamp<std::size_t>(params.max_robots, 1, kMaxTrafficRobots)),
      max_samples_(std::clamp<std::size_t>(params.max_samples, kMinSamples, kMaxSamples) & ~std::size_t{1}),
      interval_s_(SafeInterval(params.sample_interval_s)),
      bytes_(max_robots_),
      first_s_(max_robots_, -1.0),
      last_s_(max_robots_, -1.0) {
  for (auto& b : bytes_) b.fill(0);
  times_s_.reserve(max_samples_);
  sample_bytes_.reserve(max_samples_ * max_robots_);
}

void MissionTraffic::Record(int robot, TrafficKind kind, std::uint64_t bytes, double time_s) noexcept {
  if (!std::isfinite(time_s)) time_s = std::max(last_time_s_, 0.0);
  time_s = std::max(time_s, last_time_s_);
  last_time_s_ = time_s;
  const auto k = static_cast<std::size_t>(kind);
  if (robot < 0 || static_cast<std::size_t>(robot) >= max_robots_ || k >= kTrafficKinds) {
    other_bytes_ += bytes;
    return;
  }
  const auto r = static_cast<std::size_t>(robot);
  bytes_[r][k] += bytes;
  if (kind != TrafficKind::kRobotStatus) {
    if (first_s_[r] < 0.0) first_s_[r] = time_s;
    last_s_[r] = time_s;
  }
  Sample(time_s);
}

void MissionTraffic::Sample(double time_s) {
  if (times_s_.empty() || time_s >= bucket_start_s_ + interval_s_) {
    if (times_s_.size() == max_samples_) {
      // Full: keep every other sample (the later of each pair, so each kept sample still ends its interval).
      const std::size_t half = max_samples_ / 2;
      for (std::size_t i = 0; i < half; ++i) {
        times_s_[i] = times_s_[2 * i + 1];
        std::copy_n(sample_bytes_.begin() + static_cast<std::ptrdiff_t>((2 * i + 1) * max_robots_), max_robots_,
                    sample_bytes_.begin() + static_cast<std::ptrdiff_t>(i * max_robots_));
      }
      times_s_.resize(half);
      sample_bytes_.resize(half * max_robots_);
      interval_s_ *= 2.0;
    }
    times_s_.push_back(time_s);
    sample_bytes_.resize(sample_bytes_.size() + max_robots_, 0);
    bucket_start_s_ = time_s;  // a sample's interval begins at its first message
  }
  times_s_.back() = time_s;
  std::uint64_t* row = sample_bytes_.data() + (times_s_.size() - 1) * max_robots_;
  for (std::size_t r = 0; r < max_robots_; ++r) row[r] = RobotTotal(static_cast<int>(r));
}

std::uint64_t MissionTraffic::Bytes(int robot, TrafficKind kind) const noexcept {
  const auto k = static_cast<std::size_t>(kind);
  if (robot < 0 || static_cast<std::size_t>(robot) >= max_robots_ || k >= kTrafficKinds) return 0;
  return bytes_[static_cast<std::size_t>(robot)][k];
}

std::uint64_t MissionTraffic::RobotTotal(int robot) const noexcept {
  std::uint64_t n = 0;
  for (std::size_t k = 0; k < kTrafficKinds; ++k) n += Bytes(robot, static_cast<TrafficKind>(k));
  return n;
}

std::uint64_t MissionTraffic::KindTotal(TrafficKind kind) const noexcept {
  std::uint64_t n = 0;
  for (std::size_t r = 0; r < max_robots_; ++r) n += Bytes(static_cast<int>(r), kind);
  return n;
}

std::uint64_t MissionTraffic::Total() const noexcept {
  std::uint64_t n = other_bytes_;
  for (std::size_t r = 0; r < max_robots_; ++r) n += RobotTotal(static_cast<int>(r));
  return n;
}

std::uint64_t MissionTraffic::ExchangedBytes() const noexcept {
  std::uint64_t n = 0;
  for (std::size_t r = 0; r < max_robots_; ++r) {
    n += RobotTotal(static_cast<int>(r)) - Bytes(static_cast<int>(r), TrafficKind::kRobotStatus);
  }
  return n;
}

double MissionTraffic::first_s(int robot) const noexcept {
  return robot >= 0 && static_cast<std::size_t>(robot) < max_robots_ ? first_s_[static_cast<std::size_t>(robot)] : -1.0;
}

double MissionTraffic::last_s(int robot) const noexcept {
  return robot >= 0 && static_cast<std::size_t>(robot) < max_robots_ ? last_s_[static_cast<std::size_t>(robot)] : -1.0;
}

double MissionTraffic::CommSeconds() const noexcept {
  double t = 0.0;
  for (std::size_t r = 0; r < max_robots_; ++r) {
    if (first_s_[r] >= 0.0) t += last_s_[r] - first_s_[r];
  }
  return t;
}

std::uint64_t MissionTraffic::sample_bytes(std::size_t i, int robot) const noexcept {
  if (i >= times_s_.size() || robot < 0 || static_cast<std::size_t>(robot) >= max_robots_) return 0;
  return sample_bytes_[i * max_robots_ + static_cast<std::size_t>(robot)];
}

}  // namespace commerge
