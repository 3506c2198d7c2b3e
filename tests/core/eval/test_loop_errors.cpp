// SPDX-License-Identifier: BSD-3-Clause
// Intra-robot loops against ground truth (core/eval/loop_errors.hpp): the error of a loop measured with a known
// offset, the false-loop limits on both sides, and the summary's count, median and maximum on hand-made errors.
#include <doctest/doctest.h>

#include <vector>

#include "core/eval/loop_errors.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

using namespace commerge;

namespace {

// x, y, z [m] and a yaw [deg].
Eigen::Isometry3d LoopTestPose(double x, double y, double z, double yaw_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = RotationFromYawPitchRoll(yaw_deg * kDegToRad, 0.0, 0.0);
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

}  // namespace

TEST_CASE("Loop errors: an exact loop has no error, a measurement's error is its offset in the query's frame") {
  // Both keyframes face +y (yaw 90 deg); the query lies 5 m further along world y: in the match's frame, 5 m
  // ahead along its x axis, same orientation.
  const Eigen::Isometry3d gt_match = LoopTestPose(10, 0, 0, 90), gt_query = LoopTestPose(10, 5, 0, 90);
  const Eigen::Isometry3d T_true = LoopTestPose(5, 0, 0, 0);
  const Eigen::Isometry3d exact = LoopErrorTransform(T_true, gt_match, gt_query);
  CHECK(exact.translation().norm() < 1e-12);
  CHECK(RotationAngleDeg(exact) < 1e-6);
  // Measured T = T_true * O: the error is O itself (not its inverse, whose translation would be the rotated
  // -(1, 0, 0)).
  const Eigen::Isometry3d O = LoopTestPose(1, 0, 0, 10);
  const Eigen::Isometry3d error = LoopErrorTransform(T_true * O, gt_match, gt_query);
  CHECK((error.translation() - Eigen::Vector3d(1, 0, 0)).norm() < 1e-12);
  CHECK(RotationAngleDeg(error) == doctest::Approx(10.0).epsilon(1e-9));
  // Swapping match and query is a different loop: the same measurement is far off.
  CHECK(LoopErrorTransform(T_true, gt_query, gt_match).translation().norm() == doctest::Approx(10.0));
}

TEST_CASE("Loop errors: a loop is false beyond 2 m or 10 deg of error and right at or within them") {
  CHECK_FALSE(IsFalseLoop(LoopTestPose(1.9, 0, 0, 0)));
  CHECK(IsFalseLoop(LoopTestPose(2.1, 0, 0, 0)));
  CHECK_FALSE(IsFalseLoop(LoopTestPose(0, 2.0, 0, 0)));  // exactly at the limit
  CHECK(IsFalseLoop(LoopTestPose(0, 1.5, 1.5, 0)));       // 2.12 m in y and z together
  CHECK_FALSE(IsFalseLoop(LoopTestPose(0, 0, 0, 9.9)));
  CHECK(IsFalseLoop(LoopTestPose(0, 0, 0, 10.1)));
  CHECK(IsFalseLoop(LoopTestPose(0, 0, 0, -10.1)));  // either direction
  FalseLoopCriterion strict;
  strict.max_translation_m = 0.5;
  strict.max_rotation_deg = 1.0;
  CHECK(IsFalseLoop(LoopTestPose(0.6, 0, 0, 0), strict));
  CHECK(IsFalseLoop(LoopTestPose(0, 0, 0, 1.1), strict));
  CHECK_FALSE(IsFalseLoop(LoopTestPose(0.4, 0, 0, 0.9), strict));
}

TEST_CASE("Loop errors: the summary counts the false loops and takes the upper median and the largest translation") {
  // Translations 0.1, 0.4, 3.0 (false), 0.2 and 0.3 with a 12 deg turn (false): sorted 0.1 0.2 0.3 0.4 3.0.
  const std::vector<Eigen::Isometry3d> odd = {LoopTestPose(0.1, 0, 0, 0), LoopTestPose(0, 0.4, 0, 0),
                                              LoopTestPose(0, 0, 3.0, 0), LoopTestPose(0.2, 0, 0, 1),
                                              LoopTestPose(0.3, 0, 0, 12)};
  const LoopErrors e = SummarizeLoopErrors(Span<const Eigen::Isometry3d>(odd));
  CHECK(e.checked == 5);
  CHECK(e.wrong == 2);
  CHECK(e.median_m == doctest::Approx(0.3));
  CHECK(e.max_m == doctest::Approx(3.0));
  // An even count takes the upper of the two middle ones: 0.1 0.2 | 0.3 0.4 -> 0.3.
  const std::vector<Eigen::Isometry3d> even = {LoopTestPose(0.1, 0, 0, 0), LoopTestPose(0.4, 0, 0, 0),
                                               LoopTestPose(0.2, 0, 0, 0), LoopTestPose(0.3, 0, 0, 0)};
  const LoopErrors f = SummarizeLoopErrors(Span<const Eigen::Isometry3d>(even));
  CHECK(f.checked == 4);
  CHECK(f.wrong == 0);
  CHECK(f.median_m == doctest::Approx(0.3));
  CHECK(f.max_m == doctest::Approx(0.4));
  // A stricter criterion counts more false loops of the same errors.
  FalseLoopCriterion strict;
  strict.max_translation_m = 0.25;
  CHECK(SummarizeLoopErrors(Span<const Eigen::Isometry3d>(even), strict).wrong == 2);
}

TEST_CASE("Loop errors: a robot with ground truth and no loops has 0 checked, one without has -1") {
  const LoopErrors none = SummarizeLoopErrors({});
  CHECK(none.checked == 0);
  CHECK(none.wrong == 0);
  CHECK(none.median_m == 0.0);
  CHECK(none.max_m == 0.0);
  CHECK(LoopErrors{}.checked == -1);
}
