// SPDX-License-Identifier: BSD-3-Clause
// A merge against ground truth (core/eval/merge_judgement.hpp) on straight lanes whose shared places are known by
// construction: placements a known distance or angle off the truth at the place the robots met, on both sides of
// the 1 m / 3 deg criterion; a registration judged at its own keyframes or, when those lie at no shared place, over
// every shared place; the best-agreeing partner; robots that share no place; no ground truth.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "core/eval/merge_judgement.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "tests/support/pose_errors.hpp"

using namespace commerge;

namespace {

Eigen::Isometry3d JudgePose(double x, double y, double yaw_deg) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = RotationFromYawPitchRoll(yaw_deg * kDegToRad, 0.0, 0.0);
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

// Keyframes 1 m apart along x from x0 to x1 (exclusive) at lateral offset y, heading +x.
std::vector<Eigen::Isometry3d> JudgeLane(double x0, double x1, double y) {
  std::vector<Eigen::Isometry3d> out;
  for (double x = x0; x < x1; x += 1.0) out.push_back(JudgePose(x, y, 0.0));
  return out;
}

// A robot without drift: its map frame is its true start pose, its estimate the truth in that frame.
struct JudgeRobot {
  std::vector<Eigen::Isometry3d> gt, est;
  Eigen::Isometry3d T_gt_map = Eigen::Isometry3d::Identity();
};

JudgeRobot MakeJudgeRobot(std::vector<Eigen::Isometry3d> gt) {
  JudgeRobot r;
  r.gt = std::move(gt);
  r.T_gt_map = r.gt.front();
  r.est = test::InMapFrame(r.gt, r.T_gt_map);
  return r;
}

std::vector<RobotTrajectoryTruth> JudgeViews(const std::vector<JudgeRobot>& robots) {
  std::vector<RobotTrajectoryTruth> out;
  for (const JudgeRobot& r : robots) {
    out.push_back({Span<const Eigen::Isometry3d>(r.est), Span<const Eigen::Isometry3d>(r.gt), r.T_gt_map});
  }
  return out;
}

// A world translation, and a rotation by yaw_deg about the vertical through (cx, cy).
Eigen::Isometry3d JudgeShift(double dx, double dy) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(dx, dy, 0.0);
  return T;
}
Eigen::Isometry3d JudgeTurnAbout(double cx, double cy, double yaw_deg) {
  return JudgeShift(cx, cy) * JudgePose(0, 0, yaw_deg) * JudgeShift(-cx, -cy);
}

std::vector<std::uint32_t> JudgeKeyframes(std::uint32_t first, std::uint32_t last) {
  std::vector<std::uint32_t> out;
  for (std::uint32_t k = first; k <= last; ++k) out.push_back(k);
  return out;
}

// Robot 0 drives x = 0..99 on y = 0 (its start is the world origin); robot 1 x = 40..139 on y = 2: they share
// x = 40..99 (robot 1's keyframes x = 40..103 have a robot 0 keyframe within 5 m: (103 - 99)^2 + 2^2 <= 25).
std::vector<JudgeRobot> JudgeTwoRobots() {
  return {MakeJudgeRobot(JudgeLane(0, 100, 0)), MakeJudgeRobot(JudgeLane(40, 140, 2))};
}

// The verdict of robot 1 of TwoRobots placed at T_world_map1, the pair registered on robot 1's keyframes
// `keyframes_1`.
RobotVerdict VerdictOfRobot1(const Eigen::Isometry3d& T_world_map1, const std::vector<std::uint32_t>& keyframes_1,
                             bool registered = true) {
  const std::vector<JudgeRobot> robots = JudgeTwoRobots();
  const std::vector<RobotTrajectoryTruth> views = JudgeViews(robots);
  const std::vector<RobotPlacement> placements = {{true, Eigen::Isometry3d::Identity()}, {true, T_world_map1}};
  JudgedPair pair;
  pair.alpha = 0;
  pair.beta = 1;
  pair.registered = registered;
  pair.beta_keyframes = Span<const std::uint32_t>(keyframes_1);
  const std::vector<JudgedPair> pairs = {pair};
  const std::vector<RobotVerdict> v = JudgeRobots(
      Span<const RobotTrajectoryTruth>(views), Span<const RobotPlacement>(placements), Span<const JudgedPair>(pairs));
  REQUIRE(v.size() == 2);
  CHECK(v[0].merged);
  CHECK_FALSE(v[0].judged_at_place);
  CHECK_FALSE(v[0].wrong);
  return v[1];
}

}  // namespace

TEST_CASE("Merge judgement: 0.9 m off is right and 1.1 m wrong, 2.9 deg right and 3.1 deg wrong, the limits right") {
  CHECK_FALSE(IsWrongMerge({0.9, 0.0}));
  CHECK(IsWrongMerge({1.1, 0.0}));
  CHECK_FALSE(IsWrongMerge({0.0, 2.9}));
  CHECK(IsWrongMerge({0.0, 3.1}));
  CHECK_FALSE(IsWrongMerge({1.0, 3.0}));
  CHECK(IsWrongMerge({0.2, 3.1}));
  WrongMergeCriterion loose;
  loose.max_translation_m = 2.0;
  loose.max_rotation_deg = 5.0;
  CHECK_FALSE(IsWrongMerge({1.1, 3.1}, loose));
  CHECK(IsWrongMerge({2.1, 0.0}, loose));
  // The score is the larger of the two ratios to the limits.
  CHECK(WrongMergeScore({0.5, 2.4}) == doctest::Approx(0.8));
  CHECK(WrongMergeScore({1.5, 0.3}) == doctest::Approx(1.5));
  CHECK(WrongMergeScore({1.5, 0.3}, loose) == doctest::Approx(0.75));
}

TEST_CASE("Merge judgement: a pair's registered keyframes are the first pair's of the two robots, in either order") {
  const std::vector<std::uint32_t> k01_0 = {1, 2, 3}, k01_1 = {7, 8}, k21_2 = {9}, k21_1 = {10}, k12_1 = {4},
                                   k12_2 = {5};
  std::vector<JudgedPair> pairs(3);
  pairs[0] = {0, 1, true, Span<const std::uint32_t>(k01_0), Span<const std::uint32_t>(k01_1)};
  pairs[1] = {2, 1, false, Span<const std::uint32_t>(k21_2), Span<const std::uint32_t>(k21_1)};
  pairs[2] = {1, 2, true, Span<const std::uint32_t>(k12_1), Span<const std::uint32_t>(k12_2)};
  const Span<const JudgedPair> all(pairs);
  const Span<const std::uint32_t> of_0 = RegisteredKeyframes(all, 0, 1), of_1 = RegisteredKeyframes(all, 1, 0);
  CHECK(std::vector<std::uint32_t>(of_0.begin(), of_0.end()) == k01_0);
  CHECK(std::vector<std::uint32_t>(of_1.begin(), of_1.end()) == k01_1);
  // Robots 1 and 2: the first pair of the two (2-1) did not register; the later 1-2 does not count.
  CHECK(RegisteredKeyframes(all, 1, 2).empty());
  CHECK(RegisteredKeyframes(all, 2, 1).empty());
  CHECK(RegisteredKeyframes(all, 0, 2).empty());  // no such pair
  const Span<const std::uint32_t> later = RegisteredKeyframes(all.subspan(2, 1), 2, 1);
  CHECK(std::vector<std::uint32_t>(later.begin(), later.end()) == k12_2);
}

TEST_CASE("Merge judgement: shared places per pair, none at all when a robot of a pair has no ground truth") {
  std::vector<JudgeRobot> robots = JudgeTwoRobots();
  robots.push_back(MakeJudgeRobot(JudgeLane(0, 100, 300)));  // 300 m from both
  std::vector<RobotTrajectoryTruth> views = JudgeViews(robots);
  const std::vector<JudgedPair> pairs = {{0, 1, true, {}, {}}, {0, 2, false, {}, {}}, {1, 2, false, {}, {}}};
  const std::vector<SharedPlace> s =
      MeasurePairSharedPlaces(Span<const RobotTrajectoryTruth>(views), Span<const JudgedPair>(pairs), {});
  REQUIRE(s.size() == 3);
  CHECK(s[0].shared);
  CHECK(s[0].alpha_path_m == doctest::Approx(64.0));  // robot 0's x = 36..99: 36 is within 5 m of (40, 2)
  CHECK_FALSE(s[1].shared);
  CHECK_FALSE(s[2].shared);
  CHECK(s[2].alpha_path_m == 0.0);
  views[2].ground_truth = {};
  CHECK(MeasurePairSharedPlaces(Span<const RobotTrajectoryTruth>(views), Span<const JudgedPair>(pairs), {}).empty());
  const std::vector<JudgedPair> beyond = {{0, 3, false, {}, {}}};
  CHECK(MeasurePairSharedPlaces(Span<const RobotTrajectoryTruth>(views), Span<const JudgedPair>(beyond), {}).empty());
}

TEST_CASE("Merge judgement: a robot placed 0.9 m off where it met robot 0 is right, 1.1 m off is wrong") {
  const Eigen::Isometry3d truth = JudgePose(40, 2, 0);  // robot 1's start in robot 0's map
  const std::vector<std::uint32_t> met = JudgeKeyframes(10, 19);  // x = 50..59, at the shared place
  const RobotVerdict right = VerdictOfRobot1(JudgeShift(0.9, 0) * truth, met);
  CHECK(right.has_gt);
  CHECK(right.reachable);
  CHECK(right.merged);
  CHECK(right.judged_at_place);
  CHECK(right.place_partner == 0);
  CHECK(right.error_at_place.translation_m == doctest::Approx(0.9).epsilon(1e-6));
  CHECK(right.error_at_place.rotation_deg < 1e-6);
  CHECK(right.error.translation_m == doctest::Approx(0.9).epsilon(1e-6));
  CHECK_FALSE(right.wrong);
  const RobotVerdict wrong = VerdictOfRobot1(JudgeShift(0, -1.1) * truth, met);
  CHECK(wrong.judged_at_place);
  CHECK(wrong.error_at_place.translation_m == doctest::Approx(1.1).epsilon(1e-6));
  CHECK(wrong.wrong);
}

TEST_CASE("Merge judgement: turned 2.9 deg about the meeting place is right, 3.1 deg wrong, wherever the start is") {
  // The registration used robot 1's keyframes x = 90..99: the place is their centroid (94.5, 2). A turn about it
  // moves the start pose (x = 40, 54.5 m away) by 2 x 54.5 x sin(angle / 2), which alone would be wrong.
  const Eigen::Isometry3d truth = JudgePose(40, 2, 0);
  const std::vector<std::uint32_t> met = JudgeKeyframes(50, 59);
  const RobotVerdict right = VerdictOfRobot1(JudgeTurnAbout(94.5, 2, 2.9) * truth, met);
  CHECK(right.judged_at_place);
  CHECK(right.error_at_place.rotation_deg == doctest::Approx(2.9).epsilon(1e-6));
  CHECK(right.error_at_place.translation_m < 1e-6);
  CHECK(right.error.translation_m == doctest::Approx(2 * 54.5 * std::sin(1.45 * kDegToRad)).epsilon(1e-6));
  CHECK_FALSE(right.wrong);
  const RobotVerdict wrong = VerdictOfRobot1(JudgeTurnAbout(94.5, 2, -3.1) * truth, met);
  CHECK(wrong.error_at_place.rotation_deg == doctest::Approx(3.1).epsilon(1e-6));
  CHECK(wrong.error_at_place.translation_m < 1e-6);
  CHECK(wrong.wrong);
}

TEST_CASE("Merge judgement: a registration at no shared place, or none, is judged over every place the robots share") {
  // Turned 1 deg about (137, 2). Robot 1's keyframes at a place of robot 0 are x = 40..103, centroid 71.5: the
  // placement is 2 x 65.5 x sin(0.5 deg) = 1.14 m off there (wrong). At the registered keyframes x = 90..99 it
  // is 2 x 42.5 x sin(0.5 deg) = 0.74 m off (right).
  const Eigen::Isometry3d placed = JudgeTurnAbout(137, 2, 1.0) * JudgePose(40, 2, 0);
  const double at_every_place_m = 2 * 65.5 * std::sin(0.5 * kDegToRad);
  // Keyframes x = 135..139 lie at no shared place.
  const RobotVerdict elsewhere = VerdictOfRobot1(placed, JudgeKeyframes(95, 99));
  CHECK(elsewhere.judged_at_place);
  CHECK(elsewhere.error_at_place.translation_m == doctest::Approx(at_every_place_m).epsilon(1e-6));
  CHECK(elsewhere.wrong);
  // The pair did not register: its keyframes do not count.
  const RobotVerdict unregistered = VerdictOfRobot1(placed, JudgeKeyframes(50, 59), /*registered=*/false);
  CHECK(unregistered.error_at_place.translation_m == doctest::Approx(at_every_place_m).epsilon(1e-6));
  const RobotVerdict at_registered = VerdictOfRobot1(placed, JudgeKeyframes(50, 59));
  CHECK(at_registered.error_at_place.translation_m ==
        doctest::Approx(2 * 42.5 * std::sin(0.5 * kDegToRad)).epsilon(1e-6));
  CHECK_FALSE(at_registered.wrong);
}

TEST_CASE("Merge judgement: a robot that shares no place with a placed robot is judged at its start pose") {
  std::vector<JudgeRobot> robots = JudgeTwoRobots();
  robots.push_back(MakeJudgeRobot(JudgeLane(0, 100, 300)));  // shares nothing
  const std::vector<RobotTrajectoryTruth> views = JudgeViews(robots);
  const std::vector<std::uint32_t> look_alike = JudgeKeyframes(10, 19);
  JudgedPair merged02{0, 2, true, {}, Span<const std::uint32_t>(look_alike)};
  const std::vector<JudgedPair> pairs = {{0, 1, true, {}, {}}, merged02, {1, 2, false, {}, {}}};
  const Eigen::Isometry3d truth2 = JudgePose(0, 300, 0);
  // Robot 0 off its identity is still the world frame: never judged at a place, never wrong.
  std::vector<RobotPlacement> placements = {
      {true, JudgeShift(5, 0)}, {false, Eigen::Isometry3d::Identity()}, {true, JudgeShift(0, 5) * truth2}};
  std::vector<RobotVerdict> v = JudgeRobots(Span<const RobotTrajectoryTruth>(views),
                                            Span<const RobotPlacement>(placements), Span<const JudgedPair>(pairs));
  REQUIRE(v.size() == 3);
  CHECK(v[0].error.translation_m == doctest::Approx(5.0));
  CHECK_FALSE(v[0].judged_at_place);
  CHECK_FALSE(v[0].wrong);
  CHECK(v[1].reachable);  // shares a place with robot 0, but was not placed
  CHECK_FALSE(v[1].merged);
  CHECK_FALSE(v[1].wrong);
  CHECK(v[2].has_gt);
  CHECK_FALSE(v[2].reachable);
  CHECK(v[2].merged);
  CHECK_FALSE(v[2].judged_at_place);
  CHECK(v[2].place_partner == -1);
  // Its start pose against the truth of the start poses, (0, 300): placed at (0, 305).
  CHECK(v[2].error.translation_m == doctest::Approx(5.0));
  CHECK(v[2].wrong);
  placements[0].T_world_map = Eigen::Isometry3d::Identity();
  placements[2].T_world_map = JudgeShift(0.5, 0) * truth2;
  v = JudgeRobots(Span<const RobotTrajectoryTruth>(views), Span<const RobotPlacement>(placements),
                  Span<const JudgedPair>(pairs));
  CHECK(v[2].error.translation_m == doctest::Approx(0.5));
  CHECK_FALSE(v[2].wrong);
}

TEST_CASE("Merge judgement: the placed partner that agrees best decides, an unplaced robot is no partner") {
  // Robots 1 and 2 drive x = 40..139, 2 m on either side of robot 0's lane: every pair shares a place.
  std::vector<JudgeRobot> robots = JudgeTwoRobots();
  robots.push_back(MakeJudgeRobot(JudgeLane(40, 140, -2)));
  const std::vector<RobotTrajectoryTruth> views = JudgeViews(robots);
  const std::vector<JudgedPair> pairs = {{0, 1, true, {}, {}}, {0, 2, true, {}, {}}, {1, 2, true, {}, {}}};
  const Eigen::Isometry3d truth1 = JudgePose(40, 2, 0), truth2 = JudgePose(40, -2, 0);
  const auto judge = [&](const std::vector<RobotPlacement>& placements) {
    return JudgeRobots(Span<const RobotTrajectoryTruth>(views), Span<const RobotPlacement>(placements),
                       Span<const JudgedPair>(pairs));
  };
  // Both 0.5 m off robot 0 in the same direction: each agrees exactly with the other (the later partner).
  std::vector<RobotVerdict> v = judge({{true, Eigen::Isometry3d::Identity()}, {true, JudgeShift(0.5, 0) * truth1},
                                       {true, JudgeShift(0.5, 0) * truth2}});
  CHECK(v[1].place_partner == 2);
  CHECK(v[1].error_at_place.translation_m < 1e-6);
  CHECK(v[2].place_partner == 1);
  CHECK(v[1].error.translation_m == doctest::Approx(0.5));  // the start pose against robot 0 still
  // Robot 1 exact, robot 2 0.5 m off: robot 1 keeps robot 0, the first and best partner.
  v = judge({{true, Eigen::Isometry3d::Identity()}, {true, truth1}, {true, JudgeShift(0.5, 0) * truth2}});
  CHECK(v[1].place_partner == 0);
  CHECK(v[1].error_at_place.translation_m < 1e-6);
  CHECK(v[2].error_at_place.translation_m == doctest::Approx(0.5).epsilon(1e-6));  // off robot 0 and robot 1
  // Robot 1 not placed: robot 2 can only be judged against robot 0.
  v = judge({{true, Eigen::Isometry3d::Identity()}, {false, JudgeShift(0.5, 0) * truth1},
             {true, JudgeShift(0.5, 0) * truth2}});
  CHECK(v[2].place_partner == 0);
  CHECK(v[2].error_at_place.translation_m == doctest::Approx(0.5).epsilon(1e-6));
  CHECK_FALSE(v[1].merged);
  CHECK_FALSE(v[1].judged_at_place);
  // Even where an unplaced robot's identity transform would agree exactly: robots 1 and 2 start at (0, 2) and
  // (0, -2), robot 2 is placed 2 m off at (0, -4), which is robot 1's identity times the truth between them.
  const std::vector<JudgeRobot> at_origin = {MakeJudgeRobot(JudgeLane(0, 100, 0)), MakeJudgeRobot(JudgeLane(0, 100, 2)),
                                             MakeJudgeRobot(JudgeLane(0, 100, -2))};
  const std::vector<RobotTrajectoryTruth> origin_views = JudgeViews(at_origin);
  const std::vector<RobotPlacement> origin_placements = {
      {true, Eigen::Isometry3d::Identity()}, {false, Eigen::Isometry3d::Identity()}, {true, JudgePose(0, -4, 0)}};
  v = JudgeRobots(Span<const RobotTrajectoryTruth>(origin_views), Span<const RobotPlacement>(origin_placements),
                  Span<const JudgedPair>(pairs));
  CHECK(v[2].place_partner == 0);
  CHECK(v[2].error_at_place.translation_m == doctest::Approx(2.0).epsilon(1e-6));
  CHECK(v[2].wrong);
}

TEST_CASE("Merge judgement: a chain of shared pairs in any order of pairs reaches robot 0, without ground truth none") {
  // Robot 1 shares with robot 0 (x = 60..99, 4 m apart), robot 2 with robot 1 (x = 120..159), not with robot 0.
  std::vector<JudgeRobot> robots = {MakeJudgeRobot(JudgeLane(0, 100, 0)), MakeJudgeRobot(JudgeLane(60, 160, 4)),
                                    MakeJudgeRobot(JudgeLane(120, 220, 8))};
  std::vector<RobotTrajectoryTruth> views = JudgeViews(robots);
  const std::vector<RobotPlacement> placements(3);  // nothing placed
  const std::vector<JudgedPair> pairs = {{1, 2, false, {}, {}}, {0, 2, false, {}, {}}, {0, 1, false, {}, {}}};
  std::vector<RobotVerdict> v = JudgeRobots(Span<const RobotTrajectoryTruth>(views),
                                            Span<const RobotPlacement>(placements), Span<const JudgedPair>(pairs));
  CHECK(v[1].reachable);
  CHECK(v[2].reachable);
  CHECK_FALSE(v[2].merged);
  CHECK_FALSE(v[2].wrong);
  // Without the 1-2 pair robot 2 is on its own.
  v = JudgeRobots(Span<const RobotTrajectoryTruth>(views), Span<const RobotPlacement>(placements),
                  Span<const JudgedPair>(pairs).subspan(1, 2));
  CHECK(v[1].reachable);
  CHECK_FALSE(v[2].reachable);
  // No ground truth: nothing is judged, placed robots are not wrong.
  for (RobotTrajectoryTruth& r : views) r.ground_truth = {};
  const std::vector<RobotPlacement> all_placed(3, RobotPlacement{true, JudgeShift(50, 0)});
  v = JudgeRobots(Span<const RobotTrajectoryTruth>(views), Span<const RobotPlacement>(all_placed),
                  Span<const JudgedPair>(pairs));
  for (const RobotVerdict& r : v) {
    CHECK_FALSE(r.has_gt);
    CHECK_FALSE(r.reachable);
    CHECK(r.merged);
    CHECK_FALSE(r.judged_at_place);
    CHECK_FALSE(r.wrong);
  }
}
