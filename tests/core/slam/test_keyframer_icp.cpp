// SPDX-License-Identifier: BSD-3-Clause
#include <doctest/doctest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <vector>

#include "core/cloud/voxel_grid.hpp"
#include "core/geometry/angles.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "core/slam/icp.hpp"
#include "core/slam/keyframer.hpp"
#include "platform/io/kitti_bin.hpp"
#include "platform/io/poses.hpp"
#include "tests/support/pose_errors.hpp"
#include "tests/support/test_data.hpp"

using namespace commerge;
using commerge::test::AngleDeg;

namespace {

Eigen::Isometry3d Pose(double x, double y, double yaw_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_deg * kPi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

std::vector<PointXYZI> Transform(const std::vector<PointXYZI>& in, const Eigen::Isometry3d& T) {
  std::vector<PointXYZI> out;
  for (const PointXYZI& p : in) {
    const Eigen::Vector3d q = T * Eigen::Vector3f(p.x, p.y, p.z).cast<double>();
    out.push_back({static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()), p.intensity});
  }
  return out;
}

std::vector<PointXYZI> VoxelisedStreetScan(float x_m, float yaw_rad, std::uint32_t seed) {
  std::vector<PointXYZI> raw, vox;
  SpinningLidar lidar;
  lidar.azimuth_steps = 720;  // keep the test fast under qemu
  CastScan(MakeStreetScene(3), lidar, x_m, 0.0f, 1.73f, yaw_rad, seed, &raw);
  REQUIRE(VoxelDownsample(raw, VoxelGridParams{1.0}, &vox).ok());
  return vox;
}


}  // namespace

TEST_CASE("Keyframer: a keyframe every keyframe_spacing_m or keyframe_rotation_deg, never on a NaN pose") {
  Keyframer kf(KeyframerParams{1.0, 15.0});
  int keyframes = 0;
  for (int i = 0; i <= 100; ++i) keyframes += kf.Offer(Pose(0.1 * i, 0.0, 0.0));  // 10 m in 0.1 m steps
  CHECK(keyframes == 11);  // at 0, 1, 2, ... 10 m
  CHECK(kf.Offer(Pose(10.0, 0.0, 14.0)) == false);
  CHECK(kf.Offer(Pose(10.0, 0.0, 16.0)) == true);  // turning in place
  Eigen::Isometry3d bad = Pose(0, 0, 0);
  bad.translation().x() = std::numeric_limits<double>::quiet_NaN();
  CHECK_FALSE(kf.Offer(bad));
  CHECK(kf.num_rejected_poses() == 1);
  CHECK(ValidateKeyframerParams(KeyframerParams{0.0, 15.0}).code() == StatusCode::kInvalidArgument);
  CHECK(ValidateKeyframerParams(KeyframerParams{1.0, 200.0}).code() == StatusCode::kInvalidArgument);
}

TEST_CASE("ICP recovers a known rigid motion between voxelised scans of the same place") {
  const std::vector<PointXYZI> target = VoxelisedStreetScan(0.0f, 0.0f, 1);
  const Eigen::Isometry3d T_true = [] {
    Eigen::Isometry3d T = Pose(0.8, -0.4, 7.0);
    T.translation().z() = 0.05;
    return T;
  }();
  // source = target seen from a displaced sensor: p_source = T_true^-1 p_target
  const std::vector<PointXYZI> source = Transform(target, T_true.inverse());
  PointToPointIcp icp;
  icp.SetTarget(target);
  auto r = icp.Align(source, Eigen::Isometry3d::Identity(), IcpParams{});
  REQUIRE(r.ok());
  CHECK(r->converged);
  CHECK((r->T_target_source.translation() - T_true.translation()).norm() < 0.02);
  CHECK(AngleDeg(r->T_target_source.linear().transpose() * T_true.linear()) < 0.1);
  CHECK(r->mean_squared_residual_m2 < 1e-3);
  CHECK(r->inlier_ratio > 0.95);
  // The information is symmetric positive definite.
  CHECK((r->hessian - r->hessian.transpose()).norm() < 1e-6 * r->hessian.norm());
  CHECK(Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(r->hessian).eigenvalues().minCoeff() > 0.0);
}

TEST_CASE("ICP reports failure, not success, without overlap and rejects empty input") {
  const std::vector<PointXYZI> target = VoxelisedStreetScan(0.0f, 0.0f, 1);
  std::vector<PointXYZI> far = Transform(target, Pose(500.0, 0.0, 0.0));
  PointToPointIcp icp;
  icp.SetTarget(target);
  auto r = icp.Align(far, Eigen::Isometry3d::Identity(), IcpParams{});
  REQUIRE(r.ok());
  CHECK_FALSE(r->converged);
  CHECK(r->num_inliers == 0);
  CHECK(icp.Align(Span<const PointXYZI>(), Eigen::Isometry3d::Identity(), IcpParams{}).status().code() ==
        StatusCode::kInvalidArgument);
}

// Point-to-point ICP on 1 m voxel centroids is biased along a street (the centroids of two samplings of
// a facade differ by tens of centimetres): it verifies loops, the fine registration is GICP's job.
TEST_CASE("ICP aligns KITTI 00 scans 2.6 m apart close to the ground-truth relative pose") {
  CM_SHARED_DATA_OR_SKIP(dir, "kitti/kitti00_frames0-15");
  auto poses = platform::ReadKittiPoses(dir + "/poses_lidar.txt");
  REQUIRE(poses.ok());
  auto a = platform::ReadKittiBin(dir + "/velodyne/000000.bin");
  auto b = platform::ReadKittiBin(dir + "/velodyne/000003.bin");
  REQUIRE((a.ok() && b.ok()));
  std::vector<PointXYZI> va, vb;
  REQUIRE(VoxelDownsample(a->points, VoxelGridParams{1.0}, &va).ok());
  REQUIRE(VoxelDownsample(b->points, VoxelGridParams{1.0}, &vb).ok());
  const Eigen::Isometry3d T_0_3 = (*poses)[0].inverse() * (*poses)[3];
  PointToPointIcp icp;
  icp.SetTarget(va);
  auto r = icp.Align(vb, Eigen::Isometry3d::Identity(), IcpParams{});
  REQUIRE(r.ok());
  CHECK(r->converged);
  CHECK((r->T_target_source.translation() - T_0_3.translation()).norm() < 0.75);
  CHECK(AngleDeg(r->T_target_source.linear().transpose() * T_0_3.linear()) < 1.0);
  CHECK(r->mean_squared_residual_m2 < 0.3);  // tau_ICP of the paper (spinning LiDAR)
}
