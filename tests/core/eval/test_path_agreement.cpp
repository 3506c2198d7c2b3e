// SPDX-License-Identifier: BSD-3-Clause
// The shared-path agreement measure against a brute force over every keyframe pair (written here: a double loop,
// a full sort for the percentile), and against cases whose answer is known: a whole map moved (0), one robot
// shifted by a known vector (that vector's length for every pair). Random poses: core/sim/synthetic_team.hpp.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/eval/path_agreement.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/sim/synthetic_team.hpp"

namespace commerge {
namespace path_agreement_test {
namespace {

Eigen::Isometry3d RandomPose(SimRandom& rng, double sigma_m, double sigma_deg) {
  return RandomPerturbation(rng, sigma_m, sigma_deg);
}

// A wandering walk of n keyframes 1 m apart around the origin.
std::vector<Eigen::Isometry3d> Walk(SimRandom& rng, int n) {
  std::vector<Eigen::Isometry3d> poses{RandomPose(rng, 5.0, 180.0)};
  for (int k = 1; k < n; ++k) poses.push_back(poses.back() * PlanarPose(1.0, 0.0, 45.0 * kDegToRad * rng.Gaussian()));
  return poses;
}

}  // namespace

TEST_CASE("Path agreement: equals a brute force over every keyframe pair within the radius") {
  SimRandom rng(17);
  for (std::size_t stride : {std::size_t{1}, std::size_t{3}}) {
    CAPTURE(stride);
    std::vector<std::vector<Eigen::Isometry3d>> gt, est;
    for (int r = 0; r < 3; ++r) {
      gt.push_back(Walk(rng, 150));
      const Eigen::Isometry3d G = RandomPose(rng, 50.0, 90.0);  // world frame != truth frame
      std::vector<Eigen::Isometry3d> e;
      for (const Eigen::Isometry3d& T : gt.back()) e.push_back(G * T * RandomPose(rng, 0.2, 1.0));
      est.push_back(std::move(e));
    }
    std::vector<RobotPathTruth> robots;
    for (int r = 0; r < 3; ++r) robots.push_back({Span<const Eigen::Isometry3d>(est[r]), Span<const Eigen::Isometry3d>(gt[r])});
    PathAgreementParams params;
    params.keyframe_stride = stride;
    auto got = MeasurePathAgreement(Span<const RobotPathTruth>(robots), params);
    REQUIRE(got.ok());
    std::vector<double> errors;
    for (int a = 0; a < 3; ++a) {
      for (int b = a + 1; b < 3; ++b) {
        for (std::size_t i = 0; i < gt[a].size(); i += stride) {
          for (std::size_t j = 0; j < gt[b].size(); j += stride) {
            if ((gt[a][i].translation() - gt[b][j].translation()).norm() > params.radius_m) continue;
            const Eigen::Vector3d t = (gt[a][i].inverse() * gt[b][j]).translation();
            const Eigen::Vector3d e = (est[a][i].inverse() * est[b][j]).translation();
            errors.push_back((e - t).norm());
          }
        }
      }
    }
    REQUIRE(errors.size() > 50);
    std::sort(errors.begin(), errors.end());
    double sum2 = 0.0;
    for (double e : errors) sum2 += e * e;
    CHECK(got->pairs == errors.size());
    CHECK(got->rms_m == doctest::Approx(std::sqrt(sum2 / static_cast<double>(errors.size()))).epsilon(1e-6));
    const std::size_t rank = static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(errors.size()))) - 1;
    CHECK(got->p95_m == doctest::Approx(errors[rank]).epsilon(1e-5));
    CHECK(got->max_m == doctest::Approx(errors.back()).epsilon(1e-5));
  }
}

TEST_CASE("Path agreement: a whole map moved agrees exactly, one robot shifted disagrees by the shift everywhere") {
  SimRandom rng(5);
  const std::vector<Eigen::Isometry3d> gt_a = Walk(rng, 120);
  std::vector<Eigen::Isometry3d> gt_b;  // beside robot a's walk, 2 m to its left, turned 0.3 rad
  for (const Eigen::Isometry3d& T : gt_a) gt_b.push_back(T * PlanarPose(0.0, 2.0, 0.3));
  const Eigen::Isometry3d G = RandomPose(rng, 100.0, 120.0);
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  shift.translation() = Eigen::Vector3d(0.3, -0.4, 0.0);  // 0.5 m, in the world frame
  std::vector<Eigen::Isometry3d> est_a, est_b, est_b_shifted;
  for (const Eigen::Isometry3d& T : gt_a) est_a.push_back(G * T);
  for (const Eigen::Isometry3d& T : gt_b) {
    est_b.push_back(G * T);
    est_b_shifted.push_back(shift * G * T);
  }
  std::vector<RobotPathTruth> robots = {{Span<const Eigen::Isometry3d>(est_a), Span<const Eigen::Isometry3d>(gt_a)},
                                        {Span<const Eigen::Isometry3d>(est_b), Span<const Eigen::Isometry3d>(gt_b)}};
  auto same = MeasurePathAgreement(Span<const RobotPathTruth>(robots));
  REQUIRE(same.ok());
  REQUIRE(same->pairs > 0);
  CHECK(same->rms_m < 1e-9);
  robots[1].T_world_keyframe = Span<const Eigen::Isometry3d>(est_b_shifted);
  auto shifted = MeasurePathAgreement(Span<const RobotPathTruth>(robots));
  REQUIRE(shifted.ok());
  CHECK(shifted->pairs == same->pairs);
  CHECK(shifted->rms_m == doctest::Approx(0.5).epsilon(1e-6));
  CHECK(shifted->p95_m == doctest::Approx(0.5).epsilon(1e-5));
  CHECK(shifted->max_m == doctest::Approx(0.5).epsilon(1e-5));
  // A robot not placed (no world poses) is left out: no pair remains.
  robots[1].T_world_keyframe = {};
  auto alone = MeasurePathAgreement(Span<const RobotPathTruth>(robots));
  REQUIRE(alone.ok());
  CHECK(alone->pairs == 0);
}

TEST_CASE("Path agreement: bad input is refused with the robot or field named") {
  SimRandom rng(2);
  std::vector<Eigen::Isometry3d> gt = Walk(rng, 20), est = gt;
  std::vector<Eigen::Isometry3d> shorter(est.begin(), est.end() - 1);
  std::vector<RobotPathTruth> robots = {{Span<const Eigen::Isometry3d>(est), Span<const Eigen::Isometry3d>(gt)},
                                        {Span<const Eigen::Isometry3d>(shorter), Span<const Eigen::Isometry3d>(gt)}};
  CHECK(MeasurePathAgreement(Span<const RobotPathTruth>(robots)).status().message().find("robot 1 has 19 placed") !=
        std::string::npos);
  robots[1].T_world_keyframe = Span<const Eigen::Isometry3d>(est);
  est[7].translation().z() = std::nan("");
  CHECK(MeasurePathAgreement(Span<const RobotPathTruth>(robots)).status().message().find("keyframe 7") !=
        std::string::npos);
  est[7] = gt[7];
  PathAgreementParams p;
  p.radius_m = 0.0;
  CHECK(MeasurePathAgreement(Span<const RobotPathTruth>(robots), p).status().message().find("radius_m") !=
        std::string::npos);
  p = {};
  p.keyframe_stride = 0;
  CHECK(MeasurePathAgreement(Span<const RobotPathTruth>(robots), p).status().message().find("keyframe_stride") !=
        std::string::npos);
}

}  // namespace path_agreement_test
}  // namespace commerge
