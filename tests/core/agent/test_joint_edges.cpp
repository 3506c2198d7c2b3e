// SPDX-License-Identifier: BSD-3-Clause
// The edges a round gives the joint pose graph (core/agent/joint_edges.hpp), against the edge formula written out
// (T_a_b = T_map_a^-1 T_alpha_beta T_map_b) and a brute-force nearest keyframe.
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <doctest/doctest.h>

#include "core/agent/joint_edges.hpp"

namespace commerge {
namespace {

Eigen::Isometry3d YawPose(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

std::vector<Eigen::Isometry3d> ChainWalk(std::mt19937* rng, std::size_t n) {
  std::uniform_real_distribution<double> turn(-0.1, 0.1);
  std::vector<Eigen::Isometry3d> out;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (std::size_t k = 0; k < n; ++k) {
    out.push_back(T);
    T = T * YawPose(1.0, 0.0, turn(*rng));
  }
  return out;
}

PairMergeResult MergedPair(int alpha, int beta, const Eigen::Isometry3d& T_alpha_beta) {
  PairMergeResult p;
  p.alpha = alpha;
  p.beta = beta;
  p.attempted = true;
  p.stop = PairStop::kNone;
  p.registration.T_target_source = T_alpha_beta;
  return p;
}

PlaceRegistration PlaceAt(std::uint32_t ka, std::uint32_t kb, bool success, const Eigen::Isometry3d& T) {
  PlaceRegistration place;
  place.alpha_keyframe = ka;
  place.beta_keyframe = kb;
  place.success = success;
  place.T_alpha_beta = T;
  return place;
}

void CheckJointEdge(const InterRobotEdge& e, int a, std::uint32_t ka, int b, std::uint32_t kb,
                    const std::vector<std::vector<Eigen::Isometry3d>>& poses, const Eigen::Isometry3d& T_alpha_beta,
                    double weight) {
  CHECK(e.weight == weight);
  CHECK(e.robot_a == a);
  CHECK(e.robot_b == b);
  CHECK(e.keyframe_a == ka);
  CHECK(e.keyframe_b == kb);
  const Eigen::Isometry3d want = poses[static_cast<std::size_t>(a)][ka].inverse() * T_alpha_beta *
                                 poses[static_cast<std::size_t>(b)][kb];
  CHECK(e.T_a_b.isApprox(want, 1e-12));
}

}  // namespace

TEST_CASE("Joint edges: each place gives the pair's transform (spread_fit_weight) and, when it succeeded, its own "
          "registration (weight 1); a pair refined nowhere gives its transform at one place; unmerged pairs and "
          "unplaced robots give none") {
  std::mt19937 rng(8);
  const std::vector<std::vector<Eigen::Isometry3d>> poses = {ChainWalk(&rng, 60), ChainWalk(&rng, 41), ChainWalk(&rng, 30),
                                                             ChainWalk(&rng, 20)};
  const Eigen::Isometry3d T01 = YawPose(3.0, -2.0, 0.4), T02 = YawPose(-5.0, 1.0, -1.1), T12 = YawPose(0.5, 0.5, 2.0);
  const Eigen::Isometry3d T01_place = YawPose(3.1, -2.05, 0.41), T01_third = YawPose(2.95, -1.9, 0.39);
  std::vector<PairMergeResult> pairs;
  // 0-1: three places, the second failed.
  pairs.push_back(MergedPair(0, 1, T01));
  pairs.back().refinement.places = {PlaceAt(10, 5, true, T01_place), PlaceAt(30, 20, false, T01),
                                    PlaceAt(50, 40, true, T01_third)};
  // 0-2: every place failed: the pair's transform at each.
  pairs.push_back(MergedPair(0, 2, T02));
  pairs.back().refinement.places = {PlaceAt(7, 9, false, T02), PlaceAt(40, 25, false, T02)};
  // 1-2: no place (refinement off): at robot 2's middle keyframe and robot 1's nearest under the transform.
  pairs.push_back(MergedPair(1, 2, T12));
  // 0-3: refused; 2-3 merged but robot 3 is not placed.
  pairs.push_back(MergedPair(0, 3, T01));
  pairs.back().stop = PairStop::kRegistration;
  pairs.push_back(MergedPair(2, 3, T01));
  const std::vector<std::uint8_t> placed = {1, 1, 1, 0};

  JointEdgeParams params;
  params.spread_fit_weight = 2.5;
  const std::vector<InterRobotEdge> edges =
      JointEdgesOf(Span<const PairMergeResult>(pairs), Span<const std::vector<Eigen::Isometry3d>>(poses),
                   Span<const std::uint8_t>(placed), params);
  REQUIRE(edges.size() == 8);
  CheckJointEdge(edges[0], 0, 10, 1, 5, poses, T01, 2.5);
  CheckJointEdge(edges[1], 0, 10, 1, 5, poses, T01_place, 1.0);
  CheckJointEdge(edges[2], 0, 30, 1, 20, poses, T01, 2.5);
  CheckJointEdge(edges[3], 0, 50, 1, 40, poses, T01, 2.5);
  CheckJointEdge(edges[4], 0, 50, 1, 40, poses, T01_third, 1.0);
  CheckJointEdge(edges[5], 0, 7, 2, 9, poses, T02, 2.5);
  CheckJointEdge(edges[6], 0, 40, 2, 25, poses, T02, 2.5);
  // Brute force: robot 1's keyframe nearest robot 2's keyframe 15 placed by T12.
  const Eigen::Vector3d q = T12 * poses[2][15].translation();
  std::uint32_t nearest = 0;
  double best = std::numeric_limits<double>::infinity();
  for (std::uint32_t k = 0; k < poses[1].size(); ++k) {
    if ((poses[1][k].translation() - q).norm() < best) {
      best = (poses[1][k].translation() - q).norm();
      nearest = k;
    }
  }
  CheckJointEdge(edges[7], 1, nearest, 2, 15, poses, T12, 2.5);

  // A place whose keyframe lies beyond the poses is skipped, not read; the default weight is decision 032's.
  std::vector<PairMergeResult> beyond = {MergedPair(0, 1, T01)};
  beyond.back().refinement.places = {PlaceAt(60, 5, true, T01), PlaceAt(12, 3, true, T01_place)};
  const std::vector<InterRobotEdge> two =
      JointEdgesOf(Span<const PairMergeResult>(beyond), Span<const std::vector<Eigen::Isometry3d>>(poses),
                   Span<const std::uint8_t>(placed));
  REQUIRE(two.size() == 2);
  CheckJointEdge(two[0], 0, 12, 1, 3, poses, T01, JointEdgeParams{}.spread_fit_weight);
  CheckJointEdge(two[1], 0, 12, 1, 3, poses, T01_place, 1.0);
}

}  // namespace commerge
