// SPDX-License-Identifier: BSD-3-Clause
// Fine registration (core/registration/gicp): small_gicp's protocol (several perturbed initial poses, forward
// and inverse, pose error against the reference transform) on a generated pair with exact ground truth and
// on small_gicp's real pair; information matrix checks.
#include <doctest/doctest.h>

#include <Eigen/Eigenvalues>

#include <sstream>
#include <vector>

#include "core/geometry/angles.hpp"
#include "tests/core/registration/registration_test_support.hpp"
#include "tests/support/test_data.hpp"

namespace commerge {
namespace {

using test::RotationErrorDeg;
using test::TranslationErrorM;
using test::YawOffset;

// The four initial poses of the protocol: identity and three perturbations (<= 0.5 m, <= 10 deg) of the truth.
std::vector<Eigen::Isometry3d> InitialPoses(const Eigen::Isometry3d& truth) {
  std::vector<Eigen::Isometry3d> out = {Eigen::Isometry3d::Identity()};
  const double d[3][6] = {{0.3, -0.2, 0.1, 4.0, 1.0, -1.0}, {-0.5, 0.4, -0.1, -10.0, 0.5, 2.0}, {0.1, 0.5, 0.2, 7.0, -2.0, 0.0}};
  for (const auto& p : d) {
    Eigen::Isometry3d P = Eigen::Isometry3d::Identity();
    P.linear() = RotationFromYawPitchRoll(p[3] * kPi / 180.0, p[4] * kPi / 180.0, p[5] * kPi / 180.0);
    P.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
    out.push_back(truth * P);
  }
  return out;
}

}  // namespace

TEST_CASE("GICP and plane ICP converge to the ground truth of a generated pair from perturbed starts, both directions") {
  SyntheticSubmapPair pair;
  REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(21, YawOffset(30.0, 4.0, -3.0, 0.2)), &pair).ok());
  SubmapRegistrationParams params = MakeSubmapRegistrationParams(1.0);
  SubmapFeatures src, tgt;
  src.ComputeGeometry(pair.source.points, pair.source.sensor_origins_m, params.features);
  tgt.ComputeGeometry(pair.target.points, pair.target.sensor_origins_m, params.features);
  for (FineFactor factor : {FineFactor::kGicp, FineFactor::kPointToPlane}) {
    params.fine.factor = factor;
    Gicp gicp;
    for (int dir = 0; dir < 2; ++dir) {
      const Eigen::Isometry3d truth = dir == 0 ? pair.T_target_source : pair.T_target_source.inverse();
      const SubmapFeatures& s = dir == 0 ? src : tgt;
      const SubmapFeatures& t = dir == 0 ? tgt : src;
      const std::vector<Eigen::Isometry3d> starts = InitialPoses(truth);
      for (std::size_t k = 1; k < starts.size(); ++k) {  // identity is ~31 deg off: outside a local method's basin
        CAPTURE(static_cast<int>(factor));
        CAPTURE(dir);
        CAPTURE(k);
        const GicpResult r = gicp.Align(s, t, starts[k], params.fine);
        CHECK(r.converged);
        // Plane ICP uses the target normals only and is biased by about 6 cm on 1 m voxel centroids.
        const double max_m = factor == FineFactor::kGicp ? 0.05 : 0.1;
        CHECK(TranslationErrorM(truth, r.T_target_source) < max_m);
        CHECK(RotationErrorDeg(truth, r.T_target_source) < 0.2);
        CHECK(r.num_inliers > s.points().size() / 2);
        // Information: symmetric, positive definite, well above small_gicp's degeneracy floor of 10.
        CHECK((r.H - r.H.transpose()).norm() <= 1e-9 * r.H.norm());
        CHECK(Eigen::SelfAdjointEigenSolver<Matrix6d>(r.H).eigenvalues().minCoeff() > 10.0);
      }
    }
  }
}

TEST_CASE("GICP on small_gicp's pair: 4 initial poses, forward and inverse, within 2.5 deg and 0.2 m") {
  CM_SHARED_DATA_OR_SKIP(dir, "kitti/small_gicp_pair");
  const Eigen::Isometry3d truth = test::ReadTransform4x4(dir + "/T_target_source.txt");
  const std::vector<PointXYZI> source = test::LoadVoxelised(dir + "/source.bin", Eigen::Isometry3d::Identity(), 0.5);
  const std::vector<PointXYZI> target = test::LoadVoxelised(dir + "/target.bin", Eigen::Isometry3d::Identity(), 0.5);
  REQUIRE(source.size() > 1000);
  const SubmapRegistrationParams params = MakeSubmapRegistrationParams(0.5);
  SubmapFeatures src, tgt;
  src.ComputeGeometry(source, {}, params.features);
  tgt.ComputeGeometry(target, {}, params.features);
  Gicp gicp;
  for (int d = 0; d < 2; ++d) {
    const Eigen::Isometry3d ref = d == 0 ? truth : truth.inverse();
    for (const Eigen::Isometry3d& start : InitialPoses(ref)) {
      const GicpResult r = gicp.Align(d == 0 ? src : tgt, d == 0 ? tgt : src, start, params.fine);
      CHECK(r.converged);
      CHECK(RotationErrorDeg(ref, r.T_target_source) < 2.5);
      CHECK(TranslationErrorM(ref, r.T_target_source) < 0.2);
    }
  }
}

TEST_CASE("GICP reports no convergence instead of a result when nothing corresponds") {
  SyntheticSubmapPair pair;
  REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(22, Eigen::Isometry3d::Identity()), &pair).ok());
  const SubmapRegistrationParams params = MakeSubmapRegistrationParams(1.0);
  SubmapFeatures src, tgt;
  src.ComputeGeometry(pair.source.points, {}, params.features);
  tgt.ComputeGeometry(pair.target.points, {}, params.features);
  const GicpResult r = Gicp().Align(src, tgt, YawOffset(0.0, 0.0, 0.0, 500.0), params.fine);
  CHECK_FALSE(r.converged);
  CHECK(r.num_inliers == 0);
}

}  // namespace commerge
