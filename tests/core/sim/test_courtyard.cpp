// SPDX-License-Identifier: BSD-3-Clause
// The courtyard (core/sim/courtyard.hpp): where each overlap mode puts the walks, the handheld attitude stays
// within its model, the walks stay inside the courtyard, the facades close it, and planning is deterministic.
#include <doctest/doctest.h>

#include <cmath>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/sim/courtyard.hpp"
#include "core/sim/multi_robot_mission.hpp"
#include "core/sim/procedural_world.hpp"

using namespace commerge;

namespace courtyard_test {

MissionPlan PlanCourtyard(OverlapMode overlap, std::uint64_t seed, bool same_direction = false, int keyframes = 32) {
  MissionParams p;
  p.world = WorldKind::kCourtyard;
  p.overlap = overlap;
  p.robots = 2;
  p.keyframes_per_robot = keyframes;
  p.seed = seed;
  p.same_direction = same_direction;
  auto plan = PlanMission(p);
  REQUIRE(plan.ok());
  return std::move(plan).value();
}

Eigen::Vector3d At(const MissionPlan& plan, int robot, std::size_t k) {
  return plan.robots[static_cast<std::size_t>(robot)].T_gt_sensor(k).translation();
}

double Horizontal(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return (a - b).head<2>().norm(); }

}  // namespace courtyard_test

using namespace courtyard_test;

TEST_CASE("sim courtyard: partial walks meet where one ends and the next starts, moderate and complete overlap more") {
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const MissionPlan partial = PlanCourtyard(OverlapMode::kPartial, seed);
    const std::size_t last = partial.robots[0].gt.size() - 1;
    // The carriers wander up to 0.7 m off the loop each.
    CHECK(Horizontal(At(partial, 0, last), At(partial, 1, 0)) < 1.5);
    CHECK(Horizontal(At(partial, 0, 0), At(partial, 1, last)) > 10.0);
    const MissionPlan moderate = PlanCourtyard(OverlapMode::kModerate, seed);
    CHECK(Horizontal(At(moderate, 0, last / 2), At(moderate, 1, 0)) < 1.5);
    // Complete, alternating: robot 1 walks robot 0's stretch backwards.
    const MissionPlan complete = PlanCourtyard(OverlapMode::kComplete, seed);
    CHECK(Horizontal(At(complete, 0, last), At(complete, 1, 0)) < 1.5);
    CHECK(Horizontal(At(complete, 0, 0), At(complete, 1, last)) < 1.5);
    const MissionPlan same = PlanCourtyard(OverlapMode::kComplete, seed, true);
    CHECK(Horizontal(At(same, 0, 0), At(same, 1, 0)) < 1.5);
  }
}

TEST_CASE("sim courtyard: the walks stay inside, keyframes about 1 m apart, the sensor handheld within its attitude model") {
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    MissionParams p;
    p.world = WorldKind::kCourtyard;
    p.seed = seed;
    const CourtyardGeometry g = CourtyardOf(p);
    CHECK(g.width_m >= 18.0);
    CHECK(g.width_m <= 26.0);
    CHECK(g.length_m >= 36.0);
    CHECK(g.length_m <= 50.0);
    // 200 keyframes: longer than the loop, the walks wrap around it.
    const MissionPlan plan = PlanCourtyard(OverlapMode::kPartial, seed, false, 200);
    const double max_tilt_deg = kHandheldHoldPitchDeg + kHandheldTiltDeg + plan.params.roll_pitch_wobble_deg;
    for (const RobotMission& r : plan.robots) {
      REQUIRE(r.gt.size() == 200);
      REQUIRE(r.odometry.size() == 200);
      for (std::size_t k = 0; k < r.gt.size(); ++k) {
        const Eigen::Isometry3d T = r.T_gt_sensor(k);
        CHECK(std::abs(T.translation().x()) < 0.5 * g.width_m - 2.0);
        CHECK(std::abs(T.translation().y()) < 0.5 * g.length_m - 2.0);
        CHECK(std::abs(T.translation().z() - kHandheldSensorHeightM) < 0.05);
        const double tilt_deg = std::acos((T.linear() * Eigen::Vector3d::UnitZ()).z()) / kDegToRad;
        CHECK(tilt_deg < max_tilt_deg);
        if (k > 0) {
          const double step = (T.translation() - r.T_gt_sensor(k - 1).translation()).norm();
          CHECK(step > 0.5);
          CHECK(step < 1.5);
        }
      }
      CHECK(r.gt[0].isApprox(Eigen::Isometry3d::Identity()));
    }
  }
}

TEST_CASE("sim courtyard: facades close it: level rays from a keyframe return within the courtyard's diagonal") {
  const MissionPlan plan = PlanCourtyard(OverlapMode::kPartial, 3);
  auto world = BuildMissionWorld(plan);
  REQUIRE(world.ok());
  const CourtyardGeometry g = CourtyardOf(plan.params);
  const double diagonal = std::hypot(g.width_m, g.length_m);
  RayWorkspace ws;
  for (std::size_t k : {std::size_t{0}, std::size_t{15}, std::size_t{31}}) {
    const Eigen::Vector3d o = At(plan, 0, k);
    const float origin[3] = {static_cast<float>(o.x()), static_cast<float>(o.y()), static_cast<float>(o.z())};
    int hits = 0, rays = 0;
    for (int a = 0; a < 360; a += 2, ++rays) {
      const float dir[3] = {static_cast<float>(std::cos(a * kDegToRad)), static_cast<float>(std::sin(a * kDegToRad)), 0.0f};
      RayHit hit;
      if (world->CastRay(origin, dir, 0.3f, 100.0f, &ws, &hit) && static_cast<double>(hit.range_m) < diagonal) ++hits;
    }
    // Only the passage (3.5 m wide) lets level rays out.
    CHECK(hits >= rays * 9 / 10);
  }
}

TEST_CASE("sim courtyard: the same params plan the same walks, another seed another courtyard, a wrong world is refused") {
  const MissionPlan a = PlanCourtyard(OverlapMode::kModerate, 7), b = PlanCourtyard(OverlapMode::kModerate, 7);
  const MissionPlan c = PlanCourtyard(OverlapMode::kModerate, 8);
  for (std::size_t k = 0; k < a.robots[1].gt.size(); ++k) {
    CHECK(a.robots[1].T_gt_sensor(k).matrix() == b.robots[1].T_gt_sensor(k).matrix());
    CHECK(a.robots[1].odometry[k].matrix() == b.robots[1].odometry[k].matrix());
  }
  CHECK_FALSE(At(a, 1, 5).isApprox(At(c, 1, 5)));
  MissionParams urban;
  CHECK_FALSE(PlanCourtyardMission(urban).ok());
  CHECK(*WorldKindFromName("Courtyard") == WorldKind::kCourtyard);
  CHECK(std::string(WorldKindName(WorldKind::kCourtyard)) == "courtyard");
}
