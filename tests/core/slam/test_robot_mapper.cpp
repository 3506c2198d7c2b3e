// SPDX-License-Identifier: BSD-3-Clause
// The robot side end to end on a generated block loop: ray-cast scans from ground-truth poses, odometry with
// an injected drift, SOLiD on raw scans, 1 m voxels into the scan store, loops found and verified, and the
// optimised trajectory closer to the truth than the odometry.
#include <doctest/doctest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <memory>
#include <vector>

#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/umeyama.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "core/slam/robot_mapper.hpp"
#include "tests/support/block_loop_drive.hpp"

using namespace commerge;

namespace {

using test::kHeight;
using test::kSensorZ;
using test::kWidth;
using test::PoseOnLoop;

/// RMSE of positions after rigid alignment of `estimate` to `truth`.
double Ate(const std::vector<Eigen::Vector3d>& estimate, const std::vector<Eigen::Vector3d>& truth) {
  auto T = AlignRigid(Span<const Eigen::Vector3d>(estimate), Span<const Eigen::Vector3d>(truth));
  REQUIRE(T.ok());
  double sum = 0.0;
  for (std::size_t i = 0; i < estimate.size(); ++i) sum += (*T * estimate[i] - truth[i]).squaredNorm();
  return std::sqrt(sum / static_cast<double>(estimate.size()));
}

struct DriveOutcome {
  int accepted = 0, false_loops = 0;
  std::uint64_t implausible = 0;
  double ate_odometry = 0.0, ate_optimised = 0.0;
};

/// 1.25 laps of the generated block in 0.5 m steps; odometry = truth with a yaw drift of `yaw_drift_deg_per_m`
/// and a scale error `scale_error`. Loops are checked against the truth: a loop between keyframes more than
/// 3 m apart is false.
DriveOutcome DriveBlock(const RobotMapperParams& params, double yaw_drift_deg_per_m, double scale_error) {
  const BoxScene scene = MakeBlockLoopScene(11, static_cast<float>(kWidth), static_cast<float>(kHeight));
  const SpinningLidar lidar = test::BlockLoopLidar();

  auto solid = SolidDescriptor::Create(SolidPreset(LidarSensor::kVelodyneVlp16));
  REQUIRE(solid.ok());
  ScanStoreParams store_params;
  store_params.capacity_bytes = 4 << 20;
  store_params.max_scans = 1000;
  auto store = ScanStore::Create(store_params);
  REQUIRE(store.ok());

  RobotMapperCapacity capacity;
  capacity.max_keyframes = 400;
  capacity.max_points_per_raw_scan = 20000;
  RobotMapper mapper(params, capacity, &*solid, store->get());

  const double perimeter = 2.0 * (kWidth + kHeight);
  Eigen::Isometry3d T_odom = PoseOnLoop(0.0);
  Eigen::Isometry3d T_prev_truth = T_odom;
  std::vector<Eigen::Vector3d> truth, odometry;
  std::vector<PointXYZI> scan;
  DriveOutcome out;
  for (double s = 0.0; s <= 1.25 * perimeter; s += 0.5) {
    const Eigen::Isometry3d T_truth = PoseOnLoop(s);
    Eigen::Isometry3d step = T_prev_truth.inverse() * T_truth;
    step.translation() *= 1.0 + scale_error;
    step.linear() =
        Eigen::AngleAxisd(0.5 * yaw_drift_deg_per_m * kPi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
        step.linear();
    T_odom = T_odom * step;
    T_prev_truth = T_truth;
    const double yaw = std::atan2(T_truth.linear()(1, 0), T_truth.linear()(0, 0));
    CastScan(scene, lidar, static_cast<float>(T_truth.translation().x()), static_cast<float>(T_truth.translation().y()),
             static_cast<float>(kSensorZ), static_cast<float>(yaw), static_cast<std::uint32_t>(s * 2), &scan);
    auto r = mapper.AddScan(Span<const PointXYZI>(scan), T_odom);
    REQUIRE_MESSAGE(r.ok(), r.status().ToString());
    if (!r->is_keyframe) continue;
    CHECK(r->descriptor.valid);
    CHECK(r->store_status.ok());
    const std::size_t n_before_loop = truth.size();
    truth.push_back(T_truth.translation());
    odometry.push_back(T_odom.translation());
    if (r->loop.verdict == LoopVerdict::kAccepted) {
      ++out.accepted;
      const double gap = (truth[r->loop.loop.match] - truth[r->loop.loop.query]).norm();
      if (gap > 3.0) ++out.false_loops;
      // The first loop corrects the drifted keyframes: they must be reported for the server.
      if (out.accepted == 1) CHECK(r->changed_keyframes.size() > n_before_loop / 2);
    }
  }
  auto tail = mapper.OptimizePending();
  REQUIRE(tail.ok());
  CHECK(mapper.stats().pending_loops == 0);
  if (out.accepted > 0) CHECK(mapper.stats().optimisations < static_cast<std::uint64_t>(out.accepted));  // throttled
  const std::size_t n = mapper.num_keyframes();
  REQUIRE(n == truth.size());
  std::vector<Eigen::Vector3d> optimised;
  for (std::size_t k = 0; k < n; ++k) optimised.push_back(mapper.pose(k).translation());
  // The mapper's map frame is its first keyframe's: compare shapes after rigid alignment.
  out.ate_odometry = Ate(odometry, truth);
  out.ate_optimised = Ate(optimised, truth);
  out.implausible = mapper.stats().loops_implausible;
  MESSAGE("keyframes " << n << ", loops accepted " << out.accepted << ", refused as implausible " << out.implausible
                       << ", ATE odometry " << out.ate_odometry << " m, optimised " << out.ate_optimised << " m");
  CHECK(mapper.stats().keyframes == n);
  CHECK((*store)->stats().num_scans == n);
  return out;
}

}  // namespace

TEST_CASE("Robot mapper closes the loop of a generated block drive and removes most of the odometry drift") {
  // 0.1 deg/m of yaw drift and 1 % scale error (ten times what LiDAR odometry drifts), default loop gates:
  // the drift bound (2 %) refuses the loops whose correction exceeds it (9 of 36 here), the rest still close
  // the loop. With LiDAR-like drift nothing is refused (next test).
  const DriveOutcome out = DriveBlock(RobotMapperParams{}, 0.1, 0.01);
  CHECK(out.accepted >= 5);
  CHECK(out.false_loops == 0);
  CHECK(out.implausible < out.accepted);
  CHECK(out.ate_odometry > 1.5);
  CHECK(out.ate_optimised < out.ate_odometry / 3.0);
}

TEST_CASE("Robot mapper: loops correcting more than the odometry drift bound are refused, plausible ones kept") {
  // The same drive and drift against a bound far below this odometry's drift (0.5 m + 0.2 % of the path): every
  // loop's correction exceeds it, so all are refused as implausible and the trajectory keeps its drift.
  RobotMapperParams tight;
  tight.loop.max_correction_m = 0.5;
  tight.loop.max_correction_per_travelled = 0.002;
  const DriveOutcome drifting = DriveBlock(tight, 0.1, 0.01);
  CHECK(drifting.accepted == 0);
  CHECK(drifting.implausible >= 5);
  CHECK(drifting.ate_optimised == doctest::Approx(drifting.ate_odometry).epsilon(1e-6));
  // Odometry drifting 1 % (0.01 deg/m, 0.5 % scale), as LiDAR odometry does: the default bound keeps them all.
  const DriveOutcome good = DriveBlock(RobotMapperParams{}, 0.01, 0.005);
  CHECK(good.accepted >= 5);
  CHECK(good.false_loops == 0);
  CHECK(good.implausible == 0);
  RobotMapperParams bad;
  bad.loop.max_correction_m = -1.0;
  CHECK(ValidateLoopDetectorParams(bad.loop).message().find("max_correction_m") != std::string::npos);
  RobotMapperParams bad_deg;
  bad_deg.loop.max_correction_deg_per_travelled_m = -0.1;
  CHECK(ValidateLoopDetectorParams(bad_deg.loop).message().find("max_correction_deg_per_travelled_m") !=
        std::string::npos);
}
