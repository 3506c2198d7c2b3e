// SPDX-License-Identifier: BSD-3-Clause
// ScanOdometrySync: the scan pool, the odometry ring, and the rules that pair them (see the header).
#include "core/agent/scan_odometry_sync.hpp"

#include <cmath>
#include <string>

#include "core/geometry/se3.hpp"

namespace commerge {

namespace {

// The rotation of a sample may be off orthonormal by what a unit quaternion off 1 by 1e-3 gives (the LCM
// decoder's tolerance) or what poses printed with a few digits give; it is renormalised.
constexpr double kRigidTolerance = 1e-3;

// Translation linear, rotation by slerp; Eigen's slerp takes the shorter arc (it flips q_b's sign when
// q_a . q_b < 0).
Eigen::Isometry3d Interpolate(const Eigen::Quaterniond& q_a, const Eigen::Vector3d& t_a, const Eigen::Quaterniond& q_b,
                              const Eigen::Vector3d& t_b, double fraction) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q_a.slerp(fraction, q_b).normalized().toRotationMatrix();
  T.translation() = (1.0 - fraction) * t_a + fraction * t_b;
  return T;
}

}  // namespace

Status ValidateScanOdometrySyncParams(const ScanOdometrySyncParams& p) {
  if (p.max_pending_scans < 1 || p.max_pending_scans > 1024) {
    return InvalidArgument("scan/odometry sync: max_pending_scans = " + std::to_string(p.max_pending_scans) +
                           " is outside 1..1024");
  }
  if (p.odometry_history < 2 || p.odometry_history > (std::size_t{1} << 20)) {
    return InvalidArgument("scan/odometry sync: odometry_history = " + std::to_string(p.odometry_history) +
                           " is outside 2..1048576");
  }
  if (p.max_points_per_scan < 1 || p.max_points_per_scan > kMaxLidarScanPoints) {
    return InvalidArgument("scan/odometry sync: max_points_per_scan = " + std::to_string(p.max_points_per_scan) +
                           " is outside 1.." + std::to_string(kMaxLidarScanPoints));
  }
  if (!(p.max_odometry_gap_s > 0.0 && p.max_odometry_gap_s <= 3600.0)) {
    return InvalidArgument("scan/odometry sync: max_odometry_gap_s = " + std::to_string(p.max_odometry_gap_s) +
                           " is outside (0, 3600]");
  }
  if (!(p.max_speed_mps > 0.0 && std::isfinite(p.max_speed_mps))) {
    return InvalidArgument("scan/odometry sync: max_speed_mps = " + std::to_string(p.max_speed_mps) +
                           " is not a positive finite speed");
  }
  return Status::Ok();
}

Eigen::Isometry3d InterpolatePose(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b, double fraction) {
  return Interpolate(Eigen::Quaterniond(T_a.linear()).normalized(), T_a.translation(),
                     Eigen::Quaterniond(T_b.linear()).normalized(), T_b.translation(), fraction);
}

ScanOdometrySync::ScanOdometrySync(const ScanOdometrySyncParams& params)
    : params_(params), slots_(params.max_pending_scans), odometry_(params.odometry_history) {
  for (Slot& s : slots_) s.points.reserve(params_.max_points_per_scan);
}

std::size_t ScanOdometrySync::ReservedBytes(const ScanOdometrySyncParams& params) {
  return params.max_pending_scans * (sizeof(Slot) + params.max_points_per_scan * sizeof(PointXYZI)) +
         params.odometry_history * sizeof(Odometry);
}

std::size_t ScanOdometrySync::CountSlots(SlotState state) const noexcept {
  std::size_t n = 0;
  for (const Slot& s : slots_) n += s.state == state ? 1 : 0;
  return n;
}
std::size_t ScanOdometrySync::waiting() const noexcept { return CountSlots(SlotState::kWaiting); }
std::size_t ScanOdometrySync::ready() const noexcept { return CountSlots(SlotState::kReady); }

int ScanOdometrySync::Oldest(bool include_waiting, bool include_ready) const {
  int best = -1;
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    const Slot& s = slots_[i];
    const bool match = (include_waiting && s.state == SlotState::kWaiting) ||
                       (include_ready && s.state == SlotState::kReady);
    if (match && (best < 0 || s.utime_us < slots_[static_cast<std::size_t>(best)].utime_us)) {
      best = static_cast<int>(i);
    }
  }
  return best;
}

const ScanOdometrySync::Odometry& ScanOdometrySync::OdometryAt(std::size_t i) const {
  return odometry_[(odometry_head_ + i) % odometry_.size()];
}

void ScanOdometrySync::ReleaseLent() {
  for (Slot& s : slots_) {
    if (s.state == SlotState::kLent) s.state = SlotState::kFree;
  }
}

void ScanOdometrySync::PushScan(std::int64_t utime_us, Span<const PointXYZI> points) {
  ReleaseLent();
  ++stats_.scans_received;
  if (points.size() > params_.max_points_per_scan) {
    ++stats_.scans_dropped_too_many_points;
    return;
  }
  if (have_scan_ && utime_us <= last_scan_utime_us_) {
    ++stats_.scans_dropped_time_not_increasing;
    return;
  }
  have_scan_ = true;
  last_scan_utime_us_ = utime_us;
  if (odometry_count_ > 0 && utime_us < OdometryAt(0).utime_us) {
    ++stats_.scans_dropped_before_odometry;  // before a hopeless scan could evict a good one
    return;
  }
  Slot* slot = nullptr;
  for (Slot& s : slots_) {
    if (s.state == SlotState::kFree) {
      slot = &s;
      break;
    }
  }
  if (slot == nullptr) {  // every slot held: the oldest goes
    slot = &slots_[static_cast<std::size_t>(Oldest(true, true))];
    ++stats_.scans_dropped_queue_full;
  }
  slot->state = SlotState::kWaiting;
  slot->utime_us = utime_us;
  slot->points.assign(points.begin(), points.end());  // within the reserved capacity: no allocation
  slot->T_odom_sensor = Eigen::Isometry3d::Identity();
  const std::size_t now_held = held();
  if (now_held > stats_.held_high_water) stats_.held_high_water = now_held;
  Resolve();
}

void ScanOdometrySync::PushOdometry(std::int64_t utime_us, const Eigen::Isometry3d& T_odom_sensor) {
  ReleaseLent();
  ++stats_.odometry_received;
  if (!IsValidRigidTransform(T_odom_sensor, kRigidTolerance)) {
    ++stats_.odometry_rejected_invalid;
    return;
  }
  Odometry sample;
  sample.utime_us = utime_us;
  sample.translation_m = T_odom_sensor.translation();
  sample.rotation = Eigen::Quaterniond(T_odom_sensor.linear()).normalized();
  if (odometry_count_ > 0) {
    const Odometry& newest = OdometryAt(odometry_count_ - 1);
    if (utime_us <= newest.utime_us) {
      ++stats_.odometry_rejected_time_not_increasing;
      return;
    }
    const double dt_s = static_cast<double>(utime_us - newest.utime_us) * 1e-6;
    if ((sample.translation_m - newest.translation_m).norm() > params_.max_speed_mps * dt_s) {
      ++stats_.odometry_rejected_speed;
      return;
    }
  }
  if (odometry_count_ < odometry_.size()) {
    odometry_[(odometry_head_ + odometry_count_) % odometry_.size()] = sample;
    ++odometry_count_;
  } else {  // full: overwrite the oldest
    odometry_[odometry_head_] = sample;
    odometry_head_ = (odometry_head_ + 1) % odometry_.size();
  }
  ++stats_.odometry_accepted;
  Resolve();
}

void ScanOdometrySync::Resolve() {
  const double max_gap_us = params_.max_odometry_gap_s * 1e6;
  while (odometry_count_ > 0) {
    const int index = Oldest(true, false);
    if (index < 0) return;
    Slot& slot = slots_[static_cast<std::size_t>(index)];
    const std::int64_t t = slot.utime_us;
    if (t < OdometryAt(0).utime_us) {  // the ring moved past it
      slot.state = SlotState::kFree;
      ++stats_.scans_dropped_before_odometry;
      continue;
    }
    if (t > OdometryAt(odometry_count_ - 1).utime_us) return;  // wait for newer odometry
    // The first sample at or after t (exists: the newest is).
    std::size_t lo = 0, hi = odometry_count_ - 1;
    while (lo < hi) {
      const std::size_t mid = lo + (hi - lo) / 2;
      if (OdometryAt(mid).utime_us < t) {
        lo = mid + 1;
      } else {
        hi = mid;
      }
    }
    const Odometry& b = OdometryAt(lo);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    if (b.utime_us == t) {
      T.linear() = b.rotation.toRotationMatrix();
      T.translation() = b.translation_m;
    } else {
      const Odometry& a = OdometryAt(lo - 1);  // lo >= 1: t > the oldest sample's time
      const double gap_us = static_cast<double>(b.utime_us - a.utime_us);
      if (gap_us > max_gap_us) {
        slot.state = SlotState::kFree;
        ++stats_.scans_dropped_odometry_gap;
        continue;
      }
      const double s = static_cast<double>(t - a.utime_us) / gap_us;
      T = Interpolate(a.rotation, a.translation_m, b.rotation, b.translation_m, s);
    }
    slot.T_odom_sensor = T;
    slot.state = SlotState::kReady;
  }
}

bool ScanOdometrySync::PopReady(SyncedScan* out) {
  ReleaseLent();
  const int index = Oldest(false, true);
  if (index < 0) return false;
  Slot& slot = slots_[static_cast<std::size_t>(index)];
  slot.state = SlotState::kLent;
  out->utime_us = slot.utime_us;
  out->points = Span<const PointXYZI>(slot.points);
  out->T_odom_sensor = slot.T_odom_sensor;
  ++stats_.scans_taken;
  return true;
}

std::size_t ScanOdometrySync::DropWaiting() {
  ReleaseLent();
  std::size_t n = 0;
  for (Slot& s : slots_) {
    if (s.state == SlotState::kWaiting) {
      s.state = SlotState::kFree;
      ++n;
    }
  }
  stats_.scans_dropped_at_end += n;
  return n;
}

}  // namespace commerge
