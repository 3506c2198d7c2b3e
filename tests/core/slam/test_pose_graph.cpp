// SPDX-License-Identifier: BSD-3-Clause
// Pose-graph optimisation: analytic Jacobians vs finite differences, the drift-correction acceptance test on a
// synthetic two-lap trajectory with ground truth, consistency (nothing to do), incremental use, the robust
// kernel, and every rejection path (capacity, bad edges, disconnected nodes, bad parameters).
//
// ATE here = RMSE of keyframe positions against ground truth with the first pose anchored (node 0 starts at its
// ground-truth pose and is held fixed), plus the same after rigid Umeyama alignment (reported, also asserted).
#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/geometry/umeyama.hpp"
#include "core/memory/budget.hpp"
#include "core/slam/pose_graph.hpp"

namespace commerge {
namespace {

struct ScenarioParams {
  int approach_nodes = 20;  ///< straight spur from the depot into the circuit (a tree part: never moves)
  int lap_nodes = 300;      ///< 1 m keyframes: a ~300 m circuit; must be divisible by 4 (closure by symmetry)
  int laps = 2;
  int loop_every = 5;                    ///< loop edge lap m-1 -> lap m every this many keyframes
  double yaw_bias_deg_per_10m = 0.5;     ///< systematic odometry drift
  double odom_noise_m = 0.01;            ///< per axis, per edge
  double odom_noise_deg = 0.02;          ///< per axis, per edge
  double loop_noise_m = 0.02;
  double loop_noise_deg = 0.05;
  bool reverse_loops = false;  ///< loop edges point from the later to the earlier node
  unsigned seed = 7;
};

struct Scenario {
  std::vector<Eigen::Isometry3d> T_map_truth;
  std::vector<Eigen::Isometry3d> T_map_initial;  // chained noisy odometry from the true first pose
  std::vector<PoseGraphEdge> odometry;
  std::vector<PoseGraphEdge> loops;
  int approach_nodes = 0;
};

Matrix6d Information(double sigma_m, double sigma_rad) {
  Vector6d d;
  d << Eigen::Vector3d::Constant(1.0 / (sigma_m * sigma_m)), Eigen::Vector3d::Constant(1.0 / (sigma_rad * sigma_rad));
  return d.asDiagonal();
}

Vector6d Noise(std::mt19937& rng, double sigma_m, double sigma_rad) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  xi << sigma_m * n(rng), sigma_m * n(rng), sigma_m * n(rng), sigma_rad * n(rng), sigma_rad * n(rng),
      sigma_rad * n(rng);
  return xi;
}

// A rounded-square circuit (heading 2 pi s / L + 0.3 sin(8 pi s / L), closed by its 4-fold symmetry) with a
// gentle hill, driven `laps` times, each lap 0.5 m further left; reached by a straight approach.
Scenario MakeScenario(const ScenarioParams& p) {
  Scenario sc;
  sc.approach_nodes = p.approach_nodes;
  const int L = p.lap_nodes;
  std::vector<Eigen::Vector2d> xy(static_cast<std::size_t>(L) + 1, Eigen::Vector2d::Zero());
  std::vector<double> heading(static_cast<std::size_t>(L));
  for (int k = 0; k < L; ++k) {
    const double s = k + 0.5;
    heading[k] = 2.0 * kPi * s / L + 0.3 * std::sin(8.0 * kPi * s / L);
    xy[k + 1] = xy[k] + Eigen::Vector2d(std::cos(heading[k]), std::sin(heading[k]));
  }
  const auto pose = [&](const Eigen::Vector2d& at, double yaw, double z, double lateral_m) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = RotationFromYawPitchRoll(yaw, -0.02 * std::cos(yaw), 0.01 * std::sin(2.0 * yaw));
    T.translation() << at + lateral_m * Eigen::Vector2d(-std::sin(yaw), std::cos(yaw)), z;
    return T;
  };
  for (int j = 0; j < p.approach_nodes; ++j) {
    const double back = p.approach_nodes - j;
    sc.T_map_truth.push_back(pose(xy[0] - back * Eigen::Vector2d(std::cos(heading[0]), std::sin(heading[0])),
                                    heading[0], 0.0, 0.0));
  }
  for (int lap = 0; lap < p.laps; ++lap) {
    for (int k = 0; k < L; ++k) {
      sc.T_map_truth.push_back(pose(xy[k], heading[k], 1.5 * std::sin(2.0 * kPi * k / L), 0.5 * lap));
    }
  }

  std::mt19937 rng(p.seed);
  const Matrix6d odom_info = Information(0.05, 0.1 * kDegToRad);
  const Matrix6d loop_info = Information(0.05, 0.1 * kDegToRad);
  const double yaw_bias_rad_per_m = p.yaw_bias_deg_per_10m * kDegToRad / 10.0;
  sc.T_map_initial.push_back(sc.T_map_truth[0]);
  for (std::size_t i = 0; i + 1 < sc.T_map_truth.size(); ++i) {
    const Eigen::Isometry3d T_rel = sc.T_map_truth[i].inverse() * sc.T_map_truth[i + 1];
    Vector6d error = Noise(rng, p.odom_noise_m, p.odom_noise_deg * kDegToRad);
    error(5) += yaw_bias_rad_per_m * T_rel.translation().norm();
    PoseGraphEdge e;
    e.from = static_cast<std::uint32_t>(i);
    e.to = static_cast<std::uint32_t>(i + 1);
    e.T_from_to = T_rel * ExpSE3(error);
    e.information = odom_info;
    e.kind = EdgeKind::kOdometry;
    sc.odometry.push_back(e);
    sc.T_map_initial.push_back(sc.T_map_initial.back() * e.T_from_to);
  }
  for (int lap = 1; lap < p.laps; ++lap) {
    for (int k = 0; k < L; k += p.loop_every) {
      const auto a = static_cast<std::uint32_t>(p.approach_nodes + (lap - 1) * L + k);
      const auto b = static_cast<std::uint32_t>(p.approach_nodes + lap * L + k);
      PoseGraphEdge e;
      e.from = a;
      e.to = b;
      e.T_from_to = sc.T_map_truth[a].inverse() * sc.T_map_truth[b] *
                    ExpSE3(Noise(rng, p.loop_noise_m, p.loop_noise_deg * kDegToRad));
      e.information = loop_info;
      if (p.reverse_loops) {
        // The reversed residual is e' = -Ad(T_from_to) e, so Ad^-T Omega Ad^-1 gives the same cost exactly.
        const Matrix6d ad_inv = AdjointSE3(e.T_from_to.inverse());
        const Matrix6d info = ad_inv.transpose() * loop_info * ad_inv;
        e.information = 0.5 * (info + info.transpose());
        std::swap(e.from, e.to);
        e.T_from_to = e.T_from_to.inverse();
      }
      e.kind = EdgeKind::kLoop;
      sc.loops.push_back(e);
    }
  }
  return sc;
}

// Adds the scenario's nodes (initial estimate) and odometry edges, plus its loops when asked; room for
// `spare_edges` more edges.
PoseGraph MakeGraph(const Scenario& sc, bool with_loops, std::size_t spare_edges = 0) {
  PoseGraph graph(sc.T_map_truth.size(), sc.odometry.size() + sc.loops.size() + spare_edges);
  for (const auto& T : sc.T_map_initial) REQUIRE(graph.AddNode(T).ok());
  for (const auto& e : sc.odometry) REQUIRE(graph.AddEdge(e).ok());
  if (with_loops) {
    for (const auto& e : sc.loops) REQUIRE(graph.AddEdge(e).ok());
  }
  return graph;
}

std::vector<Eigen::Vector3d> Positions(Span<const Eigen::Isometry3d> poses) {
  std::vector<Eigen::Vector3d> p;
  for (const auto& T : poses) p.push_back(T.translation());
  return p;
}

// Anchored ATE [m]: position RMSE without any alignment (both trajectories start at the same pose).
double AnchoredAteM(Span<const Eigen::Isometry3d> estimate, const std::vector<Eigen::Isometry3d>& truth) {
  return AlignmentRmseM(Positions(estimate), Positions(truth), Eigen::Isometry3d::Identity());
}

// Aligned ATE [m]: position RMSE after the rigid alignment that minimises it.
double AlignedAteM(Span<const Eigen::Isometry3d> estimate, const std::vector<Eigen::Isometry3d>& truth) {
  const auto est = Positions(estimate);
  const auto gt = Positions(truth);
  const Result<Eigen::Isometry3d> T = AlignRigid(est, gt);
  REQUIRE(T.ok());
  return AlignmentRmseM(est, gt, *T);
}

bool Contains(const std::vector<std::uint32_t>& v, std::uint32_t x) { return std::binary_search(v.begin(), v.end(), x); }

double PositionErrorM(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

}  // namespace

TEST_CASE("pose-graph edge Jacobians match central finite differences") {
  std::mt19937 rng(21);
  const double h = 1e-6;
  for (int rep = 0; rep < 20; ++rep) {
    const Eigen::Isometry3d T_map_from = ExpSE3(Noise(rng, 20.0, 1.0));
    const Eigen::Isometry3d T_map_to = ExpSE3(Noise(rng, 20.0, 1.0));
    // Measurements near the current relative pose (small residual) and far from it (large residual).
    const double spread = rep % 2 ? 0.05 : 0.8;
    const Eigen::Isometry3d T_from_to = T_map_from.inverse() * T_map_to * ExpSE3(Noise(rng, spread, spread));
    Matrix6d J_from, J_to;
    const Vector6d e = PoseGraphEdgeResidual(T_map_from, T_map_to, T_from_to, &J_from, &J_to);
    CHECK((e - BoxMinus(T_map_from.inverse() * T_map_to, T_from_to)).norm() < 1e-12);
    Matrix6d num_from, num_to;
    for (int i = 0; i < 6; ++i) {
      const Vector6d d = h * Vector6d::Unit(i);
      num_from.col(i) = (PoseGraphEdgeResidual(BoxPlus(T_map_from, d), T_map_to, T_from_to) -
                         PoseGraphEdgeResidual(BoxPlus(T_map_from, -d), T_map_to, T_from_to)) / (2.0 * h);
      num_to.col(i) = (PoseGraphEdgeResidual(T_map_from, BoxPlus(T_map_to, d), T_from_to) -
                       PoseGraphEdgeResidual(T_map_from, BoxPlus(T_map_to, -d), T_from_to)) / (2.0 * h);
    }
    CHECK((J_from - num_from).cwiseAbs().maxCoeff() < 1e-6);
    CHECK((J_to - num_to).cwiseAbs().maxCoeff() < 1e-6);
  }
}

TEST_CASE("acceptance: loop closures cut the drift of a two-lap trajectory by at least 5x") {
  const Scenario sc = MakeScenario(ScenarioParams{});
  PoseGraph graph = MakeGraph(sc, true);
  REQUIRE(graph.num_nodes() == 620);
  REQUIRE(graph.num_loop_edges() == 60);

  const double ate_before = AnchoredAteM(graph.poses(), sc.T_map_truth);
  const double aligned_before = AlignedAteM(graph.poses(), sc.T_map_truth);
  const auto start = std::chrono::steady_clock::now();
  const Result<PoseGraphResult> r = graph.Optimize();
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  REQUIRE(r.ok());
  const double ate_after = AnchoredAteM(graph.poses(), sc.T_map_truth);
  const double aligned_after = AlignedAteM(graph.poses(), sc.T_map_truth);
  MESSAGE("620 nodes, 60 loops: anchored ATE " << ate_before << " m -> " << ate_after << " m, aligned ATE "
                                               << aligned_before << " m -> " << aligned_after << " m, "
                                               << r->iterations << " iterations, cost " << r->initial_cost << " -> "
                                               << r->final_cost << ", " << r->changed_nodes.size()
                                               << " changed nodes, " << ms << " ms");
  CHECK(r->converged);
  CHECK(r->final_cost < 1e-3 * r->initial_cost);
  CHECK(ate_before > 5.0);  // the drift is real: metres, not centimetres
  CHECK(ate_after * 5.0 <= ate_before);
  CHECK(aligned_after * 5.0 <= aligned_before);
  // The approach spur's own drift (20 m at 0.05 deg/m: ~1 deg of heading at the circuit entry) has no loop to
  // correct it, so the corrected circuit stays rotated by ~1 deg about its entry: ~1.2 m anchored ATE, while
  // its shape (aligned ATE) is right to centimetres.
  CHECK(ate_after < 1.5);
  CHECK(aligned_after < 0.1);
  CHECK(graph.pose(0).isApprox(sc.T_map_initial[0], 0.0));  // the gauge node is untouched

  // Nodes that drifted were moved and reported; the approach spur (a tree between node 0 and the circuit) is
  // already optimal, does not move, and is not reported.
  REQUIRE(std::is_sorted(r->changed_nodes.begin(), r->changed_nodes.end()));
  int drifted = 0;
  for (std::size_t i = 0; i < graph.num_nodes(); ++i) {
    const auto id = static_cast<std::uint32_t>(i);
    const double moved_m = PositionErrorM(graph.pose(i), sc.T_map_initial[i]);
    if (PositionErrorM(sc.T_map_initial[i], sc.T_map_truth[i]) > 0.5) {
      ++drifted;
      CHECK(Contains(r->changed_nodes, id));
    }
    if (i < static_cast<std::size_t>(sc.approach_nodes)) {
      CHECK_FALSE(Contains(r->changed_nodes, id));
      CHECK(moved_m < 1e-6);
    }
    if (Contains(r->changed_nodes, id)) {
      CHECK((moved_m > 0.01 || RotationAngleRad(graph.pose(i).linear().transpose() *
                                                sc.T_map_initial[i].linear()) > 0.1 * kDegToRad));
    }
  }
  CHECK(drifted > 400);
  CHECK(r->workspace_bytes > 0);
}

TEST_CASE("memory per keyframe stays within the robot budget's pose-graph share with a loop at every keyframe") {
  // A robot re-driving its laps closes a loop at nearly every keyframe (the long campus mission: 1 284 loops
  // in 3 000 keyframes). The budget's kPoseGraphBytesPerKeyframe must cover nodes, the mapper's odometry pose,
  // every edge and the solver's workspace there, as RobotAgent::MemoryUse() counts them.
  ScenarioParams p;
  p.laps = 4;
  p.loop_every = 1;
  const Scenario sc = MakeScenario(p);
  PoseGraph graph = MakeGraph(sc, true);
  REQUIRE(graph.num_loop_edges() == 900);
  const Result<PoseGraphResult> r = graph.Optimize();
  REQUIRE(r.ok());
  CHECK(r->converged);
  const double bytes = static_cast<double>(2 * graph.num_nodes() * sizeof(Eigen::Isometry3d) +
                                           graph.num_edges() * sizeof(PoseGraphEdge) + graph.workspace_bytes());
  const double per_keyframe = bytes / static_cast<double>(graph.num_nodes());
  MESSAGE(graph.num_nodes() << " nodes, " << graph.num_edges() << " edges: " << per_keyframe
                            << " B per keyframe (workspace " << graph.workspace_bytes() << " B)");
  CHECK(per_keyframe <= static_cast<double>(BudgetRecordSizes::kPoseGraphBytesPerKeyframe));
}

TEST_CASE("loop edges may point backwards (later node -> earlier node) with the same result") {
  ScenarioParams p;
  p.loop_every = 10;
  const Scenario forward = MakeScenario(p);
  p.reverse_loops = true;
  const Scenario backward = MakeScenario(p);
  PoseGraph a = MakeGraph(forward, true);
  PoseGraph b = MakeGraph(backward, true);
  REQUIRE(a.Optimize().ok());
  REQUIRE(b.Optimize().ok());
  double max_diff_m = 0.0;
  for (std::size_t i = 0; i < a.num_nodes(); ++i) max_diff_m = std::max(max_diff_m, PositionErrorM(a.pose(i), b.pose(i)));
  CHECK(max_diff_m < 1e-6);
  CHECK(AnchoredAteM(b.poses(), backward.T_map_truth) * 5.0 <= AnchoredAteM(backward.T_map_initial, backward.T_map_truth));
}

TEST_CASE("a graph whose odometry already agrees with its loops is left unchanged") {
  ScenarioParams p;
  p.yaw_bias_deg_per_10m = 0.0;
  p.odom_noise_m = p.odom_noise_deg = p.loop_noise_m = p.loop_noise_deg = 0.0;
  const Scenario sc = MakeScenario(p);
  PoseGraph graph = MakeGraph(sc, true);
  const Result<PoseGraphResult> r = graph.Optimize();
  REQUIRE(r.ok());
  CHECK(r->converged);
  CHECK(r->iterations <= 1);
  CHECK(r->initial_cost < 1e-12);
  CHECK(r->final_cost <= r->initial_cost);
  CHECK(r->changed_nodes.empty());
  double max_moved_m = 0.0;
  for (std::size_t i = 0; i < graph.num_nodes(); ++i) {
    max_moved_m = std::max(max_moved_m, PositionErrorM(graph.pose(i), sc.T_map_initial[i]));
  }
  CHECK(max_moved_m < 1e-9);
}

TEST_CASE("without loop edges there is nothing to correct") {
  const Scenario sc = MakeScenario(ScenarioParams{});
  PoseGraph graph = MakeGraph(sc, false);
  const Result<PoseGraphResult> r = graph.Optimize();
  REQUIRE(r.ok());
  CHECK(r->converged);
  CHECK(r->iterations <= 1);
  CHECK(r->changed_nodes.empty());
  CHECK(r->final_cost <= r->initial_cost);
  CHECK(r->initial_cost < 1e-12);  // chained odometry satisfies every odometry edge
  for (std::size_t i = 0; i < graph.num_nodes(); ++i) CHECK(PositionErrorM(graph.pose(i), sc.T_map_initial[i]) < 1e-9);
}

TEST_CASE("incremental use: optimise after each accepted loop, as the robot does") {
  ScenarioParams p;
  p.loop_every = 50;
  const Scenario sc = MakeScenario(p);
  PoseGraph graph(sc.T_map_truth.size(), sc.odometry.size() + sc.loops.size());
  // Keyframes arrive one by one; a new keyframe is placed by composing the (optimised) previous pose with the
  // odometry, and each loop (lap 2 node b closes on lap 1 node a) is added when b arrives.
  std::size_t next_loop = 0;
  std::size_t total_changed = 0;
  int optimisations = 0;
  REQUIRE(graph.AddNode(sc.T_map_initial[0]).ok());
  for (const PoseGraphEdge& odo : sc.odometry) {
    REQUIRE(graph.AddNode(graph.pose(odo.from) * odo.T_from_to).ok());
    REQUIRE(graph.AddEdge(odo).ok());
    while (next_loop < sc.loops.size() && sc.loops[next_loop].to == odo.to) {
      REQUIRE(graph.AddEdge(sc.loops[next_loop++]).ok());
      const Result<PoseGraphResult> r = graph.Optimize();
      REQUIRE(r.ok());
      CHECK(r->final_cost <= r->initial_cost);
      total_changed += r->changed_nodes.size();
      ++optimisations;
      // Only nodes of the circuit can move, never the approach spur.
      CHECK((r->changed_nodes.empty() || r->changed_nodes.front() >= static_cast<std::uint32_t>(sc.approach_nodes)));
    }
  }
  REQUIRE(next_loop == sc.loops.size());
  const double ate_before = AnchoredAteM(sc.T_map_initial, sc.T_map_truth);
  const double ate_after = AnchoredAteM(graph.poses(), sc.T_map_truth);
  MESSAGE("incremental, " << optimisations << " optimisations: anchored ATE " << ate_before << " m -> " << ate_after
                          << " m, " << total_changed << " pose updates in total");
  CHECK(ate_after * 5.0 <= ate_before);
  // The first closure moves almost everything; later ones only refine.
  CHECK(total_changed < static_cast<std::size_t>(optimisations) * graph.num_nodes());
}

TEST_CASE("a robust kernel on loop edges limits the damage of a wrong loop closure") {
  ScenarioParams p;
  p.lap_nodes = 200;
  p.yaw_bias_deg_per_10m = 0.0;  // good odometry; the damage comes from the false loop alone
  p.loop_every = 20;
  const Scenario sc = MakeScenario(p);
  PoseGraphEdge wrong;  // claims lap-1 node 50 coincides with lap-2 node 150 (they are ~45 m apart)
  wrong.from = static_cast<std::uint32_t>(sc.approach_nodes + 50);
  wrong.to = static_cast<std::uint32_t>(sc.approach_nodes + p.lap_nodes + 150);
  wrong.information = Information(0.05, 0.1 * kDegToRad);
  wrong.kind = EdgeKind::kLoop;

  PoseGraphParams plain;
  PoseGraphParams cauchy;
  cauchy.loop_kernel = RobustKernel::kCauchy;
  cauchy.loop_kernel_width = 1.0;
  PoseGraphParams huber;
  huber.loop_kernel = RobustKernel::kHuber;
  huber.loop_kernel_width = 1.0;

  // Reference: the same graph without the wrong loop.
  PoseGraph clean = MakeGraph(sc, true);
  REQUIRE(clean.Optimize(plain).ok());
  const double ate_clean = AnchoredAteM(clean.poses(), sc.T_map_truth);

  double ate[3];
  const PoseGraphParams* params[3] = {&plain, &cauchy, &huber};
  for (int k = 0; k < 3; ++k) {
    PoseGraph graph = MakeGraph(sc, true, 1);
    REQUIRE(graph.AddEdge(wrong).ok());
    const Result<PoseGraphResult> r = graph.Optimize(*params[k]);
    REQUIRE(r.ok());
    CHECK(r->final_cost <= r->initial_cost);
    CHECK(r->final_cost == doctest::Approx(graph.Cost(*params[k])));
    ate[k] = AnchoredAteM(graph.poses(), sc.T_map_truth);
  }
  MESSAGE("anchored ATE without the wrong loop " << ate_clean << " m; with it: least squares " << ate[0]
                                                 << " m, Cauchy " << ate[1] << " m, Huber " << ate[2] << " m");
  CHECK(ate[0] > 10.0 * ate_clean);           // least squares bends the map towards the false loop
  CHECK(ate[1] < ate_clean + 0.05);           // Cauchy all but ignores it
  CHECK(ate[2] < 0.5 * ate[0]);               // Huber bounds its pull
}

TEST_CASE("trivial graphs: no node, one node, two nodes") {
  PoseGraph empty(4, 4);
  Result<PoseGraphResult> r = empty.Optimize();
  REQUIRE(r.ok());
  CHECK(r->converged);
  CHECK(r->iterations == 0);

  PoseGraph one(4, 4);
  REQUIRE(one.AddNode(ExpSE3(Vector6d::Constant(0.2))).ok());
  r = one.Optimize();
  REQUIRE(r.ok());
  CHECK(r->converged);
  CHECK(r->changed_nodes.empty());
  CHECK(one.pose(0).isApprox(ExpSE3(Vector6d::Constant(0.2))));

  // Two nodes, one edge that disagrees with the initial guess: one step puts node 1 where the edge says.
  PoseGraph two(4, 4);
  REQUIRE(two.AddNode(Eigen::Isometry3d::Identity()).ok());
  REQUIRE(two.AddNode(ExpSE3((Vector6d() << 1.0, 0.0, 0.0, 0.0, 0.0, 0.0).finished())).ok());
  PoseGraphEdge e;
  e.from = 0;
  e.to = 1;
  e.T_from_to = ExpSE3((Vector6d() << 2.0, 0.5, 0.0, 0.0, 0.0, 0.3).finished());
  REQUIRE(two.AddEdge(e).ok());
  r = two.Optimize();
  REQUIRE(r.ok());
  CHECK(r->converged);
  CHECK(r->final_cost < 1e-16);
  CHECK(two.pose(1).isApprox(e.T_from_to, 1e-9));
  CHECK(r->changed_nodes == std::vector<std::uint32_t>{1});
}

TEST_CASE("a node not connected to node 0 is named in the error and nothing moves") {
  PoseGraph graph(8, 8);
  for (int i = 0; i < 5; ++i) {
    REQUIRE(graph.AddNode(ExpSE3((Vector6d() << i, 0.0, 0.0, 0.0, 0.0, 0.1 * i).finished())).ok());
  }
  PoseGraphEdge e;
  e.T_from_to = ExpSE3((Vector6d() << 1.1, 0.0, 0.0, 0.0, 0.0, 0.0).finished());
  for (std::uint32_t i : {0u, 1u, 3u}) {  // 0-1, 1-2, 3-4: nodes 3 and 4 are cut off
    e.from = i;
    e.to = i + 1;
    REQUIRE(graph.AddEdge(e).ok());
  }
  const Eigen::Isometry3d before = graph.pose(2);
  const Result<PoseGraphResult> r = graph.Optimize();
  CHECK(r.status().code() == StatusCode::kInvalidArgument);
  CHECK(r.status().message().find("node 3 is not connected") != std::string::npos);
  CHECK(graph.pose(2).isApprox(before, 0.0));
}

TEST_CASE("capacities are enforced with resource-exhausted errors") {
  PoseGraph graph(3, 2);
  for (int i = 0; i < 3; ++i) REQUIRE(graph.AddNode(Eigen::Isometry3d::Identity()).ok());
  const Status full = graph.AddNode(Eigen::Isometry3d::Identity());
  CHECK(full.code() == StatusCode::kResourceExhausted);
  CHECK(full.message().find("node capacity 3") != std::string::npos);
  CHECK(graph.num_nodes() == 3);

  PoseGraphEdge e;
  e.from = 0;
  e.to = 1;
  REQUIRE(graph.AddEdge(e).ok());
  e.from = 1;
  e.to = 2;
  REQUIRE(graph.AddEdge(e).ok());
  e.from = 0;
  e.to = 2;
  e.kind = EdgeKind::kLoop;
  const Status full_edges = graph.AddEdge(e);
  CHECK(full_edges.code() == StatusCode::kResourceExhausted);
  CHECK(full_edges.message().find("edge 2 (0 -> 2, loop)") != std::string::npos);
  CHECK(graph.num_edges() == 2);
  CHECK(graph.num_loop_edges() == 0);
  CHECK(graph.Optimize().ok());

  PoseGraph zero(0, 0);
  CHECK(zero.AddNode(Eigen::Isometry3d::Identity()).code() == StatusCode::kResourceExhausted);
}

TEST_CASE("bad nodes and edges are rejected with messages naming them") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  PoseGraph graph(8, 8);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().y() = nan;
  Status s = graph.AddNode(T);
  CHECK(s.code() == StatusCode::kInvalidArgument);
  CHECK(s.message().find("node 0") != std::string::npos);
  T = Eigen::Isometry3d::Identity();
  T.linear() *= 2.0;
  CHECK(graph.AddNode(T).code() == StatusCode::kInvalidArgument);
  CHECK(graph.num_nodes() == 0);
  for (int i = 0; i < 3; ++i) REQUIRE(graph.AddNode(Eigen::Isometry3d::Identity()).ok());

  const auto expect_bad = [&](const PoseGraphEdge& e, const std::string& what) {
    const Status st = graph.AddEdge(e);
    CHECK(st.code() == StatusCode::kInvalidArgument);
    INFO(st.message());
    CHECK(st.message().find("edge 0 (" + std::to_string(e.from) + " -> " + std::to_string(e.to)) != std::string::npos);
    CHECK(st.message().find(what) != std::string::npos);
  };
  PoseGraphEdge e;
  e.from = 0;
  e.to = 3;
  expect_bad(e, "out of range");
  e.to = 0;
  expect_bad(e, "itself");
  e.to = 1;
  e.T_from_to.translation().x() = nan;
  expect_bad(e, "T_from_to");
  e.T_from_to = Eigen::Isometry3d::Identity();
  e.information(2, 3) = nan;
  expect_bad(e, "not finite");
  e.information = Matrix6d::Identity();
  e.information(0, 5) = 0.5;  // not symmetric
  expect_bad(e, "not symmetric");
  e.information = Matrix6d::Identity();
  e.information(4, 4) = -1.0;  // indefinite
  expect_bad(e, "positive semi-definite");
  CHECK(graph.num_edges() == 0);

  e.information = Matrix6d::Identity();
  CHECK(graph.AddEdge(e).ok());
}

TEST_CASE("Optimize rejects parameters out of range and leaves the graph alone") {
  const Scenario sc = MakeScenario(ScenarioParams{});
  PoseGraph graph = MakeGraph(sc, true);
  const auto rejected = [&](PoseGraphParams p, const char* name) {
    const Result<PoseGraphResult> r = graph.Optimize(p);
    CHECK(r.status().code() == StatusCode::kInvalidArgument);
    CHECK(r.status().message().find(name) != std::string::npos);
  };
  PoseGraphParams p;
  p.max_iterations = -1;
  rejected(p, "max_iterations");
  p = PoseGraphParams{};
  p.convergence_step = std::numeric_limits<double>::quiet_NaN();
  rejected(p, "convergence_step");
  p = PoseGraphParams{};
  p.lm_initial_lambda = 0.0;
  rejected(p, "lm_initial_lambda");
  p = PoseGraphParams{};
  p.loop_kernel_width = -1.0;
  rejected(p, "loop_kernel_width");
  p = PoseGraphParams{};
  p.changed_translation_m = -0.1;
  rejected(p, "changed_translation_m");
  CHECK(graph.pose(300).isApprox(sc.T_map_initial[300], 0.0));

  // max_iterations = 0 evaluates the cost only.
  p = PoseGraphParams{};
  p.max_iterations = 0;
  const Result<PoseGraphResult> r = graph.Optimize(p);
  REQUIRE(r.ok());
  CHECK(r->iterations == 0);
  CHECK_FALSE(r->converged);
  CHECK(r->final_cost == r->initial_cost);
  CHECK(r->changed_nodes.empty());
}

}  // namespace commerge
