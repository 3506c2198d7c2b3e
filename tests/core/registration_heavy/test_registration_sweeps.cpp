// SPDX-License-Identifier: BSD-3-Clause
// Long registration sweeps (host only, CTest label `heavy`): yaw every 10 deg x offsets up to 20 m on
// generated submap pairs, many random overlapping / non-overlapping pairs, small_gicp's full GICP protocol at
// 0.3 m, all real pairs of ../shared/data/kitti against their ground truth, and 20-fold determinism.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "core/geometry/angles.hpp"
#include "platform/io/poses.hpp"
#include "tests/core/registration/registration_test_support.hpp"
#include "tests/support/test_data.hpp"

namespace commerge {
namespace {

using test::RotationErrorDeg;
using test::TranslationErrorM;
using test::View;
using test::YawOffset;

// 32 x 1024 rays, 100 m: about 4-6 k points per 3-scan submap.
SpinningLidar SweepLidar() {
  SpinningLidar lidar;
  lidar.beams = 32;
  lidar.azimuth_steps = 1024;
  lidar.max_range_m = 100.0f;
  return lidar;
}

}  // namespace

TEST_CASE("Heavy: every yaw in 10 deg steps with offsets 0, 10 and 20 m registers within 0.2 m and 1 deg") {
  const SubmapRegistrationParams params = MakeSubmapRegistrationParams(1.0);
  SubmapRegistration reg;
  int runs = 0, successes = 0;
  for (std::uint32_t scene : {41u, 42u}) {
    const BoxScene world = MakeStreetScene(scene, 260.0f);
    for (int yaw = 0; yaw < 360; yaw += 10) {
      for (double offset : {0.0, 10.0, 20.0}) {
        // The offset direction turns with the yaw so that every quadrant is covered.
        const double dir = (yaw * 2.3 + offset * 7.0) * kPi / 180.0;
        StreetPairSpec spec = test::LightStreetSpec(scene, YawOffset(yaw, offset * std::cos(dir), offset * std::sin(dir),
                                                                     offset > 0.0 ? 0.5 : 0.0),
                                                    2.0f + static_cast<float>(yaw % 30) / 10.0f, yaw % 20 == 0);
        spec.lidar = SweepLidar();
        SyntheticSubmapPair pair;
        REQUIRE(MakeStreetSubmapPairInScene(world, spec, &pair).ok());
        auto r = reg.Register(View(pair.source), View(pair.target), params);
        REQUIRE(r.ok());
        ++runs;
        CAPTURE(scene);
        CAPTURE(yaw);
        CAPTURE(offset);
        CAPTURE(std::string(RegistrationVerdictName(r->verdict)));
        CAPTURE(r->num_correspondences);
        CAPTURE(r->num_pruned_inliers);
        CAPTURE(r->num_coarse_inliers);
        CAPTURE(r->overlap_ratio);
        CAPTURE(r->directional_overlap);
        CAPTURE(pair.source.points.size());
        CAPTURE(TranslationErrorM(pair.T_target_source, r->T_target_source));
        CAPTURE(TranslationErrorM(pair.T_target_source, r->T_target_source_coarse));
        CAPTURE(RotationErrorDeg(pair.T_target_source, r->T_target_source_coarse));
        CAPTURE(r->gicp_iterations);
        CHECK(r->success());
        if (r->success()) {
          ++successes;
          CHECK(TranslationErrorM(pair.T_target_source, r->T_target_source) < 0.2);
          CHECK(RotationErrorDeg(pair.T_target_source, r->T_target_source) < 1.0);
        }
      }
    }
  }
  MESSAGE("yaw sweep: " << successes << " successes of " << runs);
}

TEST_CASE("Heavy: random pairs - at least 95 percent of overlapping pairs succeed, all correctly, none without overlap") {
  const SubmapRegistrationParams params = MakeSubmapRegistrationParams(1.0);
  SubmapRegistration reg;
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int overlapping = 0, succeeded = 0, false_successes = 0, non_overlapping = 0;
  for (int i = 0; i < 60; ++i) {
    const bool overlap = i % 2 == 0;
    const std::uint32_t scene = 300u + static_cast<std::uint32_t>(i / 2);
    const double dir = 2.0 * kPi * unit(rng);
    const double dist = 20.0 * unit(rng);
    StreetPairSpec spec = test::LightStreetSpec(scene, YawOffset(360.0 * unit(rng), dist * std::cos(dir), dist * std::sin(dir), unit(rng) - 0.5),
                                                static_cast<float>(-6.0 + 12.0 * unit(rng)), unit(rng) < 0.5);
    spec.lidar = SweepLidar();
    spec.street_length_m = 900.0f;
    spec.scans_per_submap = 3 + i % 3;
    spec.target_start_x_m = static_cast<float>(-200.0 + 100.0 * unit(rng));
    spec.source_start_x_m += spec.target_start_x_m + 8.0f;
    SyntheticSubmapPair pair;
    if (overlap) {
      REQUIRE(MakeStreetSubmapPair(spec, &pair).ok());
    } else if (i % 4 == 1) {
      REQUIRE(MakeStreetSubmapPair(spec, &pair).ok());
      SyntheticSubmapPair other;
      StreetPairSpec other_spec = spec;
      other_spec.scene_seed += 7000u;  // another street for the source robot
      REQUIRE(MakeStreetSubmapPair(other_spec, &other).ok());
      pair.source = other.source;
    } else {
      spec.source_start_x_m = spec.target_start_x_m + 320.0f + static_cast<float>(60.0 * unit(rng));  // same street, far
      REQUIRE(MakeStreetSubmapPair(spec, &pair).ok());
    }
    auto r = reg.Register(View(pair.source), View(pair.target), params);
    REQUIRE(r.ok());
    CAPTURE(i);
    CAPTURE(std::string(RegistrationVerdictName(r->verdict)));
    if (overlap) {
      ++overlapping;
      if (r->success()) {
        ++succeeded;
        CHECK(TranslationErrorM(pair.T_target_source, r->T_target_source) < 0.2);
        CHECK(RotationErrorDeg(pair.T_target_source, r->T_target_source) < 1.0);
      }
    } else {
      ++non_overlapping;
      false_successes += r->success();
      CHECK_FALSE(r->success());
    }
  }
  MESSAGE("random pairs: " << succeeded << "/" << overlapping << " overlapping succeeded, " << false_successes << "/"
                           << non_overlapping << " false successes");
  CHECK(succeeded * 100 >= 95 * overlapping);
}

TEST_CASE("Heavy: small_gicp protocol at 0.3 m, k = 20 - 4 initial poses and 2 shifted sources, forward and inverse") {
  CM_SHARED_DATA_OR_SKIP(dir, "kitti/small_gicp_pair");
  const Eigen::Isometry3d truth = test::ReadTransform4x4(dir + "/T_target_source.txt");
  SubmapRegistrationParams params = MakeSubmapRegistrationParams(0.3);
  params.features.covariance_neighbors = 20;
  for (int d = 0; d < 2; ++d) {
    const Eigen::Isometry3d ref = d == 0 ? truth : truth.inverse();
    const std::string src_file = dir + (d == 0 ? "/source.bin" : "/target.bin");
    const std::string tgt_file = dir + (d == 0 ? "/target.bin" : "/source.bin");
    const std::vector<PointXYZI> target = test::LoadVoxelised(tgt_file, Eigen::Isometry3d::Identity(), 0.3);
    SubmapFeatures tgt;
    tgt.ComputeGeometry(target, {}, params.features);
    // Shifts S: the source is moved to S^-1 p and the start is ref * S (the shift is known, as in small_gicp).
    const Eigen::Isometry3d shifts[] = {Eigen::Isometry3d::Identity(), YawOffset(180.0, 2.0, -2.0, 0.5),
                                        YawOffset(-120.0, -2.0, 1.5, -0.3)};
    for (const Eigen::Isometry3d& S : shifts) {
      const std::vector<PointXYZI> source = test::LoadVoxelised(src_file, S.inverse(), 0.3);
      SubmapFeatures src;
      src.ComputeGeometry(source, {}, params.features);
      const double noise[4][6] = {{0, 0, 0, 0, 0, 0}, {0.3, -0.2, 0.1, 4.0, 1.0, -1.0}, {-0.5, 0.4, -0.1, -10.0, 0.5, 2.0},
                                  {0.1, 0.5, 0.2, 7.0, -2.0, 0.0}};
      for (const auto& n : noise) {
        Eigen::Isometry3d P = Eigen::Isometry3d::Identity();
        P.linear() = RotationFromYawPitchRoll(n[3] * kPi / 180.0, n[4] * kPi / 180.0, n[5] * kPi / 180.0);
        P.translation() = Eigen::Vector3d(n[0], n[1], n[2]);
        const GicpResult r = Gicp().Align(src, tgt, ref * S * P, params.fine);
        CHECK(r.converged);
        CHECK(RotationErrorDeg(ref * S, r.T_target_source) < 2.5);
        CHECK(TranslationErrorM(ref * S, r.T_target_source) < 0.2);
      }
    }
  }
}

TEST_CASE("Heavy: KITTI 07 submap pairs with 3 source frames - every success within 0.2 m and 1 deg of the ground truth") {
  CM_SHARED_DATA_OR_SKIP(dir, "kitti/kitti07_keyframes");
  auto poses = platform::ReadKittiPoses(dir + "/poses_lidar.txt");
  REQUIRE(poses.ok());
  const SubmapRegistrationParams params = MakeSubmapRegistrationParams(1.0);
  SubmapRegistration reg;
  const int pairs[][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 4}, {0, 2}, {1, 3}, {2, 4}};
  const Eigen::Isometry3d frames[] = {Eigen::Isometry3d::Identity(), YawOffset(180.0, 5.0, -3.0, 0.5), YawOffset(90.0, -12.0, 9.0, 0.0)};
  int successes = 0, runs = 0;
  for (const auto& p : pairs) {
    char name[32];
    std::snprintf(name, sizeof(name), "/%06d.bin", p[0]);
    const std::vector<PointXYZI> target = test::LoadVoxelised(dir + name, Eigen::Isometry3d::Identity(), 1.0);
    std::snprintf(name, sizeof(name), "/%06d.bin", p[1]);
    for (const Eigen::Isometry3d& P : frames) {
      const std::vector<PointXYZI> source = test::LoadVoxelised(dir + name, P.inverse(), 1.0);
      const std::vector<Eigen::Vector3d> origin = {P.inverse().translation()};
      const Eigen::Isometry3d truth = (*poses)[static_cast<std::size_t>(p[0])].inverse() * (*poses)[static_cast<std::size_t>(p[1])] * P;
      auto r = reg.Register({source, origin}, {target, {}}, params);
      REQUIRE(r.ok());
      ++runs;
      CAPTURE(p[0]);
      CAPTURE(p[1]);
      CAPTURE(std::string(RegistrationVerdictName(r->verdict)));
      if (r->success()) {
        ++successes;
        CHECK(TranslationErrorM(truth, r->T_target_source) < 0.2);
        CHECK(RotationErrorDeg(truth, r->T_target_source) < 1.0);
      }
    }
  }
  MESSAGE("KITTI 07: " << successes << " successes of " << runs);
  // Pairs 0-1, 1-2, 2-3, 1-3 and 0-2 succeed in every frame through the features; 3-4 turned by 90 deg only
  // through the global search (its features give 7 consistent matches), so 18 of 21 need it. 2-4 never: its
  // true alignment scores below the overlap gates (overlap 0.38 x directional 0.11 even when GICP starts at the
  // ground truth), i.e. below wrong street alignments.
  CHECK(successes >= 18);
}

TEST_CASE("Heavy: KITTI 00 scans and Newer College plane clouds register close to their references") {
  CM_SHARED_DATA_OR_SKIP(k00, "kitti/kitti00_frames0-15");
  CM_SHARED_DATA_OR_SKIP(nc, "kitti/newer_college_01");
  const SubmapRegistrationParams params = MakeSubmapRegistrationParams(1.0);
  SubmapRegistration reg;
  // KITTI 00: the official ground truth and the raw scans disagree along the driving direction (about 20 % of
  // the travelled distance; GICP started at the ground truth drifts by the same amount at any voxel size, see
  // bench_registration). Reference: GICP started at the ground truth (same submaps, same parameters); the
  // global result must land in the same place. Loose bound against the ground truth itself.
  {
    auto poses = platform::ReadKittiPoses(k00 + "/poses_lidar.txt");
    REQUIRE(poses.ok());
    const int pairs[][2] = {{0, 5}, {0, 10}, {5, 15}};
    for (const auto& p : pairs) {
      char a[48], b[48];
      std::snprintf(a, sizeof(a), "/velodyne/%06d.bin", p[0]);
      std::snprintf(b, sizeof(b), "/velodyne/%06d.bin", p[1]);
      const Eigen::Isometry3d P = YawOffset(137.0, 6.0, -9.0, 0.0);
      const std::vector<PointXYZI> target = test::LoadVoxelised(k00 + a, Eigen::Isometry3d::Identity(), 1.0);
      const std::vector<PointXYZI> source = test::LoadVoxelised(k00 + b, P.inverse(), 1.0);
      const std::vector<Eigen::Vector3d> origin = {P.inverse().translation()};
      const Eigen::Isometry3d truth = (*poses)[static_cast<std::size_t>(p[0])].inverse() * (*poses)[static_cast<std::size_t>(p[1])] * P;
      auto r = reg.Register({source, origin}, {target, {}}, params);
      REQUIRE(r.ok());
      CAPTURE(p[1]);
      CAPTURE(std::string(RegistrationVerdictName(r->verdict)));
      CHECK(r->success());
      SubmapFeatures s, t;
      s.ComputeGeometry(source, origin, params.features);
      t.ComputeGeometry(target, {}, params.features);
      const GicpResult ref = Gicp().Align(s, t, truth, params.fine);
      REQUIRE(ref.converged);
      CHECK(TranslationErrorM(ref.T_target_source, r->T_target_source) < 0.2);
      CHECK(RotationErrorDeg(ref.T_target_source, r->T_target_source) < 1.0);
      CHECK(TranslationErrorM(truth, r->T_target_source) < 1.5);
      CHECK(RotationErrorDeg(truth, r->T_target_source) < 2.0);
    }
  }
  // Newer College plane features, 1-4 m apart.
  {
    auto poses = platform::ReadKittiPoses(nc + "/poses_lidar.txt");
    REQUIRE(poses.ok());
    const int pairs[][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 4}, {0, 2}, {0, 4}};
    for (const auto& p : pairs) {
      char a[48], b[48];
      std::snprintf(a, sizeof(a), "/planes_%06d.bin", 10 * p[0]);
      std::snprintf(b, sizeof(b), "/planes_%06d.bin", 10 * p[1]);
      const Eigen::Isometry3d P = YawOffset(-100.0, 15.0, 4.0, 1.0);
      const std::vector<PointXYZI> target = test::LoadVoxelised(nc + a, Eigen::Isometry3d::Identity(), 1.0);
      const std::vector<PointXYZI> source = test::LoadVoxelised(nc + b, P.inverse(), 1.0);
      const std::vector<Eigen::Vector3d> origin = {P.inverse().translation()};
      const Eigen::Isometry3d truth = (*poses)[static_cast<std::size_t>(p[0])].inverse() * (*poses)[static_cast<std::size_t>(p[1])] * P;
      auto r = reg.Register({source, origin}, {target, {}}, params);
      REQUIRE(r.ok());
      CAPTURE(p[0]);
      CAPTURE(p[1]);
      CAPTURE(std::string(RegistrationVerdictName(r->verdict)));
      CHECK(r->success());
      CHECK(TranslationErrorM(truth, r->T_target_source) < 0.2);
      CHECK(RotationErrorDeg(truth, r->T_target_source) < 1.0);
    }
  }
}

TEST_CASE("Heavy: clouds of different places and datasets are never registered") {
  CM_SHARED_DATA_OR_SKIP(root, "kitti");
  const SubmapRegistrationParams params = MakeSubmapRegistrationParams(1.0);
  SubmapRegistration reg;
  const std::string clouds[] = {"/kitti00_frames0-15/velodyne/000000.bin", "/kitti00_frames0-15/velodyne/000015.bin",
                                "/kitti07_keyframes/000000.bin", "/kitti07_keyframes/000003.bin",
                                "/newer_college_01/planes_000000.bin", "/small_gicp_pair/source.bin"};
  for (std::size_t i = 0; i < 6; ++i) {
    for (std::size_t j = 0; j < 6; ++j) {
      // Same dataset and close in time may overlap (KITTI 00 0/15 do): only cross-dataset pairs.
      if (i == j || i / 2 == j / 2) continue;
      const std::vector<PointXYZI> s = test::LoadVoxelised(root + clouds[i], Eigen::Isometry3d::Identity(), 1.0);
      const std::vector<PointXYZI> t = test::LoadVoxelised(root + clouds[j], Eigen::Isometry3d::Identity(), 1.0);
      auto r = reg.Register({s, {}}, {t, {}}, params);
      REQUIRE(r.ok());
      CAPTURE(clouds[i]);
      CAPTURE(clouds[j]);
      CAPTURE(std::string(RegistrationVerdictName(r->verdict)));
      CHECK_FALSE(r->success());
    }
  }
}

TEST_CASE("Heavy: 20 repeated registrations are bit-identical") {
  SyntheticSubmapPair pair;
  StreetPairSpec spec = test::LightStreetSpec(77, YawOffset(222.0, -13.0, 11.0, 0.4));
  spec.lidar = SweepLidar();
  REQUIRE(MakeStreetSubmapPair(spec, &pair).ok());
  const SubmapRegistrationParams params = MakeSubmapRegistrationParams(1.0);
  auto first = RegisterSubmaps(View(pair.source), View(pair.target), params);
  REQUIRE(first.ok());
  REQUIRE(first->success());
  SubmapRegistration reg;
  for (int k = 0; k < 20; ++k) {
    auto r = reg.Register(View(pair.source), View(pair.target), params);
    REQUIRE(r.ok());
    CHECK(std::memcmp(r->T_target_source.matrix().data(), first->T_target_source.matrix().data(), 16 * sizeof(double)) == 0);
    CHECK(r->num_fine_inliers == first->num_fine_inliers);
  }
}

}  // namespace commerge
