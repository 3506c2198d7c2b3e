// SPDX-License-Identifier: BSD-3-Clause
// ScanOdometrySync: scans get the pose of a known continuous trajectory (a tilted sensor on a constant-yaw-rate
// circle) within the chord error of the odometry rate, whatever the arrival order; every drop and rejection rule
// moves exactly its own counter; memory stays bounded (held scans never exceed max_pending_scans, the point
// buffers are the pool's, the odometry history stays a ring).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <vector>

#include "core/agent/scan_odometry_sync.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "tests/support/pose_errors.hpp"

using namespace commerge;
using commerge::test::RotationErrorRad;
using commerge::test::TranslationErrorM;

namespace {

constexpr std::int64_t kT0 = 1763800000000000;  // [us] an epoch time stamp

std::int64_t Us(double t_s) { return kT0 + static_cast<std::int64_t>(std::llround(t_s * 1e6)); }

// A robot driving a circle of radius kRadius at kYawRate (counter-clockwise, starting at the origin heading +x),
// carrying the LiDAR at a lever arm with a tilt: T_odom_sensor(t) = T_odom_body(t) * T_body_sensor.
constexpr double kRadius = 10.0;   // [m]
constexpr double kYawRate = 1.0;   // [rad/s]: 10 m/s

Eigen::Isometry3d BodySensor() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = RotationFromYawPitchRoll(0.1, 0.05, -0.03);
  T.translation() = Eigen::Vector3d(0.5, 0.2, 1.2);
  return T;
}

Eigen::Isometry3d Truth(double t_s) {
  const double yaw = kYawRate * t_s;
  Eigen::Isometry3d T_odom_body = Eigen::Isometry3d::Identity();
  T_odom_body.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_odom_body.translation() = Eigen::Vector3d(kRadius * std::sin(yaw), kRadius * (1.0 - std::cos(yaw)), 0.0);
  return T_odom_body * BodySensor();
}

// The sensor origin moves on a circle about (0, kRadius) of radius |(l_x, l_y - kRadius)| (l: the lever arm);
// a chord between samples dt apart is off the arc by at most rho (1 - cos(w dt / 2)) (the sagitta).
double Sagitta(double dt_s) {
  const Eigen::Vector3d l = BodySensor().translation();
  const double rho = std::hypot(l.x(), l.y() - kRadius);
  return rho * (1.0 - std::cos(kYawRate * dt_s / 2.0));
}


std::vector<PointXYZI> Points(std::size_t n, float tag = 0.0f) {
  std::vector<PointXYZI> p(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = {static_cast<float>(i), tag, 1.0f, 0.5f};
  return p;
}

Eigen::Isometry3d AtX(double x_m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x_m, 0.0, 0.0);
  return T;
}

ScanOdometrySyncParams SmallParams() {
  ScanOdometrySyncParams p;
  p.max_points_per_scan = 64;
  return p;
}

// Every scan received is taken, dropped under exactly one rule, or held.
void CheckAccounting(const ScanOdometrySync& sync) {
  const ScanOdometrySyncStats& s = sync.stats();
  CHECK(s.scans_received == s.scans_taken + s.scans_dropped() + sync.held());
  CHECK(s.odometry_received == s.odometry_accepted + s.odometry_rejected());
  CHECK(sync.held() <= sync.params().max_pending_scans);
}

std::vector<SyncedScan> PopAll(ScanOdometrySync* sync) {
  std::vector<SyncedScan> out;
  SyncedScan s;
  while (sync->PopReady(&s)) out.push_back(s);  // the views of all but the last are stale: times and poses only
  return out;
}

}  // namespace

TEST_CASE("scan/odometry sync: parameters outside their ranges are refused, naming them") {
  CHECK(ValidateScanOdometrySyncParams(ScanOdometrySyncParams{}).ok());
  auto refused = [](ScanOdometrySyncParams p, const char* name) {
    const Status st = ValidateScanOdometrySyncParams(p);
    CHECK(st.code() == StatusCode::kInvalidArgument);
    INFO(st.message());
    CHECK(st.message().find(name) != std::string::npos);
  };
  ScanOdometrySyncParams p;
  p.max_pending_scans = 0;
  refused(p, "max_pending_scans");
  p = {};
  p.max_pending_scans = 1025;
  refused(p, "max_pending_scans");
  p = {};
  p.odometry_history = 1;
  refused(p, "odometry_history");
  p = {};
  p.max_points_per_scan = 0;
  refused(p, "max_points_per_scan");
  p = {};
  p.max_points_per_scan = kMaxLidarScanPoints + 1;
  refused(p, "max_points_per_scan");
  for (double bad : {0.0, -0.1, 3601.0, std::numeric_limits<double>::quiet_NaN()}) {
    p = {};
    p.max_odometry_gap_s = bad;
    refused(p, "max_odometry_gap_s");
  }
  for (double bad : {0.0, -1.0, std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()}) {
    p = {};
    p.max_speed_mps = bad;
    refused(p, "max_speed_mps");
  }
  p = {};
  p.max_pending_scans = 1;
  p.odometry_history = 2;
  p.max_points_per_scan = kMaxLidarScanPoints;
  CHECK(ValidateScanOdometrySyncParams(p).ok());
  CHECK(ScanOdometrySync::ReservedBytes(p) >= kMaxLidarScanPoints * sizeof(PointXYZI));
}

TEST_CASE("scan/odometry sync: InterpolatePose is linear in translation and slerps the shorter arc") {
  const Eigen::Isometry3d a = Truth(0.3), b = Truth(0.9);
  CHECK(TranslationErrorM(InterpolatePose(a, b, 0.0), a) < 1e-12);
  CHECK(RotationErrorRad(InterpolatePose(a, b, 0.0), a) < 1e-9);
  CHECK(TranslationErrorM(InterpolatePose(a, b, 1.0), b) < 1e-12);
  CHECK(RotationErrorRad(InterpolatePose(a, b, 1.0), b) < 1e-9);
  const Eigen::Isometry3d mid = InterpolatePose(a, b, 0.25);
  CHECK((mid.translation() - (0.75 * a.translation() + 0.25 * b.translation())).norm() < 1e-12);
  // Yaw 170 deg to yaw -170 deg: the shorter arc passes 180 deg, not 0 deg.
  Eigen::Isometry3d ya = Eigen::Isometry3d::Identity(), yb = Eigen::Isometry3d::Identity();
  ya.linear() = RotationFromYawPitchRoll(170.0 * kPi / 180.0, 0.0, 0.0);
  yb.linear() = RotationFromYawPitchRoll(-170.0 * kPi / 180.0, 0.0, 0.0);
  const Eigen::Isometry3d ym = InterpolatePose(ya, yb, 0.5);
  CHECK(std::abs(std::abs(YawRad(ym.linear())) - kPi) < 1e-9);
  CHECK(RotationErrorRad(ym, ya) == doctest::Approx(10.0 * kPi / 180.0).epsilon(1e-9));
}

TEST_CASE("scan/odometry sync: scans on a constant-yaw-rate circle get the analytic pose within the chord error") {
  // Odometry at 20 Hz, scans at 10 Hz offset from the odometry samples (never on one), each scan pushed before
  // the odometry sample after it: every scan waits, then is interpolated.
  const double odo_dt = 0.05, scan_dt = 0.1, offset = 0.0123;
  const double bound = Sagitta(odo_dt);
  REQUIRE(bound > 1e-4);  // the test would not tell interpolation from the truth otherwise
  REQUIRE(bound < 0.01);
  ScanOdometrySync sync(SmallParams());
  const std::vector<PointXYZI> cloud = Points(10);
  int odo = 0, scans = 0;
  const int total_scans = 60;
  double max_error = 0.0, max_rotation_error = 0.0;
  std::uint64_t checked = 0;
  auto drain = [&]() {
    SyncedScan s;
    while (sync.PopReady(&s)) {
      const double t = static_cast<double>(s.utime_us - kT0) * 1e-6;
      CHECK(s.points.size() == 10);
      max_error = std::max(max_error, TranslationErrorM(s.T_odom_sensor, Truth(t)));
      max_rotation_error = std::max(max_rotation_error, RotationErrorRad(s.T_odom_sensor, Truth(t)));
      ++checked;
    }
  };
  while (scans < total_scans) {
    const double t_odo = odo * odo_dt, t_scan = offset + scans * scan_dt;
    if (t_scan <= t_odo) {
      sync.PushScan(Us(t_scan), Span<const PointXYZI>(cloud));
      ++scans;
    } else {
      sync.PushOdometry(Us(t_odo), Truth(t_odo));
      ++odo;
    }
    CHECK(sync.waiting() <= 1);
    drain();
  }
  sync.PushOdometry(Us(odo * odo_dt), Truth(odo * odo_dt));
  drain();
  CHECK(checked == static_cast<std::uint64_t>(total_scans));
  CHECK(sync.stats().scans_taken == static_cast<std::uint64_t>(total_scans));
  CHECK(sync.stats().scans_dropped() == 0);
  CHECK(sync.stats().odometry_rejected() == 0);
  INFO("max translation error ", max_error, " m, bound ", bound, " m");
  CHECK(max_error <= bound + 1e-9);
  CHECK(max_error > 0.5 * bound);  // interpolated (a nearest sample would be off by ~v dt / 2 = 0.25 m)
  // Constant rate about a fixed axis: slerp is exact.
  CHECK(max_rotation_error < 1e-9);
  CheckAccounting(sync);

  // A scan exactly half-way between two samples is off by the sagitta itself (linear, not nearest, not on-arc).
  ScanOdometrySync mid(SmallParams());
  mid.PushOdometry(Us(1.0), Truth(1.0));
  mid.PushOdometry(Us(1.0 + odo_dt), Truth(1.0 + odo_dt));
  mid.PushScan(Us(1.0 + odo_dt / 2), Span<const PointXYZI>(cloud));
  SyncedScan s;
  REQUIRE(mid.PopReady(&s));
  CHECK(TranslationErrorM(s.T_odom_sensor, Truth(1.0 + odo_dt / 2)) == doctest::Approx(bound).epsilon(1e-4));
}

TEST_CASE("scan/odometry sync: odometry before, after or interleaved with the scans gives the same poses") {
  const std::vector<double> scan_times = {0.031, 0.131, 0.231, 0.331};  // 4 = max_pending_scans
  std::vector<double> odo_times;
  for (int i = 0; i <= 8; ++i) odo_times.push_back(0.05 * i);
  const std::vector<PointXYZI> cloud = Points(5);
  auto run = [&](int order) {
    ScanOdometrySync sync(SmallParams());
    std::vector<SyncedScan> got;
    auto pop = [&]() {
      for (const SyncedScan& s : PopAll(&sync)) got.push_back(s);
    };
    if (order == 0) {  // all odometry first
      for (double t : odo_times) sync.PushOdometry(Us(t), Truth(t));
      for (double t : scan_times) {
        sync.PushScan(Us(t), Span<const PointXYZI>(cloud));
        CHECK(sync.ready() == 1);  // resolved on arrival
        pop();
      }
    } else if (order == 1) {  // all scans first: they wait
      for (double t : scan_times) sync.PushScan(Us(t), Span<const PointXYZI>(cloud));
      CHECK(sync.waiting() == 4);
      for (double t : odo_times) {
        sync.PushOdometry(Us(t), Truth(t));
        pop();
      }
    } else {  // odometry lagging two samples behind the scans in arrival
      std::size_t o = 0;
      for (double t : scan_times) {
        while (o < odo_times.size() && odo_times[o] + 0.1 < t) {
          sync.PushOdometry(Us(odo_times[o]), Truth(odo_times[o]));
          ++o;
        }
        sync.PushScan(Us(t), Span<const PointXYZI>(cloud));
        pop();
      }
      for (; o < odo_times.size(); ++o) {
        sync.PushOdometry(Us(odo_times[o]), Truth(odo_times[o]));
        pop();
      }
    }
    CHECK(sync.stats().scans_dropped() == 0);
    CheckAccounting(sync);
    return got;
  };
  const std::vector<SyncedScan> first = run(0), after = run(1), mixed = run(2);
  REQUIRE(first.size() == scan_times.size());
  REQUIRE(after.size() == scan_times.size());
  REQUIRE(mixed.size() == scan_times.size());
  for (std::size_t i = 0; i < scan_times.size(); ++i) {
    CHECK(first[i].utime_us == Us(scan_times[i]));  // in time order
    CHECK(after[i].utime_us == first[i].utime_us);
    CHECK(mixed[i].utime_us == first[i].utime_us);
    CHECK(TranslationErrorM(after[i].T_odom_sensor, first[i].T_odom_sensor) < 1e-12);
    CHECK(RotationErrorRad(after[i].T_odom_sensor, first[i].T_odom_sensor) < 1e-9);
    CHECK(TranslationErrorM(mixed[i].T_odom_sensor, first[i].T_odom_sensor) < 1e-12);
    CHECK(TranslationErrorM(first[i].T_odom_sensor, Truth(scan_times[i])) <= Sagitta(0.05) + 1e-9);
  }
}

TEST_CASE("scan/odometry sync: a scan at an odometry sample's time takes that pose, and the points it was given") {
  ScanOdometrySync sync(SmallParams());
  const std::vector<PointXYZI> cloud = Points(7, 3.0f);
  sync.PushScan(Us(2.0), Span<const PointXYZI>(cloud));  // waits: no odometry yet
  CHECK(sync.waiting() == 1);
  sync.PushOdometry(Us(1.0), AtX(1.0));
  CHECK(sync.waiting() == 1);  // 1.0 < 2.0: not covered yet
  // The odometry stack publishes the scan's own pose after the scan, 1 s after the previous: a gap, but no
  // interpolation over it is needed.
  sync.PushOdometry(Us(2.0), Truth(2.0));
  SyncedScan s;
  REQUIRE(sync.PopReady(&s));
  CHECK(s.utime_us == Us(2.0));
  CHECK(TranslationErrorM(s.T_odom_sensor, Truth(2.0)) < 1e-12);
  CHECK(RotationErrorRad(s.T_odom_sensor, Truth(2.0)) < 1e-9);
  REQUIRE(s.points.size() == cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    CHECK(s.points[i].x == cloud[i].x);
    CHECK(s.points[i].y == 3.0f);
  }
  CHECK_FALSE(sync.PopReady(&s));
  CHECK(sync.stats().scans_taken == 1);
  CheckAccounting(sync);
}

TEST_CASE("scan/odometry sync: each drop rule moves its own counter and nothing else") {
  const std::vector<PointXYZI> cloud = Points(8);
  auto only = [](const ScanOdometrySync& sync, std::uint64_t ScanOdometrySyncStats::*counter, std::uint64_t n) {
    const ScanOdometrySyncStats& s = sync.stats();
    CHECK(s.*counter == n);
    CHECK(s.scans_dropped() == n);
    CheckAccounting(sync);
  };

  SUBCASE("too many points") {
    ScanOdometrySync sync(SmallParams());
    sync.PushScan(Us(0.0), Span<const PointXYZI>(Points(65)));
    sync.PushScan(Us(0.1), Span<const PointXYZI>(Points(64)));  // exactly the limit
    only(sync, &ScanOdometrySyncStats::scans_dropped_too_many_points, 1);
    CHECK(sync.waiting() == 1);
  }
  SUBCASE("time not increasing") {
    ScanOdometrySync sync(SmallParams());
    sync.PushScan(Us(1.0), Span<const PointXYZI>(cloud));
    sync.PushScan(Us(1.0), Span<const PointXYZI>(cloud));  // same time
    sync.PushScan(Us(0.9), Span<const PointXYZI>(cloud));  // earlier
    only(sync, &ScanOdometrySyncStats::scans_dropped_time_not_increasing, 2);
    CHECK(sync.waiting() == 1);
  }
  SUBCASE("before the oldest odometry sample") {
    ScanOdometrySyncParams p = SmallParams();
    p.odometry_history = 4;
    ScanOdometrySync sync(p);
    sync.PushOdometry(Us(1.0), AtX(0.0));
    sync.PushScan(Us(0.99), Span<const PointXYZI>(cloud));  // before the first sample: never interpolable
    only(sync, &ScanOdometrySyncStats::scans_dropped_before_odometry, 1);
    CHECK(sync.held() == 0);
    // The ring keeps 4 samples: after 1.0 .. 1.5 it holds 1.2 .. 1.5, so a scan at 1.15 is lost as well.
    for (int i = 1; i <= 5; ++i) sync.PushOdometry(Us(1.0 + 0.1 * i), AtX(0.1 * i));
    CHECK(sync.odometry_samples() == 4);
    sync.PushScan(Us(1.15), Span<const PointXYZI>(cloud));
    only(sync, &ScanOdometrySyncStats::scans_dropped_before_odometry, 2);
    sync.PushScan(Us(1.25), Span<const PointXYZI>(cloud));  // inside the ring
    CHECK(sync.ready() == 1);
    only(sync, &ScanOdometrySyncStats::scans_dropped_before_odometry, 2);
  }
  SUBCASE("odometry gap beyond max_odometry_gap_s") {
    ScanOdometrySync sync(SmallParams());
    sync.PushOdometry(Us(0.0), AtX(0.0));
    sync.PushScan(Us(0.3), Span<const PointXYZI>(cloud));
    sync.PushOdometry(Us(0.6), AtX(1.0));  // 0.6 s between the bracketing samples
    only(sync, &ScanOdometrySyncStats::scans_dropped_odometry_gap, 1);
    CHECK(sync.held() == 0);
    // Exactly 0.5 s is not a hole.
    sync.PushScan(Us(0.8), Span<const PointXYZI>(cloud));
    sync.PushOdometry(Us(1.1), AtX(2.0));
    only(sync, &ScanOdometrySyncStats::scans_dropped_odometry_gap, 1);
    SyncedScan s;
    REQUIRE(sync.PopReady(&s));
    CHECK(s.T_odom_sensor.translation().x() == doctest::Approx(1.4));
  }
  SUBCASE("queue full: the oldest held scan goes") {
    ScanOdometrySync sync(SmallParams());  // 4 slots
    for (int i = 0; i < 6; ++i) sync.PushScan(Us(1.0 + 0.1 * i), Span<const PointXYZI>(Points(8, static_cast<float>(i))));
    only(sync, &ScanOdometrySyncStats::scans_dropped_queue_full, 2);
    CHECK(sync.waiting() == 4);
    sync.PushOdometry(Us(0.9), AtX(0.0));
    sync.PushOdometry(Us(1.6), AtX(0.0));  // 0.7 s: a gap for every held scan
    CHECK(sync.stats().scans_dropped_queue_full == 2);
    CHECK(sync.stats().scans_dropped_odometry_gap == 4);
    CHECK(sync.held() == 0);
    CheckAccounting(sync);
  }
  SUBCASE("queue full drops the oldest ready scan when nobody pops") {
    ScanOdometrySync dense(SmallParams());
    for (int i = 0; i <= 20; ++i) dense.PushOdometry(Us(0.1 * i), AtX(0.1 * i));
    for (int i = 0; i < 6; ++i) {
      dense.PushScan(Us(0.05 + 0.2 * i), Span<const PointXYZI>(Points(8, static_cast<float>(i))));
    }
    only(dense, &ScanOdometrySyncStats::scans_dropped_queue_full, 2);
    CHECK(dense.ready() == 4);
    const std::vector<SyncedScan> got = PopAll(&dense);
    REQUIRE(got.size() == 4);
    CHECK(got.front().utime_us == Us(0.45));  // scans 0 and 1 went
    CHECK(got.back().utime_us == Us(1.05));
  }
  SUBCASE("still waiting at the end of input") {
    ScanOdometrySync sync(SmallParams());
    sync.PushOdometry(Us(0.0), AtX(0.0));
    sync.PushOdometry(Us(0.1), AtX(0.1));
    sync.PushScan(Us(0.05), Span<const PointXYZI>(cloud));  // ready
    sync.PushScan(Us(0.15), Span<const PointXYZI>(cloud));  // waits
    sync.PushScan(Us(0.25), Span<const PointXYZI>(cloud));  // waits
    CHECK(sync.DropWaiting() == 2);
    only(sync, &ScanOdometrySyncStats::scans_dropped_at_end, 2);
    CHECK(sync.ready() == 1);
    SyncedScan s;
    CHECK(sync.PopReady(&s));
    CHECK(s.utime_us == Us(0.05));
  }
}

TEST_CASE("scan/odometry sync: each odometry rejection rule moves its own counter") {
  auto rejected_only = [](const ScanOdometrySync& sync, std::uint64_t ScanOdometrySyncStats::*counter,
                          std::uint64_t n) {
    CHECK(sync.stats().*counter == n);
    CHECK(sync.stats().odometry_rejected() == n);
    CheckAccounting(sync);
  };
  SUBCASE("invalid poses") {
    ScanOdometrySync sync(SmallParams());
    Eigen::Isometry3d nan = AtX(0.0);
    nan.translation().y() = std::numeric_limits<double>::quiet_NaN();
    sync.PushOdometry(Us(0.0), nan);
    Eigen::Isometry3d sheared = AtX(0.0);
    sheared.linear()(0, 1) = 0.1;  // not a rotation
    sync.PushOdometry(Us(0.1), sheared);
    Eigen::Isometry3d inf = AtX(0.0);
    inf.linear()(2, 2) = std::numeric_limits<double>::infinity();
    sync.PushOdometry(Us(0.2), inf);
    rejected_only(sync, &ScanOdometrySyncStats::odometry_rejected_invalid, 3);
    CHECK(sync.odometry_samples() == 0);
  }
  SUBCASE("time not increasing") {
    ScanOdometrySync sync(SmallParams());
    sync.PushOdometry(Us(1.0), AtX(0.0));
    sync.PushOdometry(Us(1.0), AtX(0.0));
    sync.PushOdometry(Us(0.5), AtX(0.0));
    rejected_only(sync, &ScanOdometrySyncStats::odometry_rejected_time_not_increasing, 2);
    CHECK(sync.odometry_samples() == 1);
  }
  SUBCASE("faster than max_speed_mps") {
    ScanOdometrySync sync(SmallParams());  // 30 m/s
    sync.PushOdometry(Us(0.0), AtX(0.0));
    sync.PushOdometry(Us(0.1), AtX(2.9));    // 29 m/s: accepted
    sync.PushOdometry(Us(0.2), AtX(12.9));   // 100 m/s: a jump
    rejected_only(sync, &ScanOdometrySyncStats::odometry_rejected_speed, 1);
    CHECK(sync.odometry_samples() == 2);
    // A relocalised stack keeps publishing from the new place: accepted once the elapsed time makes the jump
    // slower than 30 m/s (10 m from 2.9 m: after 1/3 s); the scans in between fall into the gap.
    sync.PushScan(Us(0.25), Span<const PointXYZI>(Points(3)));
    sync.PushOdometry(Us(0.3), AtX(13.0));  // 50 m/s from the last accepted sample
    rejected_only(sync, &ScanOdometrySyncStats::odometry_rejected_speed, 2);
    sync.PushOdometry(Us(0.7), AtX(13.1));  // 17 m/s over 0.6 s: accepted
    CHECK(sync.stats().odometry_accepted == 3);
    CHECK(sync.stats().scans_dropped_odometry_gap == 1);
    CheckAccounting(sync);
  }
}

TEST_CASE("scan/odometry sync: many scans without odometry never hold more than max_pending_scans") {
  ScanOdometrySyncParams p = SmallParams();
  p.max_pending_scans = 4;
  ScanOdometrySync sync(p);
  const std::vector<PointXYZI> cloud = Points(64);
  for (int i = 0; i < 10000; ++i) {
    sync.PushScan(kT0 + 100000LL * i, Span<const PointXYZI>(cloud));
    REQUIRE(sync.held() <= 4);
  }
  CHECK(sync.held() == 4);
  CHECK(sync.stats().held_high_water == 4);
  CHECK(sync.stats().scans_dropped_queue_full == 10000 - 4);
  CheckAccounting(sync);
  // The survivors are the newest four.
  sync.PushOdometry(kT0 + 100000LL * 9996, AtX(0.0));
  sync.PushOdometry(kT0 + 100000LL * 9999, AtX(0.5));
  const std::vector<SyncedScan> got = PopAll(&sync);
  REQUIRE(got.size() == 4);
  CHECK(got.front().utime_us == kT0 + 100000LL * 9996);
  CHECK(got.back().T_odom_sensor.translation().x() == doctest::Approx(0.5));
}

TEST_CASE("scan/odometry sync: points live in the pool's buffers and the odometry history is a ring") {
  ScanOdometrySyncParams p = SmallParams();
  p.max_pending_scans = 3;
  p.odometry_history = 16;
  ScanOdometrySync sync(p);
  std::set<const PointXYZI*> buffers;
  const std::vector<PointXYZI> full = Points(p.max_points_per_scan), small = Points(1);
  std::uint64_t popped = 0;
  for (int i = 0; i < 2000; ++i) {
    const std::int64_t t = kT0 + 50000LL * i;  // odometry and scans at 20 Hz, every third scan full size
    sync.PushOdometry(t, AtX(0.05 * i));
    sync.PushScan(t + 20000, Span<const PointXYZI>(i % 3 == 0 ? full : small));
    REQUIRE(sync.odometry_samples() <= 16);
    SyncedScan s;
    while (sync.PopReady(&s)) {
      buffers.insert(s.points.data());
      ++popped;
      CHECK(s.points.size() == (static_cast<std::int64_t>(s.utime_us - kT0 - 20000) / 50000 % 3 == 0 ? 64u : 1u));
    }
  }
  CHECK(popped == 1999);  // the last scan waits for the next sample
  CHECK(buffers.size() <= 3);  // no buffer was ever reallocated or made per scan
  CHECK(sync.odometry_samples() == 16);
  CheckAccounting(sync);
}

TEST_CASE("scan/odometry sync: a popped scan's points stay valid until the next call and scans pop in time order") {
  ScanOdometrySync sync(SmallParams());
  for (int i = 0; i <= 10; ++i) sync.PushOdometry(Us(0.1 * i), AtX(0.1 * i));
  sync.PushScan(Us(0.15), Span<const PointXYZI>(Points(4, 1.0f)));
  sync.PushScan(Us(0.25), Span<const PointXYZI>(Points(5, 2.0f)));
  SyncedScan a;
  REQUIRE(sync.PopReady(&a));
  CHECK(a.utime_us == Us(0.15));
  REQUIRE(a.points.size() == 4);
  CHECK(a.points[3].y == 1.0f);
  CHECK(sync.held() == 1);
  SyncedScan b;
  REQUIRE(sync.PopReady(&b));  // a's slot is free again from here
  CHECK(b.utime_us == Us(0.25));
  CHECK(b.points.size() == 5);
  CHECK(b.points[4].y == 2.0f);
  CHECK(b.T_odom_sensor.translation().x() == doctest::Approx(0.25));
  CHECK_FALSE(sync.PopReady(&b));
  CHECK(sync.stats().scans_taken == 2);
  CheckAccounting(sync);
}
