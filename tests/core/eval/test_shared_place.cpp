// SPDX-License-Identifier: BSD-3-Clause
// Which robots share a place (core/eval/shared_place.hpp), on trajectories whose answer is known by
// construction: parallel lanes nearer and farther than the radius, the shared stretch's length, opposite
// headings for a forward-looking sensor, and robots joined to robot 0 only through a chain.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "core/eval/shared_place.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "tests/support/pose_errors.hpp"

using namespace commerge;

namespace {

// Keyframes 1 m apart along x from x0 to x1 (exclusive), at lateral offset y, heading yaw.
std::vector<Eigen::Isometry3d> Lane(double x0, double x1, double y, double yaw_deg) {
  std::vector<Eigen::Isometry3d> out;
  for (double x = x0; x < x1; x += 1.0) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = RotationFromYawPitchRoll(yaw_deg * kDegToRad, 0.0, 0.0);
    T.translation() = Eigen::Vector3d(x, y, 0.0);
    out.push_back(T);
  }
  return out;
}

}  // namespace

TEST_CASE("Shared place: lanes within the radius share the overlapping stretch, farther ones do not") {
  SharedPlaceParams p;
  p.radius_m = 5.0;
  p.min_shared_path_m = 20.0;
  REQUIRE(ValidateSharedPlaceParams(p).ok());
  const auto a = Lane(0, 100, 0, 0);
  // Beta drives x = 60..160 four metres beside alpha: they share x = 60..100 (a point at x within 3 m of the
  // other lane's end still has a neighbour: sqrt(3^2 + 4^2) = 5).
  const SharedPlace near = MeasureSharedPlace(Span<const Eigen::Isometry3d>(a),
                                              Span<const Eigen::Isometry3d>(Lane(60, 160, 4, 0)), p);
  CHECK(near.shared);
  CHECK(near.alpha_path_m == doctest::Approx(43.0));  // x = 57..99 has a beta keyframe within 5 m
  CHECK(near.beta_path_m == doctest::Approx(42.0));   // x = 61..102 (60's predecessor is not counted)
  const SharedPlace far = MeasureSharedPlace(Span<const Eigen::Isometry3d>(a),
                                             Span<const Eigen::Isometry3d>(Lane(60, 160, 6, 0)), p);
  CHECK_FALSE(far.shared);
  CHECK(far.alpha_path_m == 0.0);
  // 15 m of common road is below min_shared_path_m.
  CHECK_FALSE(MeasureSharedPlace(Span<const Eigen::Isometry3d>(a), Span<const Eigen::Isometry3d>(Lane(88, 200, 0, 0)), p).shared);
}

TEST_CASE("Shared place: in a small scene a quarter of the shorter path is enough, never more than 20 m") {
  SharedPlaceParams p;  // 20 m or a quarter of the shorter robot's path
  const auto a = Lane(0, 41, 0, 0);  // 40 m of path
  // Beta drives x = 28..68: 12 m of common road, 17-18 m of path within the 5 m radius.
  const SharedPlace s = MeasureSharedPlace(Span<const Eigen::Isometry3d>(a), Span<const Eigen::Isometry3d>(Lane(28, 69, 0, 0)), p);
  CHECK(s.alpha_total_m == doctest::Approx(40.0));
  CHECK(s.beta_total_m == doctest::Approx(40.0));
  CHECK(s.alpha_path_m == doctest::Approx(18.0));  // x = 23..40
  CHECK(s.beta_path_m == doctest::Approx(17.0));   // x = 28..45 (28 has no predecessor to count)
  CHECK(s.shared);  // 17 m >= min(20, 0.25 x 40)
  p.min_shared_path_fraction = 0.0;  // the absolute 20 m alone
  CHECK_FALSE(MeasureSharedPlace(Span<const Eigen::Isometry3d>(a), Span<const Eigen::Isometry3d>(Lane(28, 69, 0, 0)), p).shared);
  // A long mission still needs 20 m: 17-18 m shared of 100 m paths is not enough (a quarter is 25 m).
  p.min_shared_path_fraction = 0.25;
  CHECK_FALSE(MeasureSharedPlace(Span<const Eigen::Isometry3d>(Lane(0, 101, 0, 0)), Span<const Eigen::Isometry3d>(Lane(88, 189, 0, 0)), p).shared);
  p.min_shared_path_fraction = 1.5;
  CHECK_FALSE(ValidateSharedPlaceParams(p).ok());
}

TEST_CASE("Shared place: the opposite direction counts for a spinning sensor, not for a forward-looking one") {
  const auto a = Lane(0, 100, 0, 0);
  const auto back = Lane(0, 100, 2, 180);
  SharedPlaceParams spinning;
  CHECK(MeasureSharedPlace(Span<const Eigen::Isometry3d>(a), Span<const Eigen::Isometry3d>(back), spinning).shared);
  SharedPlaceParams forward;
  forward.max_heading_deg = 70.0;
  CHECK_FALSE(MeasureSharedPlace(Span<const Eigen::Isometry3d>(a), Span<const Eigen::Isometry3d>(back), forward).shared);
  CHECK(MeasureSharedPlace(Span<const Eigen::Isometry3d>(a), Span<const Eigen::Isometry3d>(Lane(0, 100, 2, 60)), forward).shared);
  SharedPlaceParams bad;
  bad.max_heading_deg = 0.0;
  CHECK_FALSE(ValidateSharedPlaceParams(bad).ok());
  bad = SharedPlaceParams{};
  bad.radius_m = -1.0;
  CHECK_FALSE(ValidateSharedPlaceParams(bad).ok());
}

TEST_CASE("Shared place: robots joined to robot 0 through a chain of shared pairs are reachable") {
  // 4 robots, pairs in the order (0,1) (0,2) (0,3) (1,2) (1,3) (2,3): 0-1 and 1-2 share, 3 shares with nobody.
  const std::vector<bool> shared = {true, false, false, true, false, false};
  CHECK(ReachableFromRobot0(4, shared) == std::vector<bool>{true, true, true, false});
  // 2-3 sharing joins 3 through 1 and 2.
  CHECK(ReachableFromRobot0(4, {true, false, false, true, false, true}) == std::vector<bool>{true, true, true, true});
  CHECK(ReachableFromRobot0(3, {false, false, true}) == std::vector<bool>{true, false, false});
}

namespace {

Eigen::Isometry3d Pose(double x, double y, double z, double yaw_deg, double pitch_deg = 0.0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = RotationFromYawPitchRoll(yaw_deg * kDegToRad, pitch_deg * kDegToRad, 0.0);
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

using Poses = Span<const Eigen::Isometry3d>;
using test::InMapFrame;

}  // namespace

TEST_CASE("Truth at the shared place: without drift it is the transform between the true start poses") {
  // Two straight lanes 2 m apart sharing x = 40..80: a collinear stretch, so the rotation about the lane is
  // fixed only by the poses' axes.
  const auto ref_gt = Lane(0, 80, 0, 0), other_gt = Lane(40, 140, 2, 0);
  const Eigen::Isometry3d T_gt_ref = Pose(0, 0, 0, 0), T_gt_other = Pose(40, 2, 0.5, 30, 4);
  const auto ref_est = InMapFrame(ref_gt, T_gt_ref), other_est = InMapFrame(other_gt, T_gt_other);
  SharedPlaceParams p;
  p.radius_m = 3.0;
  Result<SharedPlaceTruth> t = TruthAtSharedPlace(Poses(ref_est), Poses(ref_gt), Poses(other_est), Poses(other_gt), p);
  REQUIRE(t.ok());
  CHECK(t->keyframe_pairs == 42);  // other's x = 40..81 have a ref keyframe within 3 m (x <= 79 + sqrt(5))
  const Eigen::Isometry3d start_truth = T_gt_ref.inverse() * T_gt_other;
  const TransformError e = ComputeTransformError(t->T_ref_other, start_truth);
  CHECK(e.translation_m < 1e-9);
  CHECK(e.rotation_deg < 1e-7);
  // The judged place is the centroid of other's shared keyframes (x = 40..81 in ground truth).
  CHECK((T_gt_other * t->p_other_place - Eigen::Vector3d(60.5, 2, 0)).norm() < 1e-9);
}

TEST_CASE("Truth at the shared place: a robot that drifted before the meeting is judged where it met") {
  // Other drives x = 100..60 away from ref's lane and then x = 60..0 along it (the shared part); its odometry
  // gained a drift D after the first leg, so its estimated map at the shared part is D times the truth.
  std::vector<Eigen::Isometry3d> other_gt;
  for (const Eigen::Isometry3d& T : Lane(60, 100, 40, 180)) other_gt.insert(other_gt.begin(), T);
  const auto leg2 = Lane(0, 60, 1, 180);
  for (auto it = leg2.rbegin(); it != leg2.rend(); ++it) other_gt.push_back(*it);
  const auto ref_gt = Lane(0, 60, 0, 0);
  const Eigen::Isometry3d T_gt_other = other_gt.front(), D = Pose(1.5, -0.8, 0.1, 2.0);
  std::vector<Eigen::Isometry3d> other_est = InMapFrame(other_gt, T_gt_other);
  for (std::size_t i = 40; i < other_est.size(); ++i) other_est[i] = D * other_est[i];
  SharedPlaceParams p;  // any heading: a spinning sensor sees the lane from both directions
  Result<SharedPlaceTruth> t =
      TruthAtSharedPlace(Poses(ref_gt), Poses(ref_gt), Poses(other_est), Poses(other_gt), p);
  REQUIRE(t.ok());
  CHECK(t->keyframe_pairs == 60);
  const Eigen::Isometry3d local_truth = T_gt_other * D.inverse(), start_truth = T_gt_other;
  CHECK(ErrorAtSharedPlace(local_truth, *t).translation_m < 1e-9);
  CHECK(ErrorAtSharedPlace(local_truth, *t).rotation_deg < 1e-7);
  // The start-pose truth is off at the meeting by what the drift moved the shared part (brute force over the
  // judged point: the centroid of other's estimated shared keyframes).
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (std::size_t i = 40; i < other_est.size(); ++i) centroid += other_est[i].translation();
  centroid /= 60.0;
  const TransformError off = ErrorAtSharedPlace(start_truth, *t);
  CHECK(off.translation_m == doctest::Approx((start_truth * centroid - local_truth * centroid).norm()).epsilon(1e-9));
  CHECK(off.translation_m > 1.0);
  CHECK(off.rotation_deg == doctest::Approx(2.0).epsilon(1e-6));
}

TEST_CASE("Truth at the shared place: restricted to a merge's keyframes it is the transform where the merge was made") {
  // Other drives ref's lane x = 0..80 the other way round, then 10 keyframes on a lane 50 m away; its odometry
  // drifts in two steps: keyframes 0..39 (x = 79..40) are D1 off the truth, keyframes 40.. D2. No rigid
  // transform fits both halves.
  const auto ref_gt = Lane(0, 80, 0, 0);
  std::vector<Eigen::Isometry3d> other_gt;
  for (const Eigen::Isometry3d& T : Lane(0, 80, 1, 180)) other_gt.insert(other_gt.begin(), T);
  for (const Eigen::Isometry3d& T : Lane(0, 10, 50, 0)) other_gt.push_back(T);
  const Eigen::Isometry3d T_gt_other = other_gt.front();
  const Eigen::Isometry3d D1 = Pose(0.2, -0.1, 0.0, 0.3), D2 = Pose(1.8, 1.1, 0.0, 3.0);
  std::vector<Eigen::Isometry3d> other_est = InMapFrame(other_gt, T_gt_other);
  for (std::size_t i = 0; i < other_est.size(); ++i) other_est[i] = (i < 40 ? D1 : D2) * other_est[i];
  SharedPlaceParams p;
  const auto truth_at = [&](const std::vector<std::uint32_t>& keyframes) {
    return TruthAtSharedPlace(Poses(ref_gt), Poses(ref_gt), Poses(other_est), Poses(other_gt), p, 3,
                              Span<const std::uint32_t>(keyframes));
  };
  std::vector<std::uint32_t> second_half, far_lane;
  for (std::uint32_t k = 50; k < 70; ++k) second_half.push_back(k);
  for (std::uint32_t k = 80; k < 90; ++k) far_lane.push_back(k);
  const Result<SharedPlaceTruth> local = truth_at(second_half), all = truth_at({});
  REQUIRE(local.ok());
  REQUIRE(all.ok());
  CHECK(local->keyframe_pairs == 20);
  CHECK(all->keyframe_pairs == 80);
  // Where the merge was made the truth is the second half's transform exactly (other_est = D2 other's map there).
  const Eigen::Isometry3d at_second_half = T_gt_other * D2.inverse();
  CHECK(ErrorAtSharedPlace(at_second_half, *local).translation_m < 1e-9);
  CHECK(ErrorAtSharedPlace(at_second_half, *local).rotation_deg < 1e-7);
  // Over every shared place the same transform is judged against a compromise of both halves (about half of
  // the 2.7 deg between D1 and D2).
  CHECK(ErrorAtSharedPlace(at_second_half, *all).rotation_deg > 1.0);
  // Keyframes at no shared place, and keyframes beyond other's poses.
  CHECK(truth_at(far_lane).status().code() == StatusCode::kNotFound);
  CHECK(truth_at({5, 90}).status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("Truth at the shared place: too few keyframes at a shared place and bad input are errors") {
  const auto a = Lane(0, 50, 0, 0), b = Lane(48, 100, 0, 0);
  SharedPlaceParams p;
  p.radius_m = 1.0;
  // b's keyframes x = 48, 49, 50 lie within 1 m of a keyframe of a (x <= 49): three pairs.
  CHECK(TruthAtSharedPlace(Poses(a), Poses(a), Poses(b), Poses(b), p, 3).ok());
  CHECK(TruthAtSharedPlace(Poses(a), Poses(a), Poses(b), Poses(b), p, 4).status().code() == StatusCode::kNotFound);
  const std::vector<Eigen::Isometry3d> shorter(a.begin(), a.end() - 1);
  CHECK(TruthAtSharedPlace(Poses(shorter), Poses(a), Poses(b), Poses(b), p).status().code() ==
        StatusCode::kInvalidArgument);
  std::vector<Eigen::Isometry3d> nan_b = b;
  nan_b[3].translation().x() = std::nan("");
  CHECK(TruthAtSharedPlace(Poses(a), Poses(a), Poses(nan_b), Poses(b), p).status().code() ==
        StatusCode::kInvalidArgument);
  p.radius_m = 0.0;
  CHECK(TruthAtSharedPlace(Poses(a), Poses(a), Poses(b), Poses(b), p).status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("Shared place: a forward-looking sensor's heading limit is its field of view, a spinning one's any heading") {
  CHECK(SharedPlaceParamsForSensor("avia").max_heading_deg == doctest::Approx(70.4));
  CHECK(SharedPlaceParamsForSensor("aeva").max_heading_deg == doctest::Approx(120.0));
  CHECK(SharedPlaceParamsForSensor("hdl-64e").max_heading_deg == 180.0);
  CHECK(SharedPlaceParamsForSensor("no-such-lidar").max_heading_deg == 180.0);
  // Only the heading depends on the sensor.
  const SharedPlaceParams avia = SharedPlaceParamsForSensor("avia");
  CHECK(avia.radius_m == SharedPlaceParams{}.radius_m);
  CHECK(avia.min_shared_path_m == SharedPlaceParams{}.min_shared_path_m);
}
