// SPDX-License-Identifier: BSD-3-Clause
// Inter-robot alignment RMSE (paper eq. rmsemetric) and transform errors, against ground truth: estimated
// trajectories are the ground truth expressed in each robot's own (arbitrarily placed) map frame, so the true
// inter-robot transform gives zero error and known perturbations give hand-computed errors.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/eval/alignment_metrics.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/geometry/umeyama.hpp"
#include "tests/support/pose_errors.hpp"

namespace commerge {
namespace {

using test::InMapFrame;

Eigen::Isometry3d MakePose(double x, double y, double z, double yaw, double pitch = 0.0, double roll = 0.0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = RotationFromYawPitchRoll(yaw, pitch, roll);
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

// A curved drive with some height change, `count` poses, heading along the path.
std::vector<Eigen::Isometry3d> CurvedTrajectory(double x0, double y0, double heading0, std::size_t count) {
  std::vector<Eigen::Isometry3d> poses;
  double x = x0, y = y0, yaw = heading0;
  for (std::size_t i = 0; i < count; ++i) {
    const double s = static_cast<double>(i);
    poses.push_back(MakePose(x, y, 0.3 * std::sin(0.2 * s), yaw, 0.02 * std::sin(0.3 * s), 0.01 * std::cos(0.5 * s)));
    x += 2.0 * std::cos(yaw);
    y += 2.0 * std::sin(yaw);
    yaw += 0.12 * std::sin(0.15 * s);
  }
  return poses;
}

Eigen::Isometry3d Translation(const Eigen::Vector3d& d) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = d;
  return T;
}

struct TwoRobots {
  std::vector<Eigen::Isometry3d> alpha_gt, beta_gt, alpha_est, beta_est;
  Eigen::Isometry3d T_gt_alpha, T_gt_beta, T_alpha_beta;
};

TwoRobots MakeTwoRobots(std::vector<Eigen::Isometry3d> alpha_gt) {
  TwoRobots r;
  r.alpha_gt = std::move(alpha_gt);
  r.beta_gt = CurvedTrajectory(-30.0, 45.0, -0.7, 25);
  // Each robot's map frame sits somewhere in gt (not at its first pose), with a tilt.
  r.T_gt_alpha = MakePose(12.0, -7.0, 1.5, 0.9, 0.05, -0.03);
  r.T_gt_beta = MakePose(-40.0, 20.0, -2.0, -2.2, -0.04, 0.06);
  r.alpha_est = InMapFrame(r.alpha_gt, r.T_gt_alpha);
  r.beta_est = InMapFrame(r.beta_gt, r.T_gt_beta);
  r.T_alpha_beta = r.T_gt_alpha.inverse() * r.T_gt_beta;
  return r;
}

Result<InterRobotAlignment> Rmse(const TwoRobots& r, const Eigen::Isometry3d& T_alpha_beta) {
  return InterRobotAlignmentRmse(r.alpha_est, r.alpha_gt, r.beta_est, r.beta_gt, T_alpha_beta);
}

double TransformDistance(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff();
}

}  // namespace

TEST_CASE("ComputeTransformError gives the offset norm and the rotation angle of a known perturbation") {
  const Eigen::Isometry3d T_ref = MakePose(3.0, -4.0, 1.0, 0.8, 0.2, -0.1);
  const Eigen::Vector3d d(0.3, -0.4, 1.2);  // |d| = 1.3
  const double angle = 7.5 * kPi / 180.0;
  Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
  delta.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d(1.0, 2.0, 2.0).normalized()).toRotationMatrix();
  delta.translation() = d;
  const TransformError e = ComputeTransformError(T_ref * delta, T_ref);
  CHECK(e.translation_m == doctest::Approx(1.3).epsilon(1e-12));
  CHECK(e.rotation_deg == doctest::Approx(7.5).epsilon(1e-9));
  const TransformError zero = ComputeTransformError(T_ref, T_ref);
  CHECK(zero.translation_m == 0.0);
  CHECK(zero.rotation_deg < 1e-6);
  Eigen::Isometry3d bad = T_ref;
  bad.translation().x() = std::numeric_limits<double>::quiet_NaN();
  CHECK(std::isnan(ComputeTransformError(bad, T_ref).translation_m));
}

TEST_CASE("Inter-robot RMSE is zero for the true transform and exactly the offset norm for a translated one") {
  const TwoRobots r = MakeTwoRobots(CurvedTrajectory(5.0, 3.0, 0.4, 30));
  const Result<InterRobotAlignment> exact = Rmse(r, r.T_alpha_beta);
  REQUIRE(exact.ok());
  CHECK(exact->rmse_m < 1e-9);
  CHECK(exact->max_error_m < 1e-9);
  CHECK(exact->alpha_rmse_m < 1e-9);
  CHECK(exact->count == 25);
  CHECK_FALSE(exact->used_orientations);
  // Alpha's estimate is noise-free, so the Umeyama alignment is alpha's true map frame.
  CHECK(TransformDistance(exact->T_gt_alpha, r.T_gt_alpha) < 1e-9);

  // A pure translation d in alpha's frame moves every beta pose by R_gt_alpha d: error |d| everywhere.
  const Eigen::Vector3d d(1.5, -2.0, 0.5);
  const Result<InterRobotAlignment> left = Rmse(r, Translation(d) * r.T_alpha_beta);
  REQUIRE(left.ok());
  CHECK(left->rmse_m == doctest::Approx(d.norm()).epsilon(1e-9));
  CHECK(left->max_error_m == doctest::Approx(d.norm()).epsilon(1e-9));
  // The same offset in beta's frame: R_gt_beta d, again |d|.
  const Result<InterRobotAlignment> right = Rmse(r, r.T_alpha_beta * Translation(d));
  REQUIRE(right.ok());
  CHECK(right->rmse_m == doctest::Approx(d.norm()).epsilon(1e-9));
  CHECK(right->alpha_rmse_m < 1e-9);
}

TEST_CASE("Inter-robot RMSE of a rotated transform matches the chord lengths computed by hand") {
  const TwoRobots r = MakeTwoRobots(CurvedTrajectory(5.0, 3.0, 0.4, 30));
  // Rotating beta's map by theta about its own z axis moves beta's position p (in beta's frame) by
  // |Rz p - p| = 2 sin(theta / 2) |p_xy|.
  const double theta = 3.0 * kPi / 180.0;
  Eigen::Isometry3d rot = Eigen::Isometry3d::Identity();
  rot.linear() = Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  double sum_sq = 0.0, max_e = 0.0;
  for (const auto& T : r.beta_est) {
    const double e = 2.0 * std::sin(theta / 2.0) * T.translation().head<2>().norm();
    sum_sq += e * e;
    max_e = std::max(max_e, e);
  }
  const double expected = std::sqrt(sum_sq / static_cast<double>(r.beta_est.size()));
  const Result<InterRobotAlignment> got = Rmse(r, r.T_alpha_beta * rot);
  REQUIRE(got.ok());
  CHECK(expected > 1.0);
  CHECK(got->rmse_m == doctest::Approx(expected).epsilon(1e-9));
  CHECK(got->max_error_m == doctest::Approx(max_e).epsilon(1e-9));
}

TEST_CASE("Inter-robot RMSE with a noisy alpha trajectory reports alpha's own Umeyama fit") {
  TwoRobots r = MakeTwoRobots(CurvedTrajectory(5.0, 3.0, 0.4, 30));
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (auto& T : r.alpha_est) T.translation() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  const Result<InterRobotAlignment> got = Rmse(r, r.T_alpha_beta);
  REQUIRE(got.ok());
  // Reference: the Umeyama fit of alpha's positions, computed here, and e_rmse evaluated with it.
  std::vector<Eigen::Vector3d> est, gt;
  for (std::size_t i = 0; i < r.alpha_est.size(); ++i) {
    est.push_back(r.alpha_est[i].translation());
    gt.push_back(r.alpha_gt[i].translation());
  }
  const Result<UmeyamaResult> fit = Umeyama(est, gt);
  REQUIRE(fit.ok());
  CHECK(got->alpha_rmse_m == doctest::Approx(fit->rmse_m).epsilon(1e-9));
  CHECK(got->alpha_rmse_m > 0.03);
  double sum_sq = 0.0;
  for (std::size_t j = 0; j < r.beta_est.size(); ++j) {
    sum_sq += (fit->T_target_source * r.T_alpha_beta * r.beta_est[j].translation() - r.beta_gt[j].translation())
                  .squaredNorm();
  }
  CHECK(got->rmse_m == doctest::Approx(std::sqrt(sum_sq / 25.0)).epsilon(1e-9));
  // The alignment is close to alpha's true map frame; the error it leaves on beta is small but not zero.
  CHECK((got->T_gt_alpha.translation() - r.T_gt_alpha.translation()).norm() < 0.5);
  CHECK(got->rmse_m > 0.0);
  CHECK(got->rmse_m < 0.5);
}

TEST_CASE("Inter-robot RMSE on a straight-line alpha trajectory falls back to the pose axes") {
  // Alpha drives straight along a tilted line: its positions alone leave the roll about the line free.
  std::vector<Eigen::Isometry3d> line;
  for (int i = 0; i < 20; ++i) line.push_back(MakePose(2.0 * i, 1.0 * i, 0.1 * i, std::atan2(1.0, 2.0)));
  const TwoRobots r = MakeTwoRobots(line);
  std::vector<Eigen::Vector3d> est, gt;
  for (std::size_t i = 0; i < r.alpha_est.size(); ++i) {
    est.push_back(r.alpha_est[i].translation());
    gt.push_back(r.alpha_gt[i].translation());
  }
  REQUIRE_FALSE(AlignRigid(est, gt).ok());  // positions-only Umeyama is degenerate here

  const Result<InterRobotAlignment> exact = Rmse(r, r.T_alpha_beta);
  REQUIRE_MESSAGE(exact.ok(), exact.status().ToString());
  CHECK(exact->used_orientations);
  CHECK(TransformDistance(exact->T_gt_alpha, r.T_gt_alpha) < 1e-9);
  CHECK(exact->rmse_m < 1e-9);
  CHECK(exact->alpha_rmse_m < 1e-9);
  const Eigen::Vector3d d(-0.6, 0.0, 0.8);  // |d| = 1
  const Result<InterRobotAlignment> shifted = Rmse(r, Translation(d) * r.T_alpha_beta);
  REQUIRE(shifted.ok());
  CHECK(shifted->rmse_m == doctest::Approx(1.0).epsilon(1e-9));
  CHECK(shifted->max_error_m == doctest::Approx(1.0).epsilon(1e-9));
}

TEST_CASE("Inter-robot RMSE rejects mismatched, short and non-finite inputs naming them") {
  const TwoRobots r = MakeTwoRobots(CurvedTrajectory(5.0, 3.0, 0.4, 30));
  auto message = [](const Result<InterRobotAlignment>& res) {
    REQUIRE_FALSE(res.ok());
    CHECK(res.status().code() == StatusCode::kInvalidArgument);
    return res.status().message();
  };
  std::vector<Eigen::Isometry3d> short_beta_gt(r.beta_gt.begin(), r.beta_gt.end() - 1);
  std::string m = message(InterRobotAlignmentRmse(r.alpha_est, r.alpha_gt, r.beta_est, short_beta_gt, r.T_alpha_beta));
  CHECK(m.find("beta_ground_truth") != std::string::npos);
  CHECK(m.find("24") != std::string::npos);

  std::vector<Eigen::Isometry3d> two(r.alpha_est.begin(), r.alpha_est.begin() + 2);
  std::vector<Eigen::Isometry3d> two_gt(r.alpha_gt.begin(), r.alpha_gt.begin() + 2);
  m = message(InterRobotAlignmentRmse(two, two_gt, r.beta_est, r.beta_gt, r.T_alpha_beta));
  CHECK(m.find("alpha_estimated") != std::string::npos);
  CHECK(m.find("at least 3") != std::string::npos);

  std::vector<Eigen::Isometry3d> nan_beta = r.beta_est;
  nan_beta[2].translation().y() = std::numeric_limits<double>::infinity();
  m = message(InterRobotAlignmentRmse(r.alpha_est, r.alpha_gt, nan_beta, r.beta_gt, r.T_alpha_beta));
  CHECK(m.find("beta_estimated pose 2") != std::string::npos);

  Eigen::Isometry3d nan_T = r.T_alpha_beta;
  nan_T.linear()(1, 1) = std::numeric_limits<double>::quiet_NaN();
  m = message(Rmse(r, nan_T));
  CHECK(m.find("T_alpha_beta") != std::string::npos);

  InterRobotAlignmentParams params;
  params.axis_offset_m = 0.0;
  CHECK(ValidateInterRobotAlignmentParams(params).message().find("axis_offset_m") != std::string::npos);
  params = InterRobotAlignmentParams{};
  params.collinear_ratio = 1.0;
  m = message(InterRobotAlignmentRmse(r.alpha_est, r.alpha_gt, r.beta_est, r.beta_gt, r.T_alpha_beta, params));
  CHECK(m.find("collinear_ratio") != std::string::npos);
}

}  // namespace commerge
