// SPDX-License-Identifier: BSD-3-Clause
// Multi-robot missions (core/sim/multi_robot_mission.hpp): keyframe spacing and frame conventions, the
// overlap of the routes per mode (measured from the ground truth in the ground-truth frame gt), opposite-direction
// revisits, the odometry drift model recovered from the poses, determinism and validation.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/sim/multi_robot_mission.hpp"

namespace commerge {
namespace {

MissionPlan PlanFleet(WorldKind world, OverlapMode overlap, int robots, int keyframes, std::uint64_t seed = 3,
                 double drift = 1.0) {
  MissionParams p;
  p.world = world;
  p.overlap = overlap;
  p.robots = robots;
  p.keyframes_per_robot = keyframes;
  p.seed = seed;
  p.drift.scale = drift;
  auto plan = PlanMission(p);
  REQUIRE_MESSAGE(plan.ok(), plan.status().ToString());
  return std::move(plan).value();
}

TEST_CASE("sim mission: keyframes 1 m apart, gt and odometry start at identity, sensor x along the motion") {
  for (WorldKind world : {WorldKind::kUrban, WorldKind::kCampus, WorldKind::kIndoor, WorldKind::kCave}) {
    const std::string world_name = WorldKindName(world);
    CAPTURE(world_name);
    const MissionPlan plan = PlanFleet(world, OverlapMode::kModerate, 3, 600);
    REQUIRE(plan.robots.size() == 3);
    for (const RobotMission& r : plan.robots) {
      REQUIRE(r.gt.size() == 600);
      REQUIRE(r.odometry.size() == 600);
      REQUIRE(r.times_s.size() == 600);
      CHECK(r.gt[0].isApprox(Eigen::Isometry3d::Identity(), 1e-12));
      CHECK(r.odometry[0].isApprox(Eigen::Isometry3d::Identity(), 1e-12));
      CHECK(r.times_s[0] == 0.0);
      std::size_t forward = 0, straight = 0;
      for (std::size_t k = 1; k < r.gt.size(); ++k) {
        // 1 m of travel along the path: the chord is 1 m, shorter only in turns (U-turns: ~0.3 m).
        const double step = (r.gt[k].translation() - r.gt[k - 1].translation()).norm();
        CHECK(step <= 1.0 + 1e-9);
        CHECK(step > 0.25);
        straight += step > 0.95;
        CHECK(r.times_s[k] > r.times_s[k - 1]);
        // The motion expressed in the previous sensor frame points along its x axis.
        const Eigen::Vector3d motion = r.gt[k - 1].inverse() * r.gt[k].translation();
        forward += motion.x() > 0.9 * motion.norm();
        // Height in gt = the sensor's mounting height on flat ground.
        CHECK(r.T_gt_sensor(k).translation().z() == doctest::Approx(plan.sensor_height_m));
      }
      CHECK(static_cast<double>(forward) >= 0.97 * static_cast<double>(r.gt.size() - 1));
      CHECK(static_cast<double>(straight) >= 0.97 * static_cast<double>(r.gt.size() - 1));
    }
    // Each robot starts somewhere else (its own, unknown start frame).
    for (std::size_t i = 0; i < plan.robots.size(); ++i)
      for (std::size_t j = i + 1; j < plan.robots.size(); ++j)
        CHECK(!plan.robots[i].T_gt_robotstart.isApprox(plan.robots[j].T_gt_robotstart, 1e-3));
  }
}

TEST_CASE("sim mission: routes overlap as configured, measured from the ground truth in the frame gt") {
  for (WorldKind world : {WorldKind::kUrban, WorldKind::kCampus, WorldKind::kIndoor, WorldKind::kCave}) {
    for (int robots : {2, 5}) {
      const std::string world_name = WorldKindName(world);
      CAPTURE(world_name);
      CAPTURE(robots);
      const MissionPlan complete = PlanFleet(world, OverlapMode::kComplete, robots, 1200);
      const OverlapReport c = MeasureOverlap(complete, 6.0);
      for (int i = 0; i < robots; ++i)
        for (int j = 0; j < robots; ++j) CHECK(c.fraction[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] >= 0.9);

      const MissionPlan moderate = PlanFleet(world, OverlapMode::kModerate, robots, 1200);
      const OverlapReport m = MeasureOverlap(moderate, 6.0);
      for (int i = 0; i < robots; ++i) {
        CHECK(m.any[static_cast<std::size_t>(i)] >= 0.3);
        CHECK(m.any[static_cast<std::size_t>(i)] <= 0.75);
        for (int j = 0; j < robots; ++j) CHECK(m.fraction[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] >= 0.3);
      }

      const MissionPlan partial = PlanFleet(world, OverlapMode::kPartial, robots, 1200);
      const OverlapReport p = MeasureOverlap(partial, 6.0);
      for (int i = 0; i < robots; ++i) {
        CHECK(p.any[static_cast<std::size_t>(i)] >= 0.05);
        CHECK(p.any[static_cast<std::size_t>(i)] <= 0.35);
      }
      // The shared-tour flags agree with the measured overlap.
      for (const RobotMission& r : moderate.robots) {
        double shared = 0;
        for (std::uint8_t s : r.on_shared_tour) shared += s;
        CHECK(shared / static_cast<double>(r.on_shared_tour.size()) ==
              doctest::Approx(m.any[static_cast<std::size_t>(r.id)]).epsilon(0.15));
      }
    }
  }
}

TEST_CASE("sim mission: shared places are revisited by another robot in the opposite direction") {
  const MissionPlan plan = PlanFleet(WorldKind::kUrban, OverlapMode::kComplete, 2, 800);
  std::size_t same = 0, opposite = 0;
  const RobotMission &a = plan.robots[0], &b = plan.robots[1];
  for (std::size_t i = 0; i < a.gt.size(); i += 5) {
    const Eigen::Isometry3d Ta = a.T_gt_sensor(i);
    for (std::size_t j = 0; j < b.gt.size(); ++j) {
      const Eigen::Isometry3d Tb = b.T_gt_sensor(j);
      if ((Ta.translation() - Tb.translation()).head<2>().norm() > 5.0) continue;
      const double dyaw = std::fabs(std::remainder(YawRad(Ta.linear()) - YawRad(Tb.linear()), 2 * kPi));
      same += dyaw < 30 * kDegToRad;
      opposite += dyaw > 150 * kDegToRad;
    }
  }
  CHECK(opposite > 50);
  // Robot 1 drives the tour backwards: the same direction only where routes cross.
  CHECK(opposite > same);
}

TEST_CASE("sim mission: odometry deviates from the ground truth exactly by the configured drift model") {
  const MissionPlan plan = PlanFleet(WorldKind::kCampus, OverlapMode::kModerate, 2, 3000, 11);
  const DriftParams d = plan.params.drift;
  for (const RobotMission& r : plan.robots) {
    double num = 0, den = 0;
    std::vector<Eigen::Vector3d> dt_gt, dt_odo;
    std::vector<Eigen::Vector3d> rot_err;
    std::vector<double> steps;
    for (std::size_t k = 1; k < r.gt.size(); ++k) {
      const Eigen::Isometry3d dT = r.gt[k - 1].inverse() * r.gt[k];
      const Eigen::Isometry3d dO = r.odometry[k - 1].inverse() * r.odometry[k];
      dt_gt.push_back(dT.translation());
      dt_odo.push_back(dO.translation());
      rot_err.push_back(LogSO3(dT.linear().transpose() * dO.linear()));
      steps.push_back(dT.translation().norm());
      num += (dO.translation() - dT.translation()).dot(dT.translation());
      den += dT.translation().squaredNorm();
      // Consecutive relative motions stay close: centimetres and hundredths of a degree per metre.
      CHECK((dO.translation() - dT.translation()).norm() < 0.05);
      CHECK(RotationAngleRad(dT.linear().transpose() * dO.linear()) < 0.1 * kDegToRad);
    }
    const double n = static_cast<double>(steps.size());
    // Scale bias recovered by least squares, within 4 sigma of its estimate.
    const double scale_hat = num / den;
    CHECK(std::fabs(scale_hat - r.scale_bias) < 4 * d.translation_noise_frac / std::sqrt(n));
    // Translation noise (lateral axis y, x also carries the bias), yaw bias and noise, roll noise.
    double sy = 0, sy2 = 0, yaw = 0, yaw2 = 0, roll2 = 0;
    for (std::size_t k = 0; k < steps.size(); ++k) {
      const Eigen::Vector3d e_t = dt_odo[k] - (1.0 + r.scale_bias) * dt_gt[k];
      sy += e_t.y() / steps[k];
      sy2 += (e_t.y() / steps[k]) * (e_t.y() / steps[k]);
      const double e_yaw = rot_err[k].z() - r.yaw_bias_rad_per_m * steps[k];
      yaw += e_yaw / std::sqrt(steps[k]);
      yaw2 += e_yaw * e_yaw / steps[k];
      roll2 += rot_err[k].x() * rot_err[k].x() / steps[k];
    }
    CHECK(std::sqrt(sy2 / n) == doctest::Approx(d.translation_noise_frac).epsilon(0.08));
    CHECK(std::fabs(sy / n) < 4 * d.translation_noise_frac / std::sqrt(n));
    CHECK(std::sqrt(yaw2 / n) == doctest::Approx(d.yaw_noise_deg_per_sqrt_m * kDegToRad).epsilon(0.08));
    CHECK(std::fabs(yaw / n) < 4 * d.yaw_noise_deg_per_sqrt_m * kDegToRad / std::sqrt(n));
    CHECK(std::sqrt(roll2 / n) == doctest::Approx(d.roll_pitch_noise_deg_per_sqrt_m * kDegToRad).epsilon(0.08));
    // The drawn biases are plausible draws of the configured spreads.
    CHECK(std::fabs(r.scale_bias) < 4 * d.scale_bias_std);
    CHECK(std::fabs(r.yaw_bias_rad_per_m) < 4 * d.yaw_bias_std_deg_per_m * kDegToRad);
    // Drift accumulates: the end point is off by more than the per-step noise.
    CHECK((r.odometry.back().translation() - r.gt.back().translation()).norm() > 0.5);
  }
}

TEST_CASE("sim mission: drift scale 0 gives perfect odometry, scale 2 about twice the end error of scale 1") {
  const MissionPlan perfect = PlanFleet(WorldKind::kUrban, OverlapMode::kPartial, 2, 1500, 5, 0.0);
  for (const RobotMission& r : perfect.robots)
    for (std::size_t k = 0; k < r.gt.size(); ++k) REQUIRE(r.odometry[k].isApprox(r.gt[k], 1e-9));
  const MissionPlan one = PlanFleet(WorldKind::kUrban, OverlapMode::kPartial, 2, 1500, 5, 1.0);
  const MissionPlan two = PlanFleet(WorldKind::kUrban, OverlapMode::kPartial, 2, 1500, 5, 2.0);
  for (std::size_t r = 0; r < 2; ++r) {
    const double e1 = (one.robots[r].odometry.back().translation() - one.robots[r].gt.back().translation()).norm();
    const double e2 = (two.robots[r].odometry.back().translation() - two.robots[r].gt.back().translation()).norm();
    CHECK(e2 / e1 == doctest::Approx(2.0).epsilon(0.25));
    // The ground truth does not depend on the drift.
    CHECK(one.robots[r].gt.back().isApprox(two.robots[r].gt.back(), 1e-12));
  }
}

TEST_CASE("sim mission: deterministic in the seed") {
  const MissionPlan a = PlanFleet(WorldKind::kCave, OverlapMode::kModerate, 3, 500, 21);
  const MissionPlan b = PlanFleet(WorldKind::kCave, OverlapMode::kModerate, 3, 500, 21);
  const MissionPlan c = PlanFleet(WorldKind::kCave, OverlapMode::kModerate, 3, 500, 22);
  for (std::size_t r = 0; r < 3; ++r) {
    CHECK(a.robots[r].route_nodes == b.robots[r].route_nodes);
    for (std::size_t k = 0; k < 500; ++k) {
      REQUIRE(a.robots[r].gt[k].matrix() == b.robots[r].gt[k].matrix());
      REQUIRE(a.robots[r].odometry[k].matrix() == b.robots[r].odometry[k].matrix());
    }
    CHECK(a.robots[r].T_gt_robotstart.matrix() == b.robots[r].T_gt_robotstart.matrix());
    CHECK(a.robots[r].T_gt_robotstart.matrix() != c.robots[r].T_gt_robotstart.matrix());
  }
  CHECK(ScanNoiseSeed(a.params, 0, 3) != ScanNoiseSeed(a.params, 1, 3));
  CHECK(ScanNoiseSeed(a.params, 0, 3) != ScanNoiseSeed(a.params, 0, 4));
}

TEST_CASE("sim mission: validation names the bad field") {
  MissionParams p;
  p.robots = 1;
  CHECK(PlanMission(p).status().message().find("robots") != std::string::npos);
  p.robots = 6;
  CHECK(!PlanMission(p).ok());
  p.robots = 2;
  p.keyframes_per_robot = 1;
  CHECK(PlanMission(p).status().message().find("keyframes") != std::string::npos);
  p.keyframes_per_robot = 10;
  p.drift.scale = -1;
  CHECK(PlanMission(p).status().message().find("drift") != std::string::npos);
  CHECK(*WorldKindFromName("Cave") == WorldKind::kCave);
  CHECK(!WorldKindFromName("forest").ok());
  CHECK(*OverlapModeFromName("partial") == OverlapMode::kPartial);
  CHECK(OverlapModeFromName("half").status().message().find("complete, moderate, partial") != std::string::npos);
}

}  // namespace
}  // namespace commerge
