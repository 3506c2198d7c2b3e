// SPDX-License-Identifier: BSD-3-Clause
// Joint multi-robot pose graph (core/merge/joint_graph.hpp): solve time and memory on synthetic teams.
// Usage: bench_joint_graph [--robots R] [--keyframes N]... [--edge-every K] [--wrong-share W] [--reps N] [--seed S]
//   default: --robots 3 --keyframes 1000 --keyframes 10000 --edge-every 100 --wrong-share 0.3 --reps 3
// The robots walk one winding route (x = s, y = 200 sin(s / 300), 1 m keyframes; odd robots the other way, 1 m to
// the side; robot r > 1 starts 40 r m on). Odometry = the true steps with noise 5 mm / 0.002 deg per axis and a yaw
// bias of 0.001 deg/m (alternating sign). Every K keyframes of each pair's lower robot, an edge to the other's
// nearest keyframe within 3 m (truth * noise 2 cm / 0.1 deg); then wrong edges (random keyframes, 3-15 m and any yaw
// off) until they are W of all edges. Reports per size: keyframes, edges (right + wrong), edges used, wrong used,
// LM iterations (all, and those of the least-squares phase), the median CPU and wall time of SolveJointGraph over
// --reps runs (consistency check, placement, graph
// and solve), the solver workspace, and the relative-position RMS of keyframes of two robots within 10 m against
// the truth (rigid start and joint result). Peak RSS at the end.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include "core/common/bytes.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/merge/joint_graph.hpp"
#include "platform/memory/peak_rss.hpp"

namespace {

using commerge::InterRobotEdge;
using commerge::kDegToRad;
using commerge::kPi;

struct Options {
  int robots = 3;
  std::vector<int> keyframes;
  int edge_every = 100;
  double wrong_share = 0.3;
  int reps = 3;
  unsigned seed = 1;
};

Eigen::Isometry3d Noise(std::mt19937& rng, double sigma_m, double sigma_deg) {
  std::normal_distribution<double> n(0.0, 1.0);
  commerge::Vector6d xi;
  xi << sigma_m * n(rng), sigma_m * n(rng), sigma_m * n(rng), sigma_deg * kDegToRad * n(rng),
      sigma_deg * kDegToRad * n(rng), sigma_deg * kDegToRad * n(rng);
  return commerge::ExpSE3(xi);
}

Eigen::Isometry3d Pose(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

Eigen::Isometry3d RoutePose(double s, double lateral_m, bool backwards) {
  const double heading = std::atan2(200.0 / 300.0 * std::cos(s / 300.0), 1.0);
  const Eigen::Vector2d left(-std::sin(heading), std::cos(heading));
  const Eigen::Vector2d p = Eigen::Vector2d(s, 200.0 * std::sin(s / 300.0)) + lateral_m * left;
  return Pose(p.x(), p.y(), backwards ? heading + kPi : heading);
}

struct Team {
  std::vector<std::vector<Eigen::Isometry3d>> truth, maps;
  std::vector<InterRobotEdge> edges;
  std::vector<bool> wrong;
};

Team MakeTeam(const Options& o, int n) {
  std::mt19937 rng(o.seed);
  Team t;
  for (int r = 0; r < o.robots; ++r) {
    const bool back = r % 2 == 1;
    const double start = back ? n - 1.0 : (r > 1 ? 40.0 * r : 0.0);
    std::vector<Eigen::Isometry3d> truth, map;
    for (int k = 0; k < n; ++k) truth.push_back(RoutePose(back ? start - k : start + k, back ? 1.0 : 0.0, back));
    map.push_back(Eigen::Isometry3d::Identity());
    const double bias = (r % 2 ? -1.0 : 1.0) * 0.001 * kDegToRad;
    for (int k = 1; k < n; ++k) {
      map.push_back(map.back() * truth[static_cast<std::size_t>(k - 1)].inverse() * truth[static_cast<std::size_t>(k)] *
                    Pose(0.0, 0.0, bias) * Noise(rng, 0.005, 0.002));
    }
    t.truth.push_back(std::move(truth));
    t.maps.push_back(std::move(map));
  }
  for (int a = 0; a < o.robots; ++a) {
    for (int b = a + 1; b < o.robots; ++b) {
      const auto& A = t.truth[static_cast<std::size_t>(a)];
      const auto& B = t.truth[static_cast<std::size_t>(b)];
      for (int i = 0; i < n; i += o.edge_every) {
        int best = -1;
        double best_d = 3.0;
        for (int j = 0; j < n; ++j) {
          const double d = (A[static_cast<std::size_t>(i)].translation() - B[static_cast<std::size_t>(j)].translation()).norm();
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
        e.T_a_b = A[e.keyframe_a].inverse() * B[e.keyframe_b] * Noise(rng, 0.02, 0.1);
        t.edges.push_back(e);
        t.wrong.push_back(false);
      }
    }
  }
  const std::size_t right = t.edges.size();
  const auto wrong = static_cast<std::size_t>(std::lround(o.wrong_share / (1.0 - o.wrong_share) * static_cast<double>(right)));
  std::uniform_int_distribution<int> robot(0, o.robots - 1), keyframe(0, n - 1);
  std::uniform_real_distribution<double> dist(3.0, 15.0), angle(-kPi, kPi);
  while (t.edges.size() < right + wrong) {
    InterRobotEdge e;
    e.robot_a = robot(rng);
    e.robot_b = robot(rng);
    if (e.robot_a == e.robot_b) continue;
    e.keyframe_a = static_cast<std::uint32_t>(keyframe(rng));
    e.keyframe_b = static_cast<std::uint32_t>(keyframe(rng));
    const double d = dist(rng), dir = angle(rng);
    e.T_a_b = t.truth[static_cast<std::size_t>(e.robot_a)][e.keyframe_a].inverse() *
              t.truth[static_cast<std::size_t>(e.robot_b)][e.keyframe_b] * Pose(d * std::cos(dir), d * std::sin(dir), angle(rng));
    t.edges.push_back(e);
    t.wrong.push_back(true);
  }
  return t;
}

double RelativeRms(const Team& t, const std::vector<std::vector<Eigen::Isometry3d>>& T_world_keyframe) {
  double sum = 0.0;
  std::size_t count = 0;
  for (std::size_t a = 0; a < t.truth.size(); ++a) {
    for (std::size_t b = a + 1; b < t.truth.size(); ++b) {
      if (T_world_keyframe[a].empty() || T_world_keyframe[b].empty()) continue;
      for (std::size_t i = 0; i < t.truth[a].size(); i += 7) {
        for (std::size_t j = 0; j < t.truth[b].size(); j += 7) {
          const Eigen::Vector3d truth = (t.truth[a][i].inverse() * t.truth[b][j]).translation();
          if (truth.norm() > 10.0) continue;
          const Eigen::Vector3d got = (T_world_keyframe[a][i].inverse() * T_world_keyframe[b][j]).translation();
          sum += (got - truth).squaredNorm();
          ++count;
        }
      }
    }
  }
  return count ? std::sqrt(sum / static_cast<double>(count)) : -1.0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (std::strcmp(argv[i], "--robots") == 0 && has_value) {
      o.robots = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--keyframes") == 0 && has_value) {
      o.keyframes.push_back(std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "--edge-every") == 0 && has_value) {
      o.edge_every = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--wrong-share") == 0 && has_value) {
      o.wrong_share = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--reps") == 0 && has_value) {
      o.reps = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--seed") == 0 && has_value) {
      o.seed = static_cast<unsigned>(std::atoi(argv[++i]));
    } else {
      std::fprintf(stderr,
                   "usage: %s [--robots R] [--keyframes N]... [--edge-every K] [--wrong-share W] [--reps N] "
                   "[--seed S]\n",
                   argv[0]);
      return 2;
    }
  }
  if (o.keyframes.empty()) o.keyframes = {1000, 10000};
  if (o.robots < 2 || o.robots > 16 || o.edge_every < 1 || o.reps < 1 || !(o.wrong_share >= 0.0 && o.wrong_share < 0.9)) {
    std::fprintf(stderr, "--robots in [2, 16], --edge-every >= 1, --reps >= 1, --wrong-share in [0, 0.9)\n");
    return 2;
  }
  for (int n : o.keyframes) {
    if (n < 2) {
      std::fprintf(stderr, "--keyframes must be >= 2\n");
      return 2;
    }
  }
  std::printf("joint pose graph: %d robots on one route, an edge every %d keyframes where they pass, %.0f %% wrong "
              "edges, seed %u, median of %d runs\n",
              o.robots, o.edge_every, 100.0 * o.wrong_share, o.seed, o.reps);
  std::printf("%9s %7s %6s %6s %6s %3s %3s %9s %9s %11s %11s %11s\n", "keyframes", "right", "wrong", "used", "wrongU", "it",
              "ls", "CPU ms", "wall ms", "workspace", "rigid RMS", "joint RMS");
  for (int n : o.keyframes) {
    const Team t = MakeTeam(o, n);
    std::vector<double> ms, cpu_ms;
    commerge::JointGraphResult last;
    for (int rep = 0; rep < o.reps; ++rep) {
      const auto start = std::chrono::steady_clock::now();
      const std::clock_t cpu_start = std::clock();
      auto r = commerge::SolveJointGraph(
          commerge::Span<const std::vector<Eigen::Isometry3d>>(t.maps.data(), t.maps.size()),
          commerge::Span<const InterRobotEdge>(t.edges.data(), t.edges.size()));
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
      cpu_ms.push_back(1000.0 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC);
      if (!r.ok()) {
        std::fprintf(stderr, "SolveJointGraph: %s\n", r.status().ToString().c_str());
        return 1;
      }
      last = std::move(*r);
    }
    std::sort(ms.begin(), ms.end());
    std::sort(cpu_ms.begin(), cpu_ms.end());
    std::size_t right = 0, wrong = 0, used_wrong = 0;
    for (std::size_t i = 0; i < t.edges.size(); ++i) {
      (t.wrong[i] ? wrong : right) += 1;
      if (t.wrong[i] && last.verdicts[i] == commerge::JointEdgeVerdict::kUsed) ++used_wrong;
    }
    std::vector<std::vector<Eigen::Isometry3d>> rigid(t.maps.size());
    for (std::size_t r = 0; r < t.maps.size(); ++r) {
      if (!last.placed[r]) continue;
      for (const Eigen::Isometry3d& T : t.maps[r]) rigid[r].push_back(last.T_world_map[r] * T);
    }
    std::printf("%9zu %7zu %6zu %6zu %6zu %3d %3d %9.1f %9.1f %11s %9.3f m %9.3f m\n", last.nodes, right, wrong, last.used_edges,
                used_wrong, last.solve.iterations, last.least_squares_iterations, cpu_ms[cpu_ms.size() / 2], ms[ms.size() / 2], commerge::FormatBytes(last.solve.workspace_bytes).c_str(),
                RelativeRms(t, rigid), RelativeRms(t, last.T_world_keyframe));
  }
  std::printf("peak RSS: %s\n", commerge::FormatBytes(commerge::platform::ReadRss().peak_bytes).c_str());
  return 0;
}
