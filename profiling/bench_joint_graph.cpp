// SPDX-License-Identifier: BSD-3-Clause
// Joint multi-robot pose graph (core/merge/joint_graph.hpp): solve time and memory on synthetic teams.
// Usage: bench_joint_graph [--robots R] [--keyframes N]... [--edge-every K] [--wrong-share W] [--reps N] [--seed S]
//   default: --robots 3 --keyframes 1000 --keyframes 10000 --edge-every 100 --wrong-share 0.3 --reps 3
// The team of core/sim/synthetic_team.hpp on the route y = 200 sin(s / 300): odometry noise 5 mm / 0.002 deg per
// axis and a yaw bias of 0.001 deg/m; every K keyframes of each pair's lower robot, an edge to the other's nearest
// keyframe within 3 m (truth * noise 2 cm / 0.1 deg); then wrong edges until they are W of all edges. Reports per size: keyframes, edges (right + wrong), edges used, wrong used,
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
#include <string>
#include <vector>

#include "core/common/bytes.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/eval/path_agreement.hpp"
#include "core/merge/joint_graph.hpp"
#include "core/sim/synthetic_team.hpp"
#include "platform/memory/peak_rss.hpp"

namespace {

using commerge::InterRobotEdge;

struct Options {
  int robots = 3;
  std::vector<int> keyframes;
  int edge_every = 100;
  double wrong_share = 0.3;
  int reps = 3;
  unsigned seed = 1;
};

commerge::SyntheticTeamParams TeamParams(const Options& o, int n) {
  commerge::SyntheticTeamParams p;
  p.robots = o.robots;
  p.keyframes = n;
  p.route_amplitude_m = 200.0;
  p.route_wavelength_m = 300.0;
  p.yaw_bias_deg_per_m = 0.001;
  p.step_noise_deg = 0.002;
  p.edge_every = o.edge_every;
  p.seed = o.seed;
  return p;
}

// The relative-position RMS of two robots' keyframes within 10 m (core/eval/path_agreement.hpp, every 7th keyframe).
double RelativeRms(const commerge::SyntheticTeam& t, const std::vector<std::vector<Eigen::Isometry3d>>& T_world_keyframe) {
  std::vector<commerge::RobotPathTruth> robots;
  for (std::size_t r = 0; r < t.T_gt_keyframe.size(); ++r) {
    robots.push_back({commerge::Span<const Eigen::Isometry3d>(T_world_keyframe[r]),
                      commerge::Span<const Eigen::Isometry3d>(t.T_gt_keyframe[r])});
  }
  commerge::PathAgreementParams params;
  params.keyframe_stride = 7;
  auto a = commerge::MeasurePathAgreement(commerge::Span<const commerge::RobotPathTruth>(robots), params);
  return a.ok() && a->pairs > 0 ? a->rms_m : -1.0;
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
  std::printf("%9s %6s %7s %6s %6s %6s %3s %3s %9s %9s %11s %11s %11s\n", "keyframes", "nodes", "right", "wrong", "used", "wrongU", "it",
              "ls", "CPU ms", "wall ms", "workspace", "rigid RMS", "joint RMS");
  for (int n : o.keyframes) {
    const commerge::SyntheticTeam team = commerge::MakeSyntheticTeam(TeamParams(o, n));
    const std::size_t right_count = team.right_edges.size();
    const auto wrong_count = static_cast<std::size_t>(
        std::lround(o.wrong_share / (1.0 - o.wrong_share) * static_cast<double>(right_count)));
    std::vector<InterRobotEdge> edges = team.right_edges;
    for (const InterRobotEdge& e : commerge::MakeWrongEdges(team, wrong_count, o.seed + 1)) edges.push_back(e);
    std::vector<double> ms, cpu_ms;
    commerge::JointGraphResult last;
    for (int rep = 0; rep < o.reps; ++rep) {
      const auto start = std::chrono::steady_clock::now();
      const std::clock_t cpu_start = std::clock();
      auto r = commerge::SolveJointGraph(
          commerge::Span<const std::vector<Eigen::Isometry3d>>(team.T_map_keyframe.data(), team.T_map_keyframe.size()),
          commerge::Span<const InterRobotEdge>(edges.data(), edges.size()));
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
    std::size_t used_wrong = 0;
    for (std::size_t i = right_count; i < edges.size(); ++i) used_wrong += last.verdicts[i] == commerge::JointEdgeVerdict::kUsed;
    std::vector<std::vector<Eigen::Isometry3d>> rigid(team.T_map_keyframe.size());
    for (std::size_t r = 0; r < rigid.size(); ++r) {
      if (!last.placed[r]) continue;
      for (const Eigen::Isometry3d& T : team.T_map_keyframe[r]) rigid[r].push_back(last.T_world_map[r] * T);
    }
    std::printf("%9zu %6zu %7zu %6zu %6zu %6zu %3d %3d %9.1f %9.1f %11s %9.3f m %9.3f m\n", static_cast<std::size_t>(o.robots) * static_cast<std::size_t>(n), last.nodes, right_count, wrong_count, last.used_edges,
                used_wrong, last.solve.iterations, last.least_squares_iterations, cpu_ms[cpu_ms.size() / 2], ms[ms.size() / 2], commerge::FormatBytes(last.solve.workspace_bytes).c_str(),
                RelativeRms(team, rigid), RelativeRms(team, last.T_world_keyframe));
  }
  std::printf("peak RSS: %s\n", commerge::FormatBytes(commerge::platform::ReadRss().peak_bytes).c_str());
  return 0;
}
