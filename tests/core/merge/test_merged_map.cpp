// SPDX-License-Identifier: BSD-3-Clause
// The merged-map builder (core/merge/merged_map.hpp) against a reference built by hand: every point placed with
// T_world_map * T_map_sensor, each robot's batches voxelised by VoxelGrid on its own, robot ids per point, the
// point cap, and the workspace given back by Finish().
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "core/cloud/voxel_grid.hpp"
#include "core/geometry/se3.hpp"
#include "core/merge/merged_map.hpp"

using namespace commerge;

namespace {

std::vector<PointXYZI> RandomScan(std::mt19937* rng, std::size_t n) {
  std::uniform_real_distribution<float> u(-20.0f, 20.0f);
  std::vector<PointXYZI> scan;
  for (std::size_t i = 0; i < n; ++i) scan.push_back({u(*rng), u(*rng), u(*rng) * 0.1f, static_cast<float>(i % 7)});
  return scan;
}

Eigen::Isometry3d Pose(double yaw_rad, double x, double y) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = RotationFromYawPitchRoll(yaw_rad, 0.02, -0.01);
  T.translation() = Eigen::Vector3d(x, y, 0.3);
  return T;
}

// The reference: the placed points in batches of batch_points (the last one of a robot shorter), each placed by
// hand and voxelised alone.
void Reference(const std::vector<std::vector<PointXYZI>>& scans, const std::vector<Eigen::Isometry3d>& T_map_sensor,
               const Eigen::Isometry3d& T_world_map, std::size_t batch_points, std::uint16_t id,
               std::vector<PointXYZI>* map, std::vector<std::uint16_t>* ids) {
  VoxelGrid grid;
  VoxelGridParams vp;
  std::vector<PointXYZI> batch, voxels;
  auto flush = [&] {
    if (batch.empty()) return;
    REQUIRE(grid.Downsample(Span<const PointXYZI>(batch), vp, &voxels).ok());
    map->insert(map->end(), voxels.begin(), voxels.end());
    ids->insert(ids->end(), voxels.size(), id);
    batch.clear();
  };
  for (std::size_t s = 0; s < scans.size(); ++s) {
    const Eigen::Matrix4d M = (T_world_map * T_map_sensor[s]).matrix();
    for (const PointXYZI& p : scans[s]) {
      if (batch.size() == batch_points) flush();
      const Eigen::Vector4d q = M * Eigen::Vector4f(p.x, p.y, p.z, 1.0f).cast<double>();
      batch.push_back({static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()), p.intensity});
    }
  }
  flush();
}

}  // namespace

TEST_CASE("Merged map: scans placed in the world and voxelised per robot batch equal the hand-built reference") {
  std::mt19937 rng(5);
  std::vector<std::vector<PointXYZI>> scans[2];
  std::vector<Eigen::Isometry3d> poses[2];
  for (int r = 0; r < 2; ++r) {
    for (int k = 0; k < 6; ++k) {
      scans[r].push_back(RandomScan(&rng, 400 + 50 * static_cast<std::size_t>(k)));
      poses[r].push_back(Pose(0.3 * k, 2.0 * k, -1.0 * k));
    }
  }
  const Eigen::Isometry3d T_world_map[2] = {Eigen::Isometry3d::Identity(), Pose(2.0, 30.0, -4.0)};
  for (std::size_t batch_points : {std::size_t{1}, std::size_t{1000}, std::size_t{2000000}}) {
    CAPTURE(batch_points);
    MergedMapParams params;
    params.batch_points = batch_points;
    REQUIRE(ValidateMergedMapParams(params).ok());
    MergedMapBuilder map(params);
    std::vector<PointXYZI> want;
    std::vector<std::uint16_t> want_ids;
    for (int r = 0; r < 2; ++r) {
      map.BeginRobot(static_cast<std::uint16_t>(r + 3), T_world_map[r]);
      for (std::size_t k = 0; k < scans[r].size(); ++k) map.AddScan(Span<const PointXYZI>(scans[r][k]), poses[r][k]);
      Reference(scans[r], poses[r], T_world_map[r], batch_points, static_cast<std::uint16_t>(r + 3), &want, &want_ids);
    }
    map.Finish();
    CHECK(map.scans_added() == 12);
    CHECK(map.scans_left_out() == 0);
    REQUIRE(map.points().size() == want.size());
    CHECK(map.robot_ids() == want_ids);
    double worst = 0.0;
    for (std::size_t i = 0; i < want.size(); ++i) {
      worst = std::max({worst, std::fabs(static_cast<double>(map.points()[i].x - want[i].x)),
                        std::fabs(static_cast<double>(map.points()[i].y - want[i].y)),
                        std::fabs(static_cast<double>(map.points()[i].z - want[i].z))});
    }
    CHECK(worst < 1e-3);  // float placement vs the reference's double placement
  }
}

TEST_CASE("Merged map: the point cap leaves later scans out and counts them, and Finish gives the workspace back") {
  std::mt19937 rng(9);
  MergedMapParams params;
  params.batch_points = 10;
  params.max_points = 300;
  MergedMapBuilder map(params);
  map.BeginRobot(1, Eigen::Isometry3d::Identity());
  std::size_t added = 0;
  for (int k = 0; k < 50; ++k) {
    map.AddScan(Span<const PointXYZI>(RandomScan(&rng, 200)), Pose(0.0, 50.0 * k, 0.0));
    ++added;
  }
  const std::size_t before_finish = map.memory_bytes();
  map.Finish();
  CHECK(map.points().size() <= params.max_points);
  CHECK(map.points().size() >= params.max_points - 200);
  CHECK(map.scans_left_out() > 0);
  CHECK(map.scans_added() + map.scans_left_out() == added);
  CHECK(map.memory_bytes() < before_finish);
  CHECK(map.robot_ids().size() == map.points().size());
}

TEST_CASE("Merged map: within the bytes of MergedMapParamsForBytes whatever the scans, and full maps count what they leave out") {
  std::mt19937 rng(17);
  for (std::int64_t bytes : {std::int64_t{4096}, std::int64_t{200000}, std::int64_t{3} << 20}) {
    CAPTURE(bytes);
    const MergedMapParams params = MergedMapParamsForBytes(bytes, 0.5);
    REQUIRE(ValidateMergedMapParams(params).ok());
    CHECK(params.voxel_size_m == 0.5);
    // The split: a quarter (at least one point) for the batch, the rest for the map's points.
    CHECK(params.batch_points == std::max<std::size_t>(1, static_cast<std::size_t>(bytes) / 4 /
                                                              MergedMapBuilder::kBatchPointBytes));
    CHECK(params.batch_points * MergedMapBuilder::kBatchPointBytes +
              params.max_points * MergedMapBuilder::kMapPointBytes <= static_cast<std::size_t>(bytes));
    MergedMapBuilder map(params);
    std::size_t most = 0, scans = 0;
    for (int r = 0; r < 3; ++r) {
      map.BeginRobot(static_cast<std::uint16_t>(r), Pose(0.5 * r, 40.0 * r, 3.0));
      for (int k = 0; k < 60; ++k, ++scans) {
        // Scans of every size, some larger than the batch, spread so that few points share a voxel.
        const std::size_t n = (k % 7 == 0) ? 3 * params.batch_points + 5 : static_cast<std::size_t>(50 + 37 * k);
        map.AddScan(Span<const PointXYZI>(RandomScan(&rng, n)), Pose(0.1 * k, 45.0 * k, -2.0 * r));
        most = std::max(most, map.memory_bytes());
      }
    }
    map.Finish();
    most = std::max(most, map.memory_bytes());
    CHECK(most <= static_cast<std::size_t>(bytes));
    CHECK(map.points().size() <= params.max_points);
    CHECK(map.scans_added() + map.scans_left_out() == scans);
    CHECK(map.robot_ids().size() == map.points().size());
  }
  // A budget the scans fit in leaves nothing out.
  MergedMapBuilder roomy(MergedMapParamsForBytes(std::int64_t{64} << 20));
  roomy.BeginRobot(0, Eigen::Isometry3d::Identity());
  for (int k = 0; k < 10; ++k) roomy.AddScan(Span<const PointXYZI>(RandomScan(&rng, 2000)), Pose(0.0, 50.0 * k, 0.0));
  roomy.Finish();
  CHECK(roomy.scans_left_out() == 0);
  CHECK(roomy.scans_added() == 10);
}

TEST_CASE("Merged map parameters are validated") {
  MergedMapParams p;
  CHECK(ValidateMergedMapParams(p).ok());
  p.voxel_size_m = 0.001;
  CHECK_FALSE(ValidateMergedMapParams(p).ok());
  p = MergedMapParams{};
  p.voxel_size_m = std::nan("");
  CHECK_FALSE(ValidateMergedMapParams(p).ok());
  p = MergedMapParams{};
  p.batch_points = 0;
  CHECK_FALSE(ValidateMergedMapParams(p).ok());
  p = MergedMapParams{};
  p.max_points = 0;
  CHECK_FALSE(ValidateMergedMapParams(p).ok());
}
