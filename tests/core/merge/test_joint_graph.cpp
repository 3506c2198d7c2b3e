// SPDX-License-Identifier: BSD-3-Clause
// The joint multi-robot pose graph against ground truth: three robots walk one winding route (one of them the
// other way), their odometry drifts (a yaw bias and noise), registrations where they pass each other are the
// truth's relative poses with noise (core/sim/synthetic_team.hpp). References: the truth (the relative position of the robots' keyframes where
// they are within 10 m, the measure of issue 57), the rigid merge of the same maps, and the clean solution (only
// right edges) that wrong edges must not move.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/merge/frame_solver.hpp"
#include "core/eval/path_agreement.hpp"
#include "core/merge/joint_graph.hpp"
#include "core/sim/synthetic_team.hpp"

namespace commerge {
namespace joint_graph_test {
namespace {

Eigen::Isometry3d Pose(double x, double y, double yaw) { return PlanarPose(x, y, yaw); }

// Three robots, 300 keyframes each on one winding route (core/sim/synthetic_team.hpp): robot 1 the other way, robot
// 2 from 80 m on; yaw bias +-0.005 deg/m; an edge every `every` keyframes where two robots pass within 3 m.
SyntheticTeam MakeTeam(unsigned seed, int every = 15) {
  SyntheticTeamParams p;
  p.seed = seed;
  p.edge_every = every;
  return MakeSyntheticTeam(p);
}

// The measure (core/eval/path_agreement.hpp, tested against a brute force): the RMS error of the relative
// position of two robots' keyframes within 10 m of each other.
double RelativeRms(const SyntheticTeam& t, const std::vector<std::vector<Eigen::Isometry3d>>& T_world_keyframe) {
  std::vector<RobotPathTruth> robots;
  for (std::size_t r = 0; r < t.T_gt_keyframe.size(); ++r) {
    robots.push_back({Span<const Eigen::Isometry3d>(T_world_keyframe[r]), Span<const Eigen::Isometry3d>(t.T_gt_keyframe[r])});
  }
  auto a = MeasurePathAgreement(Span<const RobotPathTruth>(robots));
  REQUIRE(a.ok());
  REQUIRE(a->pairs > 100);
  return a->rms_m;
}

double LargestMove(const JointGraphResult& a, const JointGraphResult& b) {
  double worst = 0.0;
  for (std::size_t r = 0; r < a.T_world_keyframe.size(); ++r) {
    REQUIRE(a.T_world_keyframe[r].size() == b.T_world_keyframe[r].size());
    for (std::size_t k = 0; k < a.T_world_keyframe[r].size(); ++k) {
      worst = std::max(worst, (a.T_world_keyframe[r][k].translation() - b.T_world_keyframe[r][k].translation()).norm());
    }
  }
  return worst;
}

// Two robots, 20 keyframes each 1 m apart along x of their own map frames; robot 1's map has it 5 m along y.
std::vector<std::vector<Eigen::Isometry3d>> TwoStraightRobots() {
  std::vector<std::vector<Eigen::Isometry3d>> maps(2);
  for (int k = 0; k < 20; ++k) {
    maps[0].push_back(Pose(static_cast<double>(k), 0.0, 0.0));
    maps[1].push_back(Pose(static_cast<double>(k), 5.0, 0.0));
  }
  return maps;
}

Span<const std::vector<Eigen::Isometry3d>> Maps(const SyntheticTeam& t) {
  return Span<const std::vector<Eigen::Isometry3d>>(t.T_map_keyframe.data(), t.T_map_keyframe.size());
}

}  // namespace

TEST_CASE("Joint graph: right edges along a shared route bring the robots' relative positions closer to the truth "
          "than the rigid merge") {
  for (unsigned seed : {1u, 2u, 3u}) {
    CAPTURE(seed);
    const SyntheticTeam t = MakeTeam(seed);
    REQUIRE(t.right_edges.size() >= 30);
    REQUIRE(t.right_edges.size() <= kFrameSolverMaxMeasurements);
    auto result = SolveJointGraph(Maps(t), Span<const InterRobotEdge>(t.right_edges.data(), t.right_edges.size()));
    REQUIRE(result.ok());
    CHECK(result->used_edges == t.right_edges.size());
    CHECK(std::all_of(result->verdicts.begin(), result->verdicts.end(),
                      [](JointEdgeVerdict v) { return v == JointEdgeVerdict::kUsed; }));
    CHECK(result->solve.final_cost <= result->solve.initial_cost);
    // The rigid merge (the server's frame solver over the same registrations read as map transforms, every one
    // accepted): each robot's map as it is, one transform per robot.
    std::vector<FrameMeasurement> measurements;
    for (const InterRobotEdge& e : t.right_edges) {
      FrameMeasurement m;
      m.robot_a = e.robot_a;
      m.robot_b = e.robot_b;
      m.T_a_b = t.T_map_keyframe[static_cast<std::size_t>(e.robot_a)][e.keyframe_a] * e.T_a_b *
                t.T_map_keyframe[static_cast<std::size_t>(e.robot_b)][e.keyframe_b].inverse();
      measurements.push_back(m);
    }
    FrameSolverParams fp;
    fp.max_translation_m = 20.0;
    fp.max_rotation_deg = 20.0;
    auto frames = SolveRobotFrames(3, Span<const FrameMeasurement>(measurements.data(), measurements.size()), fp);
    REQUIRE(frames.ok());
    CHECK(frames->rejected == 0);
    std::vector<std::vector<Eigen::Isometry3d>> rigid(3);
    for (std::size_t r = 0; r < 3; ++r) {
      REQUIRE(result->placed[r]);
      for (const Eigen::Isometry3d& T : t.T_map_keyframe[r]) rigid[r].push_back(frames->robots[r].T_world_map * T);
    }
    const double joint_rms = RelativeRms(t, result->T_world_keyframe);
    const double rigid_rms = RelativeRms(t, rigid);
    MESSAGE("seed " << seed << ": relative position RMS within 10 m, rigid " << rigid_rms << " m, joint "
                    << joint_rms << " m");
    CHECK(joint_rms < 0.5 * rigid_rms);
    CHECK(joint_rms <= 0.15);
  }
}

TEST_CASE("Joint graph: 20 % and 50 % wrong edges, and a consistent cluster of three, move no robot 0.1 m from the "
          "clean solution") {
  for (unsigned seed : {4u, 5u, 6u}) {
    CAPTURE(seed);
    const SyntheticTeam t = MakeTeam(seed);
    auto clean = SolveJointGraph(Maps(t), Span<const InterRobotEdge>(t.right_edges.data(), t.right_edges.size()));
    REQUIRE(clean.ok());
    for (double wrong_share : {0.2, 0.5, -1.0}) {
      CAPTURE(wrong_share);
      std::vector<InterRobotEdge> edges = t.right_edges;
      std::vector<InterRobotEdge> wrong;
      if (wrong_share > 0.0) {
        const auto count = static_cast<std::size_t>(std::lround(wrong_share / (1.0 - wrong_share) *
                                                                static_cast<double>(t.right_edges.size())));
        wrong = MakeWrongEdges(t, count, seed * 7919u);
      } else {
        // Three wrong edges that agree with each other: robot 1's map placed 8 m and 20 deg off, read at three
        // nearby keyframes of each robot.
        const Eigen::Isometry3d T_world_map1_wrong = clean->T_world_map[1] * Pose(8.0, 0.0, 20.0 * kDegToRad);
        for (std::uint32_t k : {100u, 104u, 108u}) {
          wrong.push_back(EdgeFromMapTransform(0, k, t.T_map_keyframe[0][k], 1, 300 - 1 - k, t.T_map_keyframe[1][300 - 1 - k],
                                               T_world_map1_wrong));
        }
      }
      // Wrong edges spread among the right ones (the order must not matter).
      for (std::size_t i = 0; i < wrong.size(); ++i) {
        edges.insert(edges.begin() + static_cast<std::ptrdiff_t>((i * 7) % (edges.size() + 1)), wrong[i]);
      }
      auto result = SolveJointGraph(Maps(t), Span<const InterRobotEdge>(edges.data(), edges.size()));
      REQUIRE(result.ok());
      std::size_t used = 0, used_wrong = 0;
      for (std::size_t i = 0; i < edges.size(); ++i) {
        if (result->verdicts[i] != JointEdgeVerdict::kUsed) continue;
        ++used;
        const bool is_wrong = std::any_of(wrong.begin(), wrong.end(), [&](const InterRobotEdge& w) {
          return w.robot_a == edges[i].robot_a && w.keyframe_a == edges[i].keyframe_a &&
                 w.robot_b == edges[i].robot_b && w.keyframe_b == edges[i].keyframe_b &&
                 w.T_a_b.isApprox(edges[i].T_a_b);
        });
        used_wrong += is_wrong ? 1 : 0;
      }
      REQUIRE(used > 0);
      CHECK(static_cast<double>(used - used_wrong) >= 0.99 * static_cast<double>(used));
      CHECK(used >= t.right_edges.size() * 9 / 10);
      const double moved = LargestMove(*result, *clean);
      MESSAGE("seed " << seed << ", wrong " << wrong.size() << ": used " << used << " (" << used_wrong
                      << " wrong), largest move from the clean solution " << moved << " m");
      CHECK(moved <= 0.1);
    }
  }
}

TEST_CASE("Joint graph: a pair whose edges all disagree keeps none, a single edge is used, robots not reached stay "
          "out") {
  const SyntheticTeam t = MakeTeam(9);
  // Robots 0 and 1: two edges that disagree (one right, one 10 m off); robot 2 joined by one right edge to 0.
  std::vector<InterRobotEdge> edges;
  for (const InterRobotEdge& e : t.right_edges) {
    if (e.robot_a == 0 && e.robot_b == 1 && edges.empty()) edges.push_back(e);
  }
  REQUIRE(edges.size() == 1);
  InterRobotEdge off = edges[0];
  off.T_a_b = off.T_a_b * Pose(10.0, 0.0, 0.0);
  edges.push_back(off);
  for (const InterRobotEdge& e : t.right_edges) {
    if (e.robot_a == 0 && e.robot_b == 2) {
      edges.push_back(e);
      break;
    }
  }
  REQUIRE(edges.size() == 3);
  auto result = SolveJointGraph(Maps(t), Span<const InterRobotEdge>(edges.data(), edges.size()));
  REQUIRE(result.ok());
  CHECK(result->verdicts[0] == JointEdgeVerdict::kInconsistent);
  CHECK(result->verdicts[1] == JointEdgeVerdict::kInconsistent);
  CHECK(result->verdicts[2] == JointEdgeVerdict::kUsed);
  CHECK(result->placed == std::vector<std::uint8_t>{1, 0, 1});
  CHECK(result->T_world_keyframe[1].empty());
  CHECK(result->T_world_keyframe[2].size() == 300);
  CHECK(result->nodes < 600);  // robots 0 and 2, every 5th keyframe, the last and the anchor
  // A single edge is satisfied exactly: robot 2's keyframe sits where the edge puts it from robot 0's.
  const Eigen::Isometry3d implied = result->T_world_keyframe[0][edges[2].keyframe_a] * edges[2].T_a_b;
  CHECK((implied.translation() - result->T_world_keyframe[2][edges[2].keyframe_b].translation()).norm() < 1e-3);
  CHECK(result->residuals[2] < 1e-3);
  CHECK(result->residuals[0] == -1.0);
}

TEST_CASE("Joint graph: nodes every 5th keyframe agree with the truth as well as the graph of all keyframes, every "
          "keyframe within 0.1 m of it") {
  for (unsigned seed : {1u, 2u}) {
    CAPTURE(seed);
    const SyntheticTeam t = MakeTeam(seed);
    const Span<const InterRobotEdge> edges(t.right_edges.data(), t.right_edges.size());
    JointGraphParams every;
    every.node_stride = 1;
    auto all = SolveJointGraph(Maps(t), edges, every);
    auto fifth = SolveJointGraph(Maps(t), edges);  // the default, node_stride 5
    REQUIRE(all.ok());
    REQUIRE(fifth.ok());
    CHECK(all->nodes == 900);
    CHECK(fifth->nodes < 300);
    double worst_m = 0.0, worst_deg = 0.0;
    for (std::size_t r = 0; r < 3; ++r) {
      REQUIRE(fifth->T_world_keyframe[r].size() == 300);
      for (std::size_t k = 0; k < 300; ++k) {
        const Eigen::Isometry3d d = all->T_world_keyframe[r][k].inverse() * fifth->T_world_keyframe[r][k];
        worst_m = std::max(worst_m, d.translation().norm());
        worst_deg = std::max(worst_deg, LogSO3(d.linear()).norm() / kDegToRad);
      }
    }
    const double rms_all = RelativeRms(t, all->T_world_keyframe), rms_fifth = RelativeRms(t, fifth->T_world_keyframe);
    MESSAGE("seed " << seed << ": nodes " << fifth->nodes << " of 900, largest difference " << worst_m << " m, "
                    << worst_deg << " deg; relative-position RMS " << rms_all << " / " << rms_fifth << " m");
    CHECK(worst_m <= 0.1);
    CHECK(worst_deg <= 0.5);
    CHECK(rms_fifth <= 1.05 * rms_all);
  }
}

TEST_CASE("Joint graph: two edges at one place meet at their weighted mean (weights 1 and 3: three quarters of the "
          "way)") {
  // Two straight 20-keyframe robots joined only at keyframe 10 of each, by two edges 0.06 m apart along x: nothing
  // else fixes robot 1, so least squares puts it at the weighted mean of the two (the Cauchy kernel of width 3
  // barely discounts residuals of 0.45 and 0.26 sigma: within 2 mm of it).
  const std::vector<std::vector<Eigen::Isometry3d>> maps = TwoStraightRobots();
  InterRobotEdge light, heavy;
  light.robot_a = heavy.robot_a = 0;
  light.robot_b = heavy.robot_b = 1;
  light.keyframe_a = heavy.keyframe_a = light.keyframe_b = heavy.keyframe_b = 10;
  light.T_a_b = Pose(0.0, 2.0, 0.0);
  heavy.T_a_b = Pose(0.06, 2.0, 0.0);
  const auto x_at = [&](double light_weight, double heavy_weight) -> Eigen::Vector3d {
    std::vector<InterRobotEdge> edges = {light, heavy};
    edges[0].weight = light_weight;
    edges[1].weight = heavy_weight;
    auto result = SolveJointGraph(Span<const std::vector<Eigen::Isometry3d>>(maps.data(), maps.size()),
                                  Span<const InterRobotEdge>(edges.data(), edges.size()));
    REQUIRE(result.ok());
    REQUIRE(result->used_edges == 2);
    return (result->T_world_keyframe[0][10].inverse() * result->T_world_keyframe[1][10]).translation();
  };
  const Eigen::Vector3d even = x_at(1.0, 1.0), weighted = x_at(1.0, 3.0);
  CHECK(std::abs(even.x() - 0.03) < 2e-3);
  CHECK(std::abs(weighted.x() - 0.045) < 2e-3);
  CHECK(std::abs(weighted.y() - 2.0) < 1e-3);
}

TEST_CASE("Joint graph: a pair keeps its heaviest agreeing set: two right edges of weight 2 outweigh three wrong ones "
          "that agree with each other, which outnumber them at weight 1") {
  const std::vector<std::vector<Eigen::Isometry3d>> maps = TwoStraightRobots();
  const Eigen::Isometry3d T_right = Eigen::Isometry3d::Identity(), T_wrong = Pose(8.0, 0.0, 0.35);
  const auto edges_with = [&](double right_weight) {
    std::vector<InterRobotEdge> edges;
    for (std::uint32_t k : {2u, 6u, 8u, 10u, 14u}) {
      const bool right = k == 2u || k == 14u;
      edges.push_back(EdgeFromMapTransform(0, k, maps[0][k], 1, k, maps[1][k], right ? T_right : T_wrong));
      edges.back().weight = right ? right_weight : 1.0;
    }
    return edges;
  };
  for (double right_weight : {1.0, 2.0}) {
    CAPTURE(right_weight);
    const std::vector<InterRobotEdge> edges = edges_with(right_weight);
    auto result = SolveJointGraph(Span<const std::vector<Eigen::Isometry3d>>(maps.data(), maps.size()),
                                  Span<const InterRobotEdge>(edges.data(), edges.size()));
    REQUIRE(result.ok());
    const bool right_kept = right_weight > 1.5;  // 2 x 2 > 3 x 1; 2 x 1 < 3 x 1
    for (std::size_t i = 0; i < edges.size(); ++i) {
      const bool right = i == 0 || i == 4;
      CHECK((result->verdicts[i] == JointEdgeVerdict::kUsed) == (right == right_kept));
    }
    const Eigen::Isometry3d T_world_map1 = result->T_world_keyframe[1][0] * maps[1][0].inverse();
    const Eigen::Isometry3d& want = right_kept ? T_right : T_wrong;
    CHECK((T_world_map1.translation() - want.translation()).norm() < 1e-3);
  }
}

TEST_CASE("Joint graph: EdgeFromMapTransform reads a map transform at two keyframes") {
  SimRandom rng(3);
  const Eigen::Isometry3d T_mapa_ka = RandomPerturbation(rng, 20.0, 60.0), T_mapb_kb = RandomPerturbation(rng, 20.0, 60.0);
  const Eigen::Isometry3d T_mapa_mapb = RandomPerturbation(rng, 30.0, 90.0);
  const InterRobotEdge e = EdgeFromMapTransform(2, 5, T_mapa_ka, 4, 7, T_mapb_kb, T_mapa_mapb);
  CHECK(e.robot_a == 2);
  CHECK(e.robot_b == 4);
  CHECK(e.keyframe_a == 5);
  CHECK(e.keyframe_b == 7);
  // The point p in b's map is T_mapa_mapb p in a's map, whichever way it is read.
  const Eigen::Vector3d p(1.0, -2.0, 3.0);
  const Eigen::Vector3d in_kb = T_mapb_kb.inverse() * p;
  CHECK(((T_mapa_ka * (e.T_a_b * in_kb)) - T_mapa_mapb * p).norm() < 1e-9);
}

TEST_CASE("Joint graph: bad input is refused with the value named") {
  const SyntheticTeam t = MakeTeam(1, 100);
  const auto solve = [&](std::vector<InterRobotEdge> edges, JointGraphParams p = {}) {
    return SolveJointGraph(Maps(t), Span<const InterRobotEdge>(edges.data(), edges.size()), p).status();
  };
  InterRobotEdge e = t.right_edges.front();
  InterRobotEdge bad = e;
  bad.robot_b = 3;
  CHECK(solve({bad}).message().find("robot 3 out of range") != std::string::npos);
  bad = e;
  bad.robot_b = bad.robot_a;
  CHECK(solve({bad}).message().find("both ends") != std::string::npos);
  bad = e;
  bad.keyframe_b = 300;
  CHECK(solve({bad}).message().find("keyframe") != std::string::npos);
  bad = e;
  bad.T_a_b.translation().x() = std::nan("");
  CHECK(solve({bad}).message().find("edge 0: T_a_b") != std::string::npos);
  bad = e;
  bad.T_a_b.linear() *= 1.01;
  CHECK(solve({bad}).code() == StatusCode::kInvalidArgument);
  for (double weight : {0.0, -1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    bad = e;
    bad.weight = weight;
    CHECK(solve({bad}).message().find("edge 0: weight") != std::string::npos);
  }
  JointGraphParams p;
  p.max_nodes = 899;  // keyframes, whatever the node stride
  const Status big = solve({e}, p);
  CHECK(big.code() == StatusCode::kResourceExhausted);
  CHECK(big.message().find("900 keyframes") != std::string::npos);
  p = {};
  p.max_edges_per_pair = 1;
  CHECK(solve({e, e}, p).message().find("max_edges_per_pair") != std::string::npos);
  p = {};
  p.consistency_m = 0.0;
  CHECK(solve({e}, p).message().find("consistency_m") != std::string::npos);
  p = {};
  p.drift_per_m = -1.0;
  CHECK(solve({e}, p).message().find("drift_per_m") != std::string::npos);
  std::vector<std::vector<Eigen::Isometry3d>> none;
  CHECK(SolveJointGraph(Span<const std::vector<Eigen::Isometry3d>>(none.data(), 0), {}).status().code() ==
        StatusCode::kInvalidArgument);
  std::vector<std::vector<Eigen::Isometry3d>> nan_pose = t.T_map_keyframe;
  nan_pose[2][17].translation().y() = std::nan("");
  CHECK(SolveJointGraph(Span<const std::vector<Eigen::Isometry3d>>(nan_pose.data(), nan_pose.size()), {})
            .status()
            .message()
            .find("robot 2 keyframe 17") != std::string::npos);
}

}  // namespace joint_graph_test
}  // namespace commerge
