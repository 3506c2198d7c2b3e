// SPDX-License-Identifier: BSD-3-Clause
// The joint multi-robot pose graph against ground truth: three robots walk one winding route (one of them the
// other way), their odometry drifts (a yaw bias and noise), registrations where they pass each other are the
// truth's relative poses with noise. References: the truth (the relative position of the robots' keyframes where
// they are within 10 m, the measure of issue 57), the rigid merge of the same maps, and the clean solution (only
// right edges) that wrong edges must not move.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/merge/frame_solver.hpp"
#include "core/merge/joint_graph.hpp"

namespace commerge {
namespace joint_graph_test {
namespace {

Eigen::Isometry3d Noise(std::mt19937& rng, double sigma_m, double sigma_deg) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  xi << sigma_m * n(rng), sigma_m * n(rng), sigma_m * n(rng), sigma_deg * kDegToRad * n(rng),
      sigma_deg * kDegToRad * n(rng), sigma_deg * kDegToRad * n(rng);
  return ExpSE3(xi);
}

Eigen::Isometry3d Pose(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

// The route: x = s, y = 20 sin(s / 30), heading along it; `lateral_m` to its left.
Eigen::Isometry3d RoutePose(double s, double lateral_m, bool backwards) {
  const double dy = 20.0 / 30.0 * std::cos(s / 30.0);
  const double heading = std::atan2(dy, 1.0);
  const Eigen::Vector2d left(-std::sin(heading), std::cos(heading));
  const Eigen::Vector2d p = Eigen::Vector2d(s, 20.0 * std::sin(s / 30.0)) + lateral_m * left;
  return Pose(p.x(), p.y(), backwards ? heading + kPi : heading);
}

struct Team {
  std::vector<std::vector<Eigen::Isometry3d>> truth;  // T_world_keyframe
  std::vector<std::vector<Eigen::Isometry3d>> maps;   // T_map_keyframe: the robots' drifted odometry
  std::vector<InterRobotEdge> right;
};

// Robots 0 and 2 walk the route forwards (2 starting 40 m on), robot 1 backwards 1 m to the side, 300 keyframes
// 1 m apart each; odometry = the true steps with noise (5 mm / 0.01 deg) and a yaw bias of +-0.005 deg/m. Every
// `every` keyframes of the lower robot of each pair, an edge to the other's nearest keyframe (within 3 m) with noise
// 2 cm / 0.1 deg.
Team MakeTeam(unsigned seed, int every = 15) {
  std::mt19937 rng(seed);
  Team t;
  const int n = 300;
  const double start[3] = {0.0, 299.0, 40.0};
  const double bias_deg[3] = {0.005, -0.005, 0.004};
  for (int r = 0; r < 3; ++r) {
    std::vector<Eigen::Isometry3d> truth, map;
    for (int k = 0; k < n; ++k) {
      const double s = r == 1 ? start[r] - k : start[r] + k;
      truth.push_back(RoutePose(s, r == 1 ? 1.0 : 0.0, r == 1));
    }
    map.push_back(Eigen::Isometry3d::Identity());
    for (int k = 1; k < n; ++k) {
      const Eigen::Isometry3d step = truth[static_cast<std::size_t>(k - 1)].inverse() * truth[static_cast<std::size_t>(k)];
      map.push_back(map.back() * step * Pose(0.0, 0.0, bias_deg[r] * kDegToRad) * Noise(rng, 0.005, 0.01));
    }
    t.truth.push_back(std::move(truth));
    t.maps.push_back(std::move(map));
  }
  for (int a = 0; a < 3; ++a) {
    for (int b = a + 1; b < 3; ++b) {
      for (int i = 0; i < n; i += every) {
        int best = -1;
        double best_d = 3.0;
        for (int j = 0; j < n; ++j) {
          const double d = (t.truth[static_cast<std::size_t>(a)][static_cast<std::size_t>(i)].translation() -
                            t.truth[static_cast<std::size_t>(b)][static_cast<std::size_t>(j)].translation())
                               .norm();
          if (d < best_d) {
            best_d = d;
            best = j;
          }
        }
        if (best < 0) continue;
        InterRobotEdge e;
        e.robot_a = a;
        e.robot_b = b;
        e.keyframe_a = static_cast<std::uint32_t>(i);
        e.keyframe_b = static_cast<std::uint32_t>(best);
        e.T_a_b = t.truth[static_cast<std::size_t>(a)][e.keyframe_a].inverse() *
                  t.truth[static_cast<std::size_t>(b)][e.keyframe_b] * Noise(rng, 0.02, 0.1);
        t.right.push_back(e);
      }
    }
  }
  return t;
}

// Wrong edges: random keyframes of a random pair, related by a transform 3-15 m and any yaw from the truth's.
std::vector<InterRobotEdge> WrongEdges(const Team& t, std::size_t count, std::mt19937& rng) {
  std::uniform_int_distribution<int> robot(0, 2), keyframe(0, 299);
  std::uniform_real_distribution<double> dist(3.0, 15.0), angle(-kPi, kPi);
  std::vector<InterRobotEdge> out;
  while (out.size() < count) {
    InterRobotEdge e;
    e.robot_a = robot(rng);
    e.robot_b = robot(rng);
    if (e.robot_a == e.robot_b) continue;
    e.keyframe_a = static_cast<std::uint32_t>(keyframe(rng));
    e.keyframe_b = static_cast<std::uint32_t>(keyframe(rng));
    const double d = dist(rng), dir = angle(rng);
    e.T_a_b = t.truth[static_cast<std::size_t>(e.robot_a)][e.keyframe_a].inverse() *
              t.truth[static_cast<std::size_t>(e.robot_b)][e.keyframe_b] *
              Pose(d * std::cos(dir), d * std::sin(dir), angle(rng));
    out.push_back(e);
  }
  return out;
}

// Over every pair of keyframes of two different robots within 10 m of each other in the truth: the RMS error of
// their relative position (the second in the first's frame, so no frame's choice enters) in `T_world_keyframe`
// against the truth's.
double RelativeRms(const Team& t, const std::vector<std::vector<Eigen::Isometry3d>>& T_world_keyframe) {
  double sum = 0.0;
  std::size_t count = 0;
  for (std::size_t a = 0; a < t.truth.size(); ++a) {
    for (std::size_t b = a + 1; b < t.truth.size(); ++b) {
      for (std::size_t i = 0; i < t.truth[a].size(); i += 3) {
        for (std::size_t j = 0; j < t.truth[b].size(); j += 3) {
          const Eigen::Vector3d truth = (t.truth[a][i].inverse() * t.truth[b][j]).translation();
          if (truth.norm() > 10.0) continue;
          const Eigen::Vector3d got = (T_world_keyframe[a][i].inverse() * T_world_keyframe[b][j]).translation();
          sum += (got - truth).squaredNorm();
          ++count;
        }
      }
    }
  }
  REQUIRE(count > 100);
  return std::sqrt(sum / static_cast<double>(count));
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

Span<const std::vector<Eigen::Isometry3d>> Maps(const Team& t) {
  return Span<const std::vector<Eigen::Isometry3d>>(t.maps.data(), t.maps.size());
}

}  // namespace

TEST_CASE("Joint graph: right edges along a shared route bring the robots' relative positions closer to the truth "
          "than the rigid merge") {
  for (unsigned seed : {1u, 2u, 3u}) {
    CAPTURE(seed);
    const Team t = MakeTeam(seed);
    REQUIRE(t.right.size() >= 30);
    REQUIRE(t.right.size() <= kFrameSolverMaxMeasurements);
    auto result = SolveJointGraph(Maps(t), Span<const InterRobotEdge>(t.right.data(), t.right.size()));
    REQUIRE(result.ok());
    CHECK(result->used_edges == t.right.size());
    CHECK(std::all_of(result->verdicts.begin(), result->verdicts.end(),
                      [](JointEdgeVerdict v) { return v == JointEdgeVerdict::kUsed; }));
    CHECK(result->solve.final_cost <= result->solve.initial_cost);
    // The rigid merge (the server's frame solver over the same registrations read as map transforms, every one
    // accepted): each robot's map as it is, one transform per robot.
    std::vector<FrameMeasurement> measurements;
    for (const InterRobotEdge& e : t.right) {
      FrameMeasurement m;
      m.robot_a = e.robot_a;
      m.robot_b = e.robot_b;
      m.T_a_b = t.maps[static_cast<std::size_t>(e.robot_a)][e.keyframe_a] * e.T_a_b *
                t.maps[static_cast<std::size_t>(e.robot_b)][e.keyframe_b].inverse();
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
      for (const Eigen::Isometry3d& T : t.maps[r]) rigid[r].push_back(frames->robots[r].T_world_map * T);
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
    const Team t = MakeTeam(seed);
    auto clean = SolveJointGraph(Maps(t), Span<const InterRobotEdge>(t.right.data(), t.right.size()));
    REQUIRE(clean.ok());
    std::mt19937 rng(seed * 7919u);
    for (double wrong_share : {0.2, 0.5, -1.0}) {
      CAPTURE(wrong_share);
      std::vector<InterRobotEdge> edges = t.right;
      std::vector<InterRobotEdge> wrong;
      if (wrong_share > 0.0) {
        const auto count = static_cast<std::size_t>(std::lround(wrong_share / (1.0 - wrong_share) *
                                                                static_cast<double>(t.right.size())));
        wrong = WrongEdges(t, count, rng);
      } else {
        // Three wrong edges that agree with each other: robot 1's map placed 8 m and 20 deg off, read at three
        // nearby keyframes of each robot.
        const Eigen::Isometry3d T_world_map1_wrong = clean->T_world_map[1] * Pose(8.0, 0.0, 20.0 * kDegToRad);
        for (std::uint32_t k : {100u, 104u, 108u}) {
          wrong.push_back(EdgeFromMapTransform(0, k, t.maps[0][k], 1, 300 - 1 - k, t.maps[1][300 - 1 - k],
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
      CHECK(used >= t.right.size() * 9 / 10);
      const double moved = LargestMove(*result, *clean);
      MESSAGE("seed " << seed << ", wrong " << wrong.size() << ": used " << used << " (" << used_wrong
                      << " wrong), largest move from the clean solution " << moved << " m");
      CHECK(moved <= 0.1);
    }
  }
}

TEST_CASE("Joint graph: a pair whose edges all disagree keeps none, a single edge is used, robots not reached stay "
          "out") {
  const Team t = MakeTeam(9);
  std::mt19937 rng(9);
  // Robots 0 and 1: two edges that disagree (one right, one 10 m off); robot 2 joined by one right edge to 0.
  std::vector<InterRobotEdge> edges;
  for (const InterRobotEdge& e : t.right) {
    if (e.robot_a == 0 && e.robot_b == 1 && edges.empty()) edges.push_back(e);
  }
  REQUIRE(edges.size() == 1);
  InterRobotEdge off = edges[0];
  off.T_a_b = off.T_a_b * Pose(10.0, 0.0, 0.0);
  edges.push_back(off);
  for (const InterRobotEdge& e : t.right) {
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
  CHECK(result->nodes == 600);
  // A single edge is satisfied exactly: robot 2's keyframe sits where the edge puts it from robot 0's.
  const Eigen::Isometry3d implied = result->T_world_keyframe[0][edges[2].keyframe_a] * edges[2].T_a_b;
  CHECK((implied.translation() - result->T_world_keyframe[2][edges[2].keyframe_b].translation()).norm() < 1e-3);
  CHECK(result->residuals[2] < 1e-3);
  CHECK(result->residuals[0] == -1.0);
}

TEST_CASE("Joint graph: EdgeFromMapTransform reads a map transform at two keyframes") {
  std::mt19937 rng(3);
  const Eigen::Isometry3d T_mapa_ka = Noise(rng, 20.0, 60.0), T_mapb_kb = Noise(rng, 20.0, 60.0);
  const Eigen::Isometry3d T_mapa_mapb = Noise(rng, 30.0, 90.0);
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
  const Team t = MakeTeam(1, 100);
  const auto solve = [&](std::vector<InterRobotEdge> edges, JointGraphParams p = {}) {
    return SolveJointGraph(Maps(t), Span<const InterRobotEdge>(edges.data(), edges.size()), p).status();
  };
  InterRobotEdge e = t.right.front();
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
  JointGraphParams p;
  p.max_nodes = 899;
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
  std::vector<std::vector<Eigen::Isometry3d>> nan_pose = t.maps;
  nan_pose[2][17].translation().y() = std::nan("");
  CHECK(SolveJointGraph(Span<const std::vector<Eigen::Isometry3d>>(nan_pose.data(), nan_pose.size()), {})
            .status()
            .message()
            .find("robot 2 keyframe 17") != std::string::npos);
}

}  // namespace joint_graph_test
}  // namespace commerge
