// SPDX-License-Identifier: BSD-3-Clause
// The robot side end to end on a generated block loop: ray-cast scans from ground-truth poses, odometry with
// an injected drift, SOLiD on raw scans, 1 m voxels into the scan store, loops found and verified, and the
// optimised trajectory closer to the truth than the odometry.
#include <doctest/doctest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "core/descriptor/ring_occupancy.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/memory/budget.hpp"
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

namespace {

// A place built for the descriptor-input tests: ground at z = -1.7 m in the odometry frame, a ring of low wall
// at 12 m, poles every 20 deg at 6 m and a tall wall segment at 22 m, around the origin. Heights, ranges and
// azimuths (odd degrees) stay off the ring descriptor's cell edges (bands 0.3/1/2/4/8 m, rings of 5 m, 6 deg).
std::vector<Eigen::Vector3d> DescriptorTestPlace() {
  std::vector<Eigen::Vector3d> place;
  for (int s = 1; s < 360; s += 2) {
    const double a = s * kDegToRad;
    for (double r = 2.5; r < 38.0; r += 1.5) place.emplace_back(r * std::cos(a), r * std::sin(a), -1.7);
    place.emplace_back(12.0 * std::cos(a), 12.0 * std::sin(a), -1.0);
    if (s % 20 == 1) {
      for (double h = -1.1; h < 3.0; h += 0.6) place.emplace_back(6.0 * std::cos(a), 6.0 * std::sin(a), h);
    }
    if (s < 90) {
      for (double h = -1.0; h < 5.0; h += 0.7) place.emplace_back(22.0 * std::cos(a), 22.0 * std::sin(a), h);
    }
  }
  return place;
}

// The place as a sensor at T_odom_sensor sees it; `half_fov_deg` < 180 keeps a forward cone only.
std::vector<PointXYZI> SeenFrom(const std::vector<Eigen::Vector3d>& place, const Eigen::Isometry3d& T_odom_sensor,
                                double half_fov_deg = 180.0) {
  std::vector<PointXYZI> scan;
  const Eigen::Isometry3d T_sensor_odom = T_odom_sensor.inverse();
  for (const Eigen::Vector3d& p : place) {
    const Eigen::Vector3d q = T_sensor_odom * p;
    if (std::fabs(std::atan2(q.y(), q.x())) > half_fov_deg * kDegToRad) continue;
    scan.push_back({static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()), 1.0f});
  }
  return scan;
}

struct MapperFixture {
  RingOccupancyDescriptor ring;
  std::unique_ptr<ScanStore> store;
  std::unique_ptr<RobotMapper> mapper;
  explicit MapperFixture(const DescriptorInputParams& input, std::size_t max_points_per_raw_scan = 20000,
                         std::size_t min_stored_points = 0) {
    ScanStoreParams store_params;
    store_params.capacity_bytes = 1 << 20;
    store_params.max_scans = 100;
    auto made = ScanStore::Create(store_params);
    REQUIRE(made.ok());
    store = std::move(*made);
    RobotMapperParams params;
    params.descriptor_input = input;
    params.voxel.min_points = min_stored_points;
    RobotMapperCapacity capacity;
    capacity.max_keyframes = 50;
    capacity.max_points_per_raw_scan = max_points_per_raw_scan;
    capacity.max_points_per_stored_scan = std::min(capacity.max_points_per_stored_scan, max_points_per_raw_scan);
    mapper = std::make_unique<RobotMapper>(params, capacity, &ring, store.get());
  }
  std::vector<float> Add(const std::vector<PointXYZI>& scan, const Eigen::Isometry3d& T_odom_sensor) {
    auto step = mapper->AddScan(Span<const PointXYZI>(scan), T_odom_sensor);
    REQUIRE(step.ok());
    REQUIRE(step->is_keyframe);
    const Span<const float> d = mapper->descriptor(step->keyframe);
    return std::vector<float>(d.begin(), d.end());
  }
};

double L2(const std::vector<float>& a, const std::vector<float>& b) {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += (static_cast<double>(a[i]) - static_cast<double>(b[i])) * (static_cast<double>(a[i]) - static_cast<double>(b[i]));
  return std::sqrt(s);
}

}  // namespace

TEST_CASE("Robot mapper descriptor input: levelling by the odometry's gravity removes the sensor's roll and pitch") {
  const std::vector<Eigen::Vector3d> place = DescriptorTestPlace();
  Eigen::Isometry3d T_level = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_tilted = Eigen::Isometry3d::Identity();
  T_tilted.linear() = (Eigen::AngleAxisd(8.0 * kDegToRad, Eigen::Vector3d::UnitX()) *
                       Eigen::AngleAxisd(4.0 * kDegToRad, Eigen::Vector3d::UnitY()))
                          .toRotationMatrix();
  DescriptorInputParams level;
  level.level = true;
  MapperFixture a(level), b(level), raw_a(DescriptorInputParams{}), raw_b(DescriptorInputParams{});
  const std::vector<float> da = a.Add(SeenFrom(place, T_level), T_level);
  const std::vector<float> db = b.Add(SeenFrom(place, T_tilted), T_tilted);
  const std::vector<float> ra = raw_a.Add(SeenFrom(place, T_level), T_level);
  const std::vector<float> rb = raw_b.Add(SeenFrom(place, T_tilted), T_tilted);
  MESSAGE("levelled: " << L2(da, db) << ", raw: " << L2(ra, rb));
  CHECK(L2(da, db) < 0.02);
  CHECK(L2(ra, rb) > 0.1);  // the tilt does change the raw scan's descriptor (the test can fail)
  CHECK(L2(da, ra) < 1e-6);  // an untilted sensor: levelling changes nothing
  // The id tells the inputs apart; with both options off it is the descriptor's own.
  CHECK(raw_a.mapper->descriptor_parameter_id() == raw_a.ring.parameter_id());
  CHECK(a.mapper->descriptor_parameter_id() != raw_a.ring.parameter_id());
}

TEST_CASE("Robot mapper descriptor input: an odometry frame that leans (a handheld sensor's first pose) is levelled by its ground") {
  // Two robots drive the same three poses 1 m apart. Robot A's sensor is level and its odometry frame too.
  // Robot B's sensor is held pitched and rolled by (8, 4) deg all along, and its odometry frame is its first
  // keyframe's sensor frame, so the odometry believes the sensor level: levelling by the frame's z leaves the
  // lean in, levelling by the ground removes it.
  const std::vector<Eigen::Vector3d> place = DescriptorTestPlace();
  const Eigen::Matrix3d R_hold = (Eigen::AngleAxisd(8.0 * kDegToRad, Eigen::Vector3d::UnitY()) *
                                  Eigen::AngleAxisd(4.0 * kDegToRad, Eigen::Vector3d::UnitX()))
                                     .toRotationMatrix();
  DescriptorInputParams by_ground;
  by_ground.level = true;
  DescriptorInputParams by_frame = by_ground;
  by_frame.ground_up.min_frame_tilt_deg = 0.0;
  MapperFixture a(by_ground), b(by_ground), b_frame(by_frame), a_frame(by_frame);
  Eigen::Isometry3d T_world_b0 = Eigen::Isometry3d::Identity();
  T_world_b0.linear() = R_hold;
  for (int k = 0; k < 3; ++k) {
    Eigen::Isometry3d T_world_a = Eigen::Isometry3d::Identity();
    T_world_a.translation() = Eigen::Vector3d(k * 1.0, 0.0, 0.0);
    Eigen::Isometry3d T_world_b = T_world_a;
    T_world_b.linear() = R_hold;
    const Eigen::Isometry3d T_odom_b = T_world_b0.inverse() * T_world_b;
    const std::vector<float> da = a.Add(SeenFrom(place, T_world_a), T_world_a);
    const std::vector<float> da_frame = a_frame.Add(SeenFrom(place, T_world_a), T_world_a);
    const std::vector<float> db = b.Add(SeenFrom(place, T_world_b), T_odom_b);
    const std::vector<float> db_frame = b_frame.Add(SeenFrom(place, T_world_b), T_odom_b);
    MESSAGE("keyframe " << k << ": by the ground " << L2(da, db) << ", by the frame " << L2(da, db_frame));
    CHECK(L2(da, db) < 0.02);
    CHECK(L2(da, db_frame) > 0.1);  // the lean does change the descriptor when only the frame levels it
    CHECK(L2(da, da_frame) == 0.0);  // a level frame levels exactly as before
  }
  // Up from the ground: the hold, as B's frame sees it (8.9 deg from its z), and nothing on A's.
  const double hold_deg = std::acos((R_hold.transpose() * Eigen::Vector3d::UnitZ()).z()) / kDegToRad;
  CHECK(b.mapper->ground_up().tilt_deg() == doctest::Approx(hold_deg).epsilon(0.01));
  CHECK(b.mapper->levels_by_ground());
  CHECK(a.mapper->ground_up().tilt_deg() < 0.01);
  CHECK_FALSE(a.mapper->levels_by_ground());
  CHECK_FALSE(b_frame.mapper->levels_by_ground());
  CHECK(a.mapper->descriptor_parameter_id() != a_frame.mapper->descriptor_parameter_id());
}

TEST_CASE("Robot mapper descriptor input: a forward-looking sensor's local map keeps what it passed") {
  // A 70 deg cone drives 5 m along x in 1 m keyframes past two poles at (8, +-4) m, then sees them at 53 deg,
  // outside its cone. Ground everywhere, a wall ahead at x = 30 m. With a 5 m local map the last keyframe's
  // descriptor holds the poles (ring 1: 5-10 m, bands 0.3-4 m above the ground), as the 360 deg view from that
  // pose does; the cone's own scan does not.
  std::vector<Eigen::Vector3d> place;
  for (double x = -10.0; x < 40.0; x += 1.3) {
    for (double y = -20.0; y < 20.0; y += 1.3) place.emplace_back(x, y, -1.7);
  }
  for (double y = -15.0; y < 15.0; y += 0.5) place.emplace_back(30.0, y, 0.0);
  for (double h = -1.1; h < 2.0; h += 0.6) {
    place.emplace_back(8.0, 4.0, h);
    place.emplace_back(8.0, -4.0, h);
  }
  DescriptorInputParams windowed;
  windowed.local_map_window_m = 5.0;
  MapperFixture local(windowed), single(DescriptorInputParams{}), full(DescriptorInputParams{});
  std::vector<float> d_local, d_single;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int k = 0; k <= 5; ++k) {
    T.translation() = Eigen::Vector3d(k, 0.0, 0.0);
    d_local = local.Add(SeenFrom(place, T, 35.0), T);
    d_single = single.Add(SeenFrom(place, T, 35.0), T);
  }
  const std::vector<float> d_full = full.Add(SeenFrom(place, T), T);
  for (std::size_t band = 0; band < 3; ++band) {  // 0.3-1, 1-2, 2-4 m above the ground
    const std::size_t cell = 1 * 5 + band;        // ring 1
    CAPTURE(band);
    CHECK(d_full[cell] > 0.0f);
    CHECK(d_local[cell] > 0.0f);
    CHECK(d_single[cell] == 0.0f);
  }
  // Keyframes that left the window are dropped: at 10 m of path only the keyframes from 5 m on are joined, none
  // of which saw the poles (now 4.5 m away beside and behind the sensor): rings 0 and 1 hold nothing above the
  // ground again.
  for (int k = 6; k <= 10; ++k) {
    T.translation() = Eigen::Vector3d(k, 0.0, 0.0);
    d_local = local.Add(SeenFrom(place, T, 35.0), T);
  }
  for (std::size_t band = 0; band < 3; ++band) {
    CHECK(d_local[0 * 5 + band] == 0.0f);
    CHECK(d_local[1 * 5 + band] == 0.0f);
  }
}

TEST_CASE("Robot mapper descriptor input: the local map stays within the raw-scan work budget") {
  // Scans of about 1 250 points against a raw-scan capacity of 1 300: the local map keeps at most one raw scan
  // of points (older keyframes are dropped first), and the whole scan workspace, with the scene-scaled stored
  // voxels on, stays within the budget's kRawPointWorkBytes per raw point (core/memory/budget.hpp).
  const std::vector<Eigen::Vector3d> place = DescriptorTestPlace();
  std::size_t largest = 0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int k = 0; k <= 10; ++k) {
    T.translation() = Eigen::Vector3d(0.5 * k, 0.0, 0.0);
    largest = std::max(largest, SeenFrom(place, T).size());
  }
  const std::size_t capacity = largest + 50;
  DescriptorInputParams windowed;
  windowed.level = true;
  windowed.local_map_window_m = 10.0;
  windowed.voxel_m = 0.05;  // fine voxels: the kept keyframes hold nearly all their points
  MapperFixture local(windowed, capacity, /*min_stored_points=*/1000);
  for (int k = 0; k <= 10; ++k) {
    T.translation() = Eigen::Vector3d(k, 0.0, 0.0);
    local.Add(SeenFrom(place, T), T);
  }
  const std::size_t budget = capacity * static_cast<std::size_t>(BudgetRecordSizes::kRawPointWorkBytes);
  MESSAGE("scan workspace " << local.mapper->scan_workspace_bytes() << " B, budget " << budget << " B");
  CHECK(local.mapper->scan_workspace_bytes() <= budget);
}

namespace {

// A 6 x 4 x 2.5 m room around the sensor (walls, floor, ceiling; a point every 0.1 m), sensor frame.
std::vector<PointXYZI> SmallRoomScan() {
  std::vector<PointXYZI> scan;
  auto add = [&scan](double x, double y, double z) {
    scan.push_back({static_cast<float>(x), static_cast<float>(y), static_cast<float>(z), 1.0f});
  };
  for (double a = -3.0; a < 3.0; a += 0.1) {
    for (double h = -1.2; h < 1.3; h += 0.1) {
      add(a + 0.01, -1.99, h);
      add(a + 0.01, 1.99, h);
    }
  }
  for (double b = -2.0; b < 2.0; b += 0.1) {
    for (double h = -1.2; h < 1.3; h += 0.1) {
      add(-2.99, b + 0.01, h);
      add(2.99, b + 0.01, h);
    }
  }
  for (double a = -3.0; a < 3.0; a += 0.1) {
    for (double b = -2.0; b < 2.0; b += 0.1) {
      add(a + 0.01, b + 0.01, -1.21);
      add(a + 0.01, b + 0.01, 1.29);
    }
  }
  return scan;
}

// The ladder's first size (1 m / sqrt(2)^k, down to 0.25 m) at which the plain voxel grid keeps min_points.
double FirstSizeWith(const std::vector<PointXYZI>& scan, std::size_t min_points) {
  std::vector<PointXYZI> out;
  for (int k = 0;; ++k) {
    const double v = std::pow(0.5, 0.5 * k);
    if (v < 0.25 - 1e-9) return std::pow(0.5, 0.5 * (k - 1));
    REQUIRE(VoxelDownsample(Span<const PointXYZI>(scan), VoxelGridParams{v}, &out).ok());
    if (out.size() >= min_points) return v;
  }
}

}  // namespace

TEST_CASE("Robot mapper stores a small room's scan finer than 1 m when asked, a street-sized scan at 1 m") {
  const std::vector<PointXYZI> room = SmallRoomScan();
  const std::vector<PointXYZI> street = SeenFrom(DescriptorTestPlace(), Eigen::Isometry3d::Identity());
  std::vector<PointXYZI> at_1m, stored;
  REQUIRE(VoxelDownsample(Span<const PointXYZI>(room), VoxelGridParams{1.0}, &at_1m).ok());
  const std::size_t room_at_1m = at_1m.size();
  REQUIRE(VoxelDownsample(Span<const PointXYZI>(street), VoxelGridParams{1.0}, &at_1m).ok());
  const std::size_t street_at_1m = at_1m.size();
  MESSAGE("room " << room_at_1m << " points at 1 m, street " << street_at_1m);
  REQUIRE(room_at_1m < 1000);
  REQUIRE(street_at_1m >= 1000);
  for (std::size_t min_points : {std::size_t{0}, std::size_t{1000}}) {
    CAPTURE(min_points);
    MapperFixture f(DescriptorInputParams{}, 20000, min_points);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    auto room_step = f.mapper->AddScan(Span<const PointXYZI>(room), T);
    T.translation().x() = 5.0;
    auto street_step = f.mapper->AddScan(Span<const PointXYZI>(street), T);
    REQUIRE(room_step.ok());
    REQUIRE(street_step.ok());
    REQUIRE(room_step->store_status.ok());
    REQUIRE(street_step->store_status.ok());
    const double want_room = min_points == 0 ? 1.0 : FirstSizeWith(room, min_points);
    CHECK(room_step->voxel_size_m == doctest::Approx(want_room));
    CHECK(street_step->voxel_size_m == 1.0);
    // What the store holds is the plain voxel grid at that size.
    std::vector<PointXYZI> want;
    REQUIRE(VoxelDownsample(Span<const PointXYZI>(room), VoxelGridParams{want_room}, &want).ok());
    auto got = f.store->GetPoints(room_step->keyframe, &stored);
    REQUIRE(got.ok());
    CHECK(stored.size() == want.size());
    CHECK(room_step->voxel_points == want.size());
    CHECK(f.mapper->stats().scans_stored_finer == (min_points == 0 ? 0u : 1u));
  }
}
