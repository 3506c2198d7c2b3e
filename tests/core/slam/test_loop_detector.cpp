// SPDX-License-Identifier: BSD-3-Clause
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/cloud/voxel_grid.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "core/slam/loop_detector.hpp"
#include "core/slam/robot_mapper.hpp"

using namespace commerge;

TEST_CASE("DescriptorDatabase finds the exact nearest valid descriptor before the window (brute-force reference)") {
  auto solid = SolidDescriptor::Create(SolidParams{});
  REQUIRE(solid.ok());
  DescriptorDatabase db(*solid, 300);
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<std::vector<float>> all;
  for (int k = 0; k < 300; ++k) {
    std::vector<float> d(40);
    double n = 0.0;
    for (float& x : d) {
      x = u(rng);
      n += static_cast<double>(x) * static_cast<double>(x);
    }
    for (float& x : d) x = static_cast<float>(static_cast<double>(x) / std::sqrt(n));
    const bool valid = k % 7 != 3;
    REQUIRE(db.Add(Span<const float>(d), valid).ok());
    all.push_back(d);
  }
  std::vector<float> extra(40, 0.1f);
  CHECK(db.Add(Span<const float>(extra), true).code() == StatusCode::kResourceExhausted);
  CHECK(db.Add(Span<const float>(extra.data(), 39), true).code() == StatusCode::kInvalidArgument);
  for (std::size_t query : {0u, 50u, 150u, 299u}) {
    for (std::size_t end : {std::size_t{0}, std::size_t{1}, std::size_t{100}, query}) {
      const auto m = db.NearestBefore(Span<const float>(all[query]), end);
      double best = 1e9;
      long best_k = -1;
      for (std::size_t k = 0; k < end; ++k) {
        if (k % 7 == 3) continue;  // invalid ones are never matched
        const double d = SolidDistance(Span<const float>(all[query]), Span<const float>(all[k]));
        if (d < best) best = d, best_k = static_cast<long>(k);
      }
      CHECK(m.found == (best_k >= 0));
      if (best_k >= 0) {
        CHECK(m.keyframe == static_cast<std::uint32_t>(best_k));
        CHECK(m.distance == doctest::Approx(best).epsilon(1e-9));
      }
    }
  }
}

TEST_CASE("LoopVerifier accepts the same place from any heading and rejects a different place") {
  SpinningLidar lidar;
  lidar.azimuth_steps = 600;
  const BoxScene scene = MakeStreetScene(21);
  std::vector<PointXYZI> raw, a, b, far;
  CastScan(scene, lidar, 10.0f, 0.0f, 1.73f, 0.0f, 1, &raw);
  REQUIRE(VoxelDownsample(raw, VoxelGridParams{1.0}, &a).ok());
  CastScan(scene, lidar, 10.5f, 0.3f, 1.73f, 2.6f, 2, &raw);  // same place, opposite heading
  REQUIRE(VoxelDownsample(raw, VoxelGridParams{1.0}, &b).ok());
  CastScan(scene, lidar, 70.0f, 0.0f, 1.73f, 0.0f, 3, &raw);  // 60 m further
  REQUIRE(VoxelDownsample(raw, VoxelGridParams{1.0}, &far).ok());
  LoopDetectorParams p;
  LoopVerifier verifier;
  // The trajectory's prediction is useless here (identity): the yaw hypotheses must find it.
  auto same = verifier.Verify(200, 10, 0.01, Span<const PointXYZI>(b), Span<const PointXYZI>(a),
                              Eigen::Isometry3d::Identity(), p);
  REQUIRE(same.ok());
  CHECK(same->verdict == LoopVerdict::kAccepted);
  const Eigen::Isometry3d& T = same->loop.T_match_query;  // b's frame into a's frame
  CHECK(std::abs(std::atan2(T.linear()(1, 0), T.linear()(0, 0)) - 2.6) < 0.03);
  CHECK((T.translation().head<2>() - Eigen::Vector2d(0.5, 0.3)).norm() < 0.5);
  CHECK((same->loop.information - same->loop.information.transpose()).norm() < 1e-6 * same->loop.information.norm());

  auto different = verifier.Verify(200, 10, 0.01, Span<const PointXYZI>(far), Span<const PointXYZI>(a),
                                   Eigen::Isometry3d::Identity(), p);
  REQUIRE(different.ok());
  CHECK(different->verdict != LoopVerdict::kAccepted);
  auto gated = verifier.Verify(200, 10, 0.2, Span<const PointXYZI>(b), Span<const PointXYZI>(a),
                               Eigen::Isometry3d::Identity(), p);
  CHECK(gated->verdict == LoopVerdict::kDescriptorTooFar);
}

TEST_CASE("Robot mapper: empty, NaN-only and oversized scans and NaN poses give defined results") {
  auto solid = SolidDescriptor::Create(SolidParams{});
  REQUIRE(solid.ok());
  ScanStoreParams sp;
  sp.capacity_bytes = 1 << 20;
  sp.max_scans = 100;
  auto store = ScanStore::Create(sp);
  REQUIRE(store.ok());
  RobotMapperCapacity cap;
  cap.max_keyframes = 3;
  cap.max_points_per_raw_scan = 1000;
  RobotMapper mapper(RobotMapperParams{}, cap, &*solid, store->get());
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();

  auto empty = mapper.AddScan(Span<const PointXYZI>(), T);  // first pose: a keyframe, with nothing in it
  REQUIRE(empty.ok());
  CHECK(empty->is_keyframe);
  CHECK_FALSE(empty->descriptor.valid);
  CHECK(empty->loop.verdict == LoopVerdict::kNoCandidate);

  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<PointXYZI> nans(10, PointXYZI{nan, nan, nan, 0.0f});
  T.translation().x() = 1.0;
  auto nan_scan = mapper.AddScan(Span<const PointXYZI>(nans), T);
  REQUIRE(nan_scan.ok());
  CHECK(nan_scan->is_keyframe);
  CHECK_FALSE(nan_scan->descriptor.valid);
  CHECK(nan_scan->voxel_points == 0);
  CHECK_FALSE(mapper.descriptor_valid(1));

  Eigen::Isometry3d bad = T;
  bad.translation().y() = std::numeric_limits<double>::infinity();
  auto bad_pose = mapper.AddScan(Span<const PointXYZI>(nans), bad);
  REQUIRE(bad_pose.ok());
  CHECK_FALSE(bad_pose->is_keyframe);

  std::vector<PointXYZI> big(1001, PointXYZI{1.0f, 2.0f, 3.0f, 0.0f});
  CHECK(mapper.AddScan(Span<const PointXYZI>(big), T).status().code() == StatusCode::kInvalidArgument);

  T.translation().x() = 2.0;
  REQUIRE(mapper.AddScan(Span<const PointXYZI>(), T).ok());
  T.translation().x() = 3.0;
  CHECK(mapper.AddScan(Span<const PointXYZI>(), T).status().code() == StatusCode::kResourceExhausted);
  CHECK(mapper.num_keyframes() == 3);
  CHECK(mapper.stats().invalid_descriptors == 3);
  auto pending = mapper.OptimizePending();
  REQUIRE(pending.ok());
  CHECK(pending->empty());
}
