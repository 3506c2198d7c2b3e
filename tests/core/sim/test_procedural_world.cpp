// SPDX-License-Identifier: BSD-3-Clause
// Procedural worlds (core/sim/procedural_world.hpp): what each world contains, the driving corridor is free
// at every keyframe (no robot inside a wall, a car or the rock), scans see the world, place recognition with
// SOLiD on 16-beam scans works across robots, and generation is deterministic.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/geometry/angles.hpp"
#include "core/sim/lidar_models.hpp"
#include "core/sim/multi_robot_mission.hpp"
#include "core/sim/procedural_world.hpp"

namespace commerge {
namespace {

MissionPlan Plan(WorldKind world, OverlapMode overlap, int keyframes, std::uint64_t seed = 4) {
  MissionParams p;
  p.world = world;
  p.overlap = overlap;
  p.robots = 2;
  p.keyframes_per_robot = keyframes;
  p.seed = seed;
  auto plan = PlanMission(p);
  REQUIRE(plan.ok());
  return std::move(plan).value();
}

TEST_CASE("sim worlds: each kind holds its own primitives") {
  const World urban = *BuildMissionWorld(Plan(WorldKind::kUrban, OverlapMode::kModerate, 300));
  CHECK(urban.boxes().size() > 100);      // buildings, cars
  CHECK(urban.cylinders().size() > 50);   // poles, trunks
  CHECK(!urban.has_ceiling());
  const World campus = *BuildMissionWorld(Plan(WorldKind::kCampus, OverlapMode::kModerate, 300));
  CHECK(campus.spheres().size() > 3 * campus.boxes().size());  // mostly trees
  const World indoor = *BuildMissionWorld(Plan(WorldKind::kIndoor, OverlapMode::kModerate, 300));
  CHECK(indoor.has_ceiling());
  CHECK(indoor.ceiling_z_m() == kIndoorCeilingM);
  CHECK(indoor.boxes().size() > 500);  // walls, doors, rooms
  const World cave = *BuildMissionWorld(Plan(WorldKind::kCave, OverlapMode::kModerate, 300));
  CHECK(cave.tunnel_segments().size() > 50);
  CHECK(cave.boxes().empty());
}

TEST_CASE("sim worlds: the driving corridor is free at every keyframe (nothing within 0.5 m of the sensor)") {
  for (WorldKind kind : {WorldKind::kUrban, WorldKind::kCampus, WorldKind::kIndoor, WorldKind::kCave}) {
    const std::string name = WorldKindName(kind);
    CAPTURE(name);
    const MissionPlan plan = Plan(kind, OverlapMode::kPartial, 400);
    const auto world = BuildMissionWorld(plan);
    REQUIRE(world.ok());
    RayWorkspace ws;
    double nearest = 1e9;
    for (const RobotMission& r : plan.robots) {
      for (std::size_t k = 0; k < r.gt.size(); k += 3) {
        const Eigen::Vector3d p = r.T_gt_sensor(k).translation();
        const float o[3] = {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
        if (kind == WorldKind::kCave) CHECK(world->TunnelSignedDistance(o) < -0.5f);  // inside the tunnel
        for (int a = 0; a < 24; ++a) {
          for (double el : {-0.25, 0.0, 0.3}) {
            const double az = 2 * kPi * a / 24;
            const float d[3] = {static_cast<float>(std::cos(el) * std::cos(az)), static_cast<float>(std::cos(el) * std::sin(az)),
                                static_cast<float>(std::sin(el))};
            RayHit hit;
            if (world->CastRay(o, d, 0.0f, 3.0f, &ws, &hit)) nearest = std::min(nearest, static_cast<double>(hit.range_m));
          }
        }
      }
    }
    CHECK(nearest > 0.5);
  }
}

TEST_CASE("sim worlds: 16-beam scans see the world (returns on most rays in closed worlds)") {
  LidarModel lidar = MakeLidarModel(LidarKind::kVlp16);
  lidar.azimuth_steps = 180;
  for (WorldKind kind : {WorldKind::kUrban, WorldKind::kCampus, WorldKind::kIndoor, WorldKind::kCave}) {
    const std::string name = WorldKindName(kind);
    CAPTURE(name);
    const MissionPlan plan = Plan(kind, OverlapMode::kModerate, 200);
    const World world = *BuildMissionWorld(plan);
    LidarScanWorkspace ws;
    std::vector<PointXYZI> scan;
    double fraction = 0;
    for (std::size_t k = 0; k < 200; k += 40) {
      REQUIRE(SimulateLidarScan(world, lidar, plan.robots[0].T_gt_sensor(k), 1, k, &ws, &scan).ok());
      fraction += static_cast<double>(scan.size()) / lidar.rays_per_frame() / 5.0;
      for (const PointXYZI& p : scan) REQUIRE(p.intensity >= 0.0f);
    }
    // Closed worlds return (almost) every ray; outdoors the upper beams see the sky between buildings / trees.
    CHECK(fraction > (kind == WorldKind::kIndoor || kind == WorldKind::kCave ? 0.97 : 0.5));
  }
}

TEST_CASE("sim worlds: SOLiD on 16-beam scans recognises places another robot visited") {
  // Complete overlap: robot 1 drives robot 0's tour backwards. For robot-0 queries, the nearest robot-1 scan
  // in R-SOLiD distance must mostly be a scan taken near the same place.
  const MissionPlan plan = Plan(WorldKind::kUrban, OverlapMode::kComplete, 300, 8);
  const World world = *BuildMissionWorld(plan);
  LidarModel lidar = MakeLidarModel(LidarKind::kVlp16);
  lidar.azimuth_steps = 450;
  auto solid = SolidDescriptor::Create(SolidPreset(LidarSensor::kVelodyneVlp16));
  REQUIRE(solid.ok());
  LidarScanWorkspace ws;
  std::vector<PointXYZI> scan;
  auto describe = [&](int r, std::size_t k) {
    REQUIRE(SimulateLidarScan(world, lidar, plan.robots[static_cast<std::size_t>(r)].T_gt_sensor(k),
                              ScanNoiseSeed(plan.params, r, k), k, &ws, &scan).ok());
    std::vector<float> d(solid->dimension());
    REQUIRE(solid->Compute(scan, d).ok());
    return d;
  };
  std::vector<std::vector<float>> db;
  std::vector<Eigen::Vector3d> db_pos;
  for (std::size_t k = 0; k < 300; k += 3) {
    db.push_back(describe(1, k));
    db_pos.push_back(plan.robots[1].T_gt_sensor(k).translation());
  }
  int queries = 0, recognised = 0;
  for (std::size_t k = 5; k < 300; k += 15) {
    const std::vector<float> q = describe(0, k);
    const Eigen::Vector3d pos = plan.robots[0].T_gt_sensor(k).translation();
    std::size_t best = 0;
    double best_d = 1e9, nearest_m = 1e9;
    for (std::size_t j = 0; j < db.size(); ++j) {
      const double dist = solid->Distance(q, db[j]);
      if (dist < best_d) {
        best_d = dist;
        best = j;
      }
      nearest_m = std::min(nearest_m, (db_pos[j] - pos).head<2>().norm());
    }
    if (nearest_m > 3.0) continue;  // robot 1 was not here (within the database's 3 m sampling)
    ++queries;
    recognised += (db_pos[best] - pos).head<2>().norm() < 8.0;
  }
  REQUIRE(queries >= 10);
  CHECK(recognised >= queries * 6 / 10);
}

TEST_CASE("sim worlds: generation is deterministic") {
  const MissionPlan plan = Plan(WorldKind::kCampus, OverlapMode::kModerate, 300);
  const World a = *BuildMissionWorld(plan), b = *BuildMissionWorld(plan);
  REQUIRE(a.spheres().size() == b.spheres().size());
  REQUIRE(a.boxes().size() == b.boxes().size());
  CHECK(std::memcmp(a.spheres().data(), b.spheres().data(), a.spheres().size() * sizeof(Sphere)) == 0);
  CHECK(std::memcmp(a.boxes().data(), b.boxes().data(), a.boxes().size() * sizeof(OrientedBox)) == 0);
  const World c = *BuildMissionWorld(Plan(WorldKind::kCampus, OverlapMode::kModerate, 300, 5));
  CHECK((c.spheres().size() != a.spheres().size() ||
         std::memcmp(a.spheres().data(), c.spheres().data(), a.spheres().size() * sizeof(Sphere)) != 0));
}

}  // namespace
}  // namespace commerge
