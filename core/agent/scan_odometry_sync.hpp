// SPDX-License-Identifier: BSD-3-Clause
// ScanOdometrySync: pairs live LiDAR scans with the odometry stack's poses. Scans and odometry arrive on separate
// channels, in any order and at different rates (odometry typically 10-100 Hz, scans 10 Hz). For each scan it
// produces (scan, T_odom_sensor at the scan's time stamp), interpolated between the two odometry samples that
// bracket the scan time (linear in translation, slerp in rotation), as soon as an odometry sample at or after the
// scan time has arrived.
//
// Rules, each with its counter in ScanOdometrySyncStats:
//  * a scan with more than max_points_per_scan points is dropped (scans_dropped_too_many_points);
//  * a scan whose time stamp is not after the previous scan's is dropped (scans_dropped_time_not_increasing): the
//    mapper needs scans in time order;
//  * a scan older than the oldest odometry sample held can never be interpolated: dropped
//    (scans_dropped_before_odometry);
//  * two bracketing odometry samples more than max_odometry_gap_s apart are a hole, not a motion: the scan is
//    dropped (scans_dropped_odometry_gap); nothing is ever extrapolated;
//  * at most max_pending_scans scans are held (waiting for odometry, or synchronised and not yet taken); a scan
//    arriving when all are held drops the oldest held one (scans_dropped_queue_full);
//  * an odometry sample that is not a finite rigid transform is rejected (odometry_rejected_invalid), one whose
//    time stamp is not after the newest accepted sample's is rejected (odometry_rejected_time_not_increasing), and
//    one that moves faster than max_speed_mps from the newest accepted sample is rejected
//    (odometry_rejected_speed). A real relocalisation jump is therefore accepted only once the elapsed time makes
//    it slower than max_speed_mps; the scans in between fall into an odometry gap and are dropped.
// Every scan received is, at any time, taken, dropped under exactly one rule, or held:
// scans_received = scans_taken + scans_dropped() + held().
//
// Memory is fixed at construction: max_pending_scans point buffers of max_points_per_scan points each, and a ring
// of odometry_history samples. Pushing and popping never allocate. Pure: no clock, no I/O; time is the messages'
// time stamps.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "core/agent/live_input.hpp"
#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

struct ScanOdometrySyncParams {
  /// Scans held at once (waiting for odometry, or synchronised and not yet popped); 1..1024.
  std::size_t max_pending_scans = 4;
  /// Odometry samples kept (a ring; the oldest is overwritten); 2..1048576. 256 samples cover 2.56 s at 100 Hz.
  std::size_t odometry_history = 256;
  /// Points of one scan; larger scans are dropped. 1..kMaxLidarScanPoints. The default is the mapper's
  /// RobotMapperCapacity::max_points_per_raw_scan.
  std::size_t max_points_per_scan = 131072;
  /// Bracketing odometry samples further apart than this are a hole [s]; > 0 and <= 3600.
  double max_odometry_gap_s = 0.5;
  /// An odometry sample implying a faster motion than this from the previous one is rejected [m/s]; > 0.
  double max_speed_mps = 30.0;
};

/// InvalidArgument naming the parameter when one is outside its range.
Status ValidateScanOdometrySyncParams(const ScanOdometrySyncParams& params);

struct ScanOdometrySyncStats {
  std::uint64_t scans_received = 0;
  std::uint64_t scans_taken = 0;                        ///< synchronised and handed out by PopReady
  std::uint64_t scans_dropped_too_many_points = 0;
  std::uint64_t scans_dropped_time_not_increasing = 0;
  std::uint64_t scans_dropped_before_odometry = 0;
  std::uint64_t scans_dropped_odometry_gap = 0;
  std::uint64_t scans_dropped_queue_full = 0;
  std::uint64_t scans_dropped_at_end = 0;               ///< still waiting at DropWaiting()
  std::uint64_t odometry_received = 0;
  std::uint64_t odometry_accepted = 0;
  std::uint64_t odometry_rejected_invalid = 0;
  std::uint64_t odometry_rejected_time_not_increasing = 0;
  std::uint64_t odometry_rejected_speed = 0;
  std::size_t held_high_water = 0;                      ///< most scans held at once

  /// Sum of the scans_dropped_* counters.
  std::uint64_t scans_dropped() const noexcept {
    return scans_dropped_too_many_points + scans_dropped_time_not_increasing + scans_dropped_before_odometry +
           scans_dropped_odometry_gap + scans_dropped_queue_full + scans_dropped_at_end;
  }
  /// Sum of the odometry_rejected_* counters.
  std::uint64_t odometry_rejected() const noexcept {
    return odometry_rejected_invalid + odometry_rejected_time_not_increasing + odometry_rejected_speed;
  }
};

/// A synchronised scan. `points` views the sync's buffer: valid until the next non-const call on it.
struct SyncedScan {
  std::int64_t utime_us = 0;
  Span<const PointXYZI> points;
  Eigen::Isometry3d T_odom_sensor = Eigen::Isometry3d::Identity();
};

/// T at `fraction` (0 = T_a, 1 = T_b) on the way from T_a to T_b: translation linear, rotation by slerp along
/// the shorter arc.
Eigen::Isometry3d InterpolatePose(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b, double fraction);

class ScanOdometrySync {
 public:
  /// Precondition: ValidateScanOdometrySyncParams(params).ok(). Reserves every buffer.
  explicit ScanOdometrySync(const ScanOdometrySyncParams& params);

  /// One scan (sensor frame) with its time stamp; copied into a pool buffer. Non-finite points are copied as
  /// they are (the LCM decoder already dropped them).
  void PushScan(std::int64_t utime_us, Span<const PointXYZI> points);
  void PushScan(const LidarScan& scan) { PushScan(scan.utime_us, Span<const PointXYZI>(scan.points)); }

  /// One odometry pose T_odom_sensor at its time stamp.
  void PushOdometry(std::int64_t utime_us, const Eigen::Isometry3d& T_odom_sensor);
  void PushOdometry(const OdometrySample& sample) { PushOdometry(sample.utime_us, sample.T_odom_sensor); }

  /// The oldest synchronised scan, in time order; false when none is ready. Its points stay valid until the next
  /// non-const call.
  bool PopReady(SyncedScan* out);

  /// End of input: drops the scans still waiting for odometry (counted in scans_dropped_at_end) and returns how
  /// many. Synchronised scans stay poppable.
  std::size_t DropWaiting();

  std::size_t waiting() const noexcept;  ///< scans waiting for odometry
  std::size_t ready() const noexcept;    ///< synchronised scans not yet popped
  std::size_t held() const noexcept { return waiting() + ready(); }
  std::size_t odometry_samples() const noexcept { return odometry_count_; }
  const ScanOdometrySyncStats& stats() const noexcept { return stats_; }
  const ScanOdometrySyncParams& params() const noexcept { return params_; }

  /// Bytes the object reserves for `params` (point pool and odometry ring), for a memory budget.
  static std::size_t ReservedBytes(const ScanOdometrySyncParams& params);

 private:
  enum class SlotState { kFree, kWaiting, kReady, kLent };
  struct Slot {
    SlotState state = SlotState::kFree;
    std::int64_t utime_us = 0;
    std::vector<PointXYZI> points;  // capacity max_points_per_scan, reserved once
    Eigen::Isometry3d T_odom_sensor = Eigen::Isometry3d::Identity();
  };
  struct Odometry {
    std::int64_t utime_us = 0;
    Eigen::Vector3d translation_m = Eigen::Vector3d::Zero();
    Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  };

  void ReleaseLent();
  /// Resolves waiting scans, oldest first, while odometry covers them.
  void Resolve();
  /// The slot with the oldest time among those waiting (with `include_waiting`) or ready (with
  /// `include_ready`); -1 if none.
  int Oldest(bool include_waiting, bool include_ready) const;
  const Odometry& OdometryAt(std::size_t i) const;  ///< i = 0 is the oldest sample held
  std::size_t CountSlots(SlotState state) const noexcept;

  ScanOdometrySyncParams params_;
  std::vector<Slot> slots_;
  std::vector<Odometry> odometry_;  // ring of params_.odometry_history
  std::size_t odometry_head_ = 0;   // index of the oldest sample
  std::size_t odometry_count_ = 0;
  std::int64_t last_scan_utime_us_ = 0;
  bool have_scan_ = false;
  ScanOdometrySyncStats stats_;
};

}  // namespace commerge
