// SPDX-License-Identifier: BSD-3-Clause
// Pose-graph optimisation time on synthetic multi-lap trajectories with drifting odometry.
// Usage: bench_pose_graph [--nodes N]... [--lap-nodes L] [--loop-every K] [--yaw-bias-deg-per-10m B] [--seed S]
//   default: --nodes 2000 --nodes 10000 --nodes 20000 --lap-nodes 500 --loop-every 100 --yaw-bias-deg-per-10m 0.3
// Keyframes every 1 m around a ~L m rounded-square circuit, each lap 0.5 m to the left of the previous one.
// Odometry = true relative pose * Exp(noise 1 cm / 0.02 deg per axis + yaw bias); the initial estimate chains it.
// Loops: lap m node k -> lap m-1 node k every K nodes (true relative pose * Exp(noise 2 cm / 0.05 deg)).
// Reports anchored ATE (position RMSE, first pose shared) and aligned ATE (after rigid Umeyama alignment),
// LM iterations, optimisation wall time, solver workspace, and the time of one re-optimisation after one more
// loop edge (the robot's steady-state cost per accepted loop).
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
#include "core/geometry/umeyama.hpp"
#include "core/slam/pose_graph.hpp"
#include "platform/memory/peak_rss.hpp"

namespace {

using commerge::EdgeKind;
using commerge::ExpSE3;
using commerge::kDegToRad;
using commerge::kPi;
using commerge::Matrix6d;
using commerge::PoseGraph;
using commerge::PoseGraphEdge;
using commerge::Vector6d;

struct Options {
  std::vector<int> nodes;
  int lap_nodes = 500;
  int loop_every = 100;
  double yaw_bias_deg_per_10m = 0.3;
  unsigned seed = 1;
};

struct Scenario {
  std::vector<Eigen::Isometry3d> truth;
  std::vector<Eigen::Isometry3d> initial;
  std::vector<PoseGraphEdge> edges;  // odometry then loops
  std::size_t loops = 0;
};

Vector6d Noise(std::mt19937& rng, double sigma_m, double sigma_rad) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  xi << sigma_m * n(rng), sigma_m * n(rng), sigma_m * n(rng), sigma_rad * n(rng), sigma_rad * n(rng),
      sigma_rad * n(rng);
  return xi;
}

Matrix6d Information(double sigma_m, double sigma_rad) {
  Vector6d d;
  d << Eigen::Vector3d::Constant(1.0 / (sigma_m * sigma_m)), Eigen::Vector3d::Constant(1.0 / (sigma_rad * sigma_rad));
  return d.asDiagonal();
}

Scenario MakeScenario(int num_nodes, const Options& o) {
  const int L = o.lap_nodes;
  std::vector<Eigen::Vector2d> xy(static_cast<std::size_t>(L) + 1, Eigen::Vector2d::Zero());
  std::vector<double> heading(static_cast<std::size_t>(L));
  for (int k = 0; k < L; ++k) {
    const double s = k + 0.5;
    heading[k] = 2.0 * kPi * s / L + 0.3 * std::sin(8.0 * kPi * s / L);
    xy[k + 1] = xy[k] + Eigen::Vector2d(std::cos(heading[k]), std::sin(heading[k]));
  }
  Scenario sc;
  for (int i = 0; i < num_nodes; ++i) {
    const int lap = i / L;
    const int k = i % L;
    const double yaw = heading[k];
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = commerge::RotationFromYawPitchRoll(yaw, -0.02 * std::cos(yaw), 0.01 * std::sin(2.0 * yaw));
    T.translation() << xy[k] + 0.5 * lap * Eigen::Vector2d(-std::sin(yaw), std::cos(yaw)),
        1.5 * std::sin(2.0 * kPi * k / L);
    sc.truth.push_back(T);
  }
  std::mt19937 rng(o.seed);
  const Matrix6d info = Information(0.05, 0.1 * kDegToRad);
  sc.initial.push_back(sc.truth[0]);
  for (int i = 0; i + 1 < num_nodes; ++i) {
    const Eigen::Isometry3d T_rel = sc.truth[i].inverse() * sc.truth[i + 1];
    Vector6d error = Noise(rng, 0.01, 0.02 * kDegToRad);
    error(5) += o.yaw_bias_deg_per_10m * kDegToRad / 10.0 * T_rel.translation().norm();
    PoseGraphEdge e;
    e.from = static_cast<std::uint32_t>(i);
    e.to = static_cast<std::uint32_t>(i + 1);
    e.T_from_to = T_rel * ExpSE3(error);
    e.information = info;
    sc.edges.push_back(e);
    sc.initial.push_back(sc.initial.back() * e.T_from_to);
  }
  for (int b = L; b < num_nodes; b += o.loop_every) {
    PoseGraphEdge e;
    e.from = static_cast<std::uint32_t>(b);
    e.to = static_cast<std::uint32_t>(b - L);
    e.T_from_to = sc.truth[b].inverse() * sc.truth[b - L] * ExpSE3(Noise(rng, 0.02, 0.05 * kDegToRad));
    e.information = info;
    e.kind = EdgeKind::kLoop;
    sc.edges.push_back(e);
    ++sc.loops;
  }
  return sc;
}

std::vector<Eigen::Vector3d> Positions(commerge::Span<const Eigen::Isometry3d> poses) {
  std::vector<Eigen::Vector3d> p;
  p.reserve(poses.size());
  for (const auto& T : poses) p.push_back(T.translation());
  return p;
}

void Ate(commerge::Span<const Eigen::Isometry3d> estimate, const std::vector<Eigen::Isometry3d>& truth,
         double* anchored_m, double* aligned_m) {
  const auto est = Positions(estimate);
  const auto gt = Positions(truth);
  *anchored_m = commerge::AlignmentRmseM(est, gt, Eigen::Isometry3d::Identity());
  const auto T = commerge::AlignRigid(est, gt);
  *aligned_m = T.ok() ? commerge::AlignmentRmseM(est, gt, *T) : -1.0;
}

// Wall and CPU time of a call [ms] (CPU time is the fairer figure on a loaded machine).
struct Stopwatch {
  std::chrono::steady_clock::time_point wall = std::chrono::steady_clock::now();
  std::clock_t cpu = std::clock();
  double WallMs() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wall).count();
  }
  double CpuMs() const { return 1000.0 * static_cast<double>(std::clock() - cpu) / CLOCKS_PER_SEC; }
};

int Run(int num_nodes, const Options& o) {
  const Scenario sc = MakeScenario(num_nodes, o);
  PoseGraph graph(sc.truth.size(), sc.edges.size() + 1);
  for (const auto& T : sc.initial) {
    if (!graph.AddNode(T).ok()) return 1;
  }
  for (const auto& e : sc.edges) {
    if (const commerge::Status s = graph.AddEdge(e); !s.ok()) {
      std::fprintf(stderr, "AddEdge: %s\n", s.ToString().c_str());
      return 1;
    }
  }
  double ate0 = 0, aligned0 = 0, ate1 = 0, aligned1 = 0;
  Ate(graph.poses(), sc.truth, &ate0, &aligned0);
  Stopwatch watch;
  const auto r = graph.Optimize();
  const double ms = watch.WallMs();
  const double cpu_ms = watch.CpuMs();
  if (!r.ok()) {
    std::fprintf(stderr, "Optimize: %s\n", r.status().ToString().c_str());
    return 1;
  }
  Ate(graph.poses(), sc.truth, &ate1, &aligned1);

  // Steady state: one more loop (last node -> same place one lap earlier), then re-optimise.
  PoseGraphEdge extra;
  extra.from = static_cast<std::uint32_t>(num_nodes - 1);
  extra.to = static_cast<std::uint32_t>(num_nodes - 1 - o.lap_nodes);
  extra.T_from_to = sc.truth[extra.from].inverse() * sc.truth[extra.to];
  extra.information = sc.edges.front().information;
  extra.kind = EdgeKind::kLoop;
  double re_cpu_ms = -1.0;
  int re_iterations = 0;
  std::size_t re_changed = 0;
  if (num_nodes > o.lap_nodes && graph.AddEdge(extra).ok()) {
    const Stopwatch re_watch;
    const auto r2 = graph.Optimize();
    re_cpu_ms = re_watch.CpuMs();
    if (r2.ok()) {
      re_iterations = r2->iterations;
      re_changed = r2->changed_nodes.size();
    }
  }

  std::printf("%7d %6zu %5zu | %8.3f %8.3f | %8.3f %8.3f | %3d %-3s %8.1f %8.1f | %9s %6.0f | %8.1f %3d %6zu\n",
              num_nodes, sc.edges.size(), sc.loops, ate0, ate1, aligned0, aligned1, r->iterations,
              r->converged ? "yes" : "no", cpu_ms, ms,
              commerge::FormatBytes(static_cast<std::int64_t>(r->workspace_bytes)).c_str(),
              static_cast<double>(r->workspace_bytes) / num_nodes, re_cpu_ms, re_iterations, re_changed);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (std::strcmp(argv[i], "--nodes") == 0 && has_value) {
      o.nodes.push_back(std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "--lap-nodes") == 0 && has_value) {
      o.lap_nodes = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--loop-every") == 0 && has_value) {
      o.loop_every = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--yaw-bias-deg-per-10m") == 0 && has_value) {
      o.yaw_bias_deg_per_10m = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--seed") == 0 && has_value) {
      o.seed = static_cast<unsigned>(std::atoi(argv[++i]));
    } else {
      std::fprintf(stderr,
                   "usage: %s [--nodes N]... [--lap-nodes L] [--loop-every K] [--yaw-bias-deg-per-10m B] [--seed S]\n",
                   argv[0]);
      return 2;
    }
  }
  if (o.nodes.empty()) o.nodes = {2000, 10000, 20000};
  if (o.lap_nodes < 4 || o.lap_nodes % 4 != 0 || o.loop_every < 1) {
    std::fprintf(stderr, "--lap-nodes must be a positive multiple of 4 and --loop-every >= 1\n");
    return 2;
  }
  for (const int n : o.nodes) {
    if (n < 2) {
      std::fprintf(stderr, "--nodes must be >= 2\n");
      return 2;
    }
  }
  std::printf("circuit %d m (1 m keyframes), loop every %d nodes, yaw bias %.2f deg / 10 m, seed %u\n", o.lap_nodes,
              o.loop_every, o.yaw_bias_deg_per_10m, o.seed);
  std::printf("  nodes  edges loops | ATE anchored [m]  | ATE aligned [m]   | LM it conv  CPU ms  wall ms |"
              " workspace B/node | +1 loop: CPU ms it changed\n");
  std::printf("                     |   before    after |   before    after |                             |\n");
  for (const int n : o.nodes) {
    if (Run(n, o) != 0) return 1;
  }
  std::printf("peak RSS: %s\n", commerge::FormatBytes(commerge::platform::ReadRss().peak_bytes).c_str());
  return 0;
}
