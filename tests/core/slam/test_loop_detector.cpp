// SPDX-License-Identifier: BSD-3-Clause
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/cloud/voxel_grid.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/geometry/angles.hpp"
#include "core/memory/budget.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "core/slam/loop_detector.hpp"
#include "core/slam/robot_mapper.hpp"
#include "tests/support/pose_errors.hpp"

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

TEST_CASE("LoopVerifier: the GICP refinement removes point-to-point ICP's bias on 1 m voxel scans") {
  // Revisits of the same street a few decimetres off the first pass (along and across the road, small yaw):
  // the loop transform is checked against the true relative pose of the two sensor poses.
  SpinningLidar lidar;
  lidar.azimuth_steps = 900;
  const BoxScene scene = MakeStreetScene(21);
  struct Revisit {
    float x0, dx, dy, dyaw;
  };
  const Revisit revisits[] = {{10.0f, 0.45f, 0.6f, 0.02f},  {25.0f, -0.4f, 0.6f, -0.03f}, {40.0f, 0.3f, -0.5f, 0.0f},
                              {55.0f, -0.25f, 0.7f, 0.05f}, {18.0f, 0.5f, 0.3f, -0.01f}, {33.0f, -0.5f, -0.6f, 0.03f}};
  LoopDetectorParams paper;
  paper.refine_with_gicp = false;
  LoopDetectorParams refined;  // default: refinement on
  LoopVerifier verifier;
  double icp_error_sum = 0.0, refined_error_sum = 0.0;
  int n = 0;
  std::vector<PointXYZI> raw, a, b;
  for (const Revisit& r : revisits) {
    CastScan(scene, lidar, r.x0, 0.0f, 1.73f, 0.0f, 7, &raw);
    REQUIRE(VoxelDownsample(raw, VoxelGridParams{1.0}, &a).ok());
    CastScan(scene, lidar, r.x0 + r.dx, r.dy, 1.73f, r.dyaw, 8, &raw);
    REQUIRE(VoxelDownsample(raw, VoxelGridParams{1.0}, &b).ok());
    Eigen::Isometry3d T_true = Eigen::Isometry3d::Identity();  // b's sensor frame in a's
    T_true.linear() = Eigen::AngleAxisd(static_cast<double>(r.dyaw), Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T_true.translation() = Eigen::Vector3d(static_cast<double>(r.dx), static_cast<double>(r.dy), 0.0);
    auto icp = verifier.Verify(300, 10, 0.01, Span<const PointXYZI>(b), Span<const PointXYZI>(a),
                               Eigen::Isometry3d::Identity(), paper);
    auto gicp = verifier.Verify(300, 10, 0.01, Span<const PointXYZI>(b), Span<const PointXYZI>(a),
                                Eigen::Isometry3d::Identity(), refined);
    REQUIRE(icp.ok());
    REQUIRE(gicp.ok());
    REQUIRE(icp->verdict == LoopVerdict::kAccepted);
    REQUIRE(gicp->verdict == LoopVerdict::kAccepted);
    // Without the refinement the measurement is ICP's (the paper's letter).
    CHECK_FALSE(icp->loop.refined);
    CHECK(icp->loop.T_match_query.isApprox(icp->loop.icp.T_target_source));
    // With it, ICP's own result and information are unchanged and the transform is GICP's.
    CHECK(gicp->loop.refined);
    CHECK(gicp->loop.icp.T_target_source.isApprox(icp->loop.icp.T_target_source, 1e-9));
    CHECK(gicp->loop.information.isApprox(icp->loop.information, 1e-9));
    const double e_icp = (T_true.inverse() * icp->loop.T_match_query).translation().norm();
    const double e_gicp = (T_true.inverse() * gicp->loop.T_match_query).translation().norm();
    const double rot_gicp_deg = test::AngleDeg((T_true.inverse() * gicp->loop.T_match_query).linear());
    CAPTURE(r.x0);
    CAPTURE(e_icp);
    CAPTURE(e_gicp);
    CHECK(e_gicp < 0.05);
    CHECK(rot_gicp_deg < 0.2);
    icp_error_sum += e_icp;
    refined_error_sum += e_gicp;
    ++n;
  }
  MESSAGE("mean loop translation error: point-to-point ICP " << icp_error_sum / n << " m, refined "
                                                              << refined_error_sum / n << " m");
  // The point of the refinement: ICP alone is biased by decimetres on these scans, the refinement is not.
  CHECK(icp_error_sum / n > 0.08);
  CHECK(refined_error_sum < 0.25 * icp_error_sum);
}

TEST_CASE("LoopVerifier: a refinement that moves ICP's result too far is dropped, and its parameters are checked") {
  SpinningLidar lidar;
  lidar.azimuth_steps = 600;
  const BoxScene scene = MakeStreetScene(21);
  std::vector<PointXYZI> raw, a, b;
  CastScan(scene, lidar, 20.0f, 0.0f, 1.73f, 0.0f, 1, &raw);
  REQUIRE(VoxelDownsample(raw, VoxelGridParams{1.0}, &a).ok());
  CastScan(scene, lidar, 20.4f, 0.6f, 1.73f, 0.0f, 2, &raw);
  REQUIRE(VoxelDownsample(raw, VoxelGridParams{1.0}, &b).ok());
  LoopDetectorParams p;
  p.max_refinement_m = 0.0;  // any change is too large
  LoopVerifier verifier;
  auto check = verifier.Verify(300, 10, 0.01, Span<const PointXYZI>(b), Span<const PointXYZI>(a),
                               Eigen::Isometry3d::Identity(), p);
  REQUIRE(check.ok());
  REQUIRE(check->verdict == LoopVerdict::kAccepted);
  CHECK_FALSE(check->loop.refined);
  CHECK(check->loop.T_match_query.isApprox(check->loop.icp.T_target_source));
  // The robot's loop_closure budget per point of the two scans (core/memory/budget.hpp) covers what the check
  // and its refinement hold for these scans.
  const std::size_t points = std::max(a.size(), b.size());
  MESSAGE("loop check workspace " << verifier.workspace_bytes() << " B for scans of " << a.size() << " and "
                                  << b.size() << " points");
  CHECK(verifier.workspace_bytes() > 0);
  CHECK(static_cast<std::int64_t>(verifier.workspace_bytes()) <=
        2 * static_cast<std::int64_t>(points) * BudgetRecordSizes::kIcpPointBytes);

  CHECK(ValidateLoopDetectorParams(LoopDetectorParams{}).ok());
  LoopDetectorParams bad;
  bad.max_refinement_deg = -1.0;
  Status s = ValidateLoopDetectorParams(bad);
  CHECK(s.code() == StatusCode::kInvalidArgument);
  CHECK(s.message().find("max_refinement_deg") != std::string::npos);
  bad = LoopDetectorParams{};
  bad.refine_features.covariance_neighbors = bad.refine_features.max_neighbors + 1;
  s = ValidateLoopDetectorParams(bad);
  CHECK(s.message().find("refine_features") != std::string::npos);
  bad.refine_with_gicp = false;  // not used, not checked
  CHECK(ValidateLoopDetectorParams(bad).ok());
  bad = LoopDetectorParams{};
  bad.refine_gicp.max_iterations = 0;
  s = ValidateLoopDetectorParams(bad);
  CHECK(s.message().find("refine_gicp") != std::string::npos);
}
