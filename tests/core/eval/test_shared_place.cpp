// SPDX-License-Identifier: BSD-3-Clause
// Which robots share a place (core/eval/shared_place.hpp), on trajectories whose answer is known by
// construction: parallel lanes nearer and farther than the radius, the shared stretch's length, opposite
// headings for a forward-looking sensor, and robots joined to robot 0 only through a chain.
#include <doctest/doctest.h>

#include <vector>

#include "core/eval/shared_place.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

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
