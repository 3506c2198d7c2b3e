// SPDX-License-Identifier: BSD-3-Clause
// End-to-end cascade on affinity data from two overlapping trajectories with known ground truth: two robots
// drive the same generated street in opposite directions (beta's map frame is its own start pose), SOLiD is
// computed on ray-cast scans, and the cascade must select only true loops (ground-truth distance of the two
// keyframes), shrink the candidate set at every stage (L_K in L_V in L_seq) and predict the bytes it asks for.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "core/agent/messages.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/exchange/exchange_cascade.hpp"
#include "core/geometry/angles.hpp"
#include "core/sim/keyframe_drive.hpp"
#include "core/solvers/max_clique.hpp"

namespace commerge {
namespace {

// VLP-16-like sensor with a coarse azimuth (keeps the test quick under qemu).
SimulatedKeyframes Drive(const BoxScene& scene, float x0, float lane_y, float yaw, int keyframes, std::uint32_t seed) {
  SpinningLidar lidar;
  lidar.beams = 16;
  lidar.azimuth_steps = 450;
  lidar.min_elevation_deg = -15.0f;
  lidar.max_elevation_deg = 15.0f;
  lidar.max_range_m = 80.0f;
  StraightDrive drive;
  drive.start_x_m = x0;
  drive.lane_y_m = lane_y;
  drive.yaw_rad = yaw;
  drive.keyframes = keyframes;
  drive.seed = seed;
  auto sim = SimulateStraightDrive(scene, lidar, SolidPreset(LidarSensor::kVelodyneVlp16), drive);
  REQUIRE(sim.ok());
  // The robots report stored (voxelised) point counts; a stand-in proportional to the raw count.
  for (auto& n : sim->raw_points) n /= 25;
  return std::move(*sim);
}

CascadeRobotInput Input(const SimulatedKeyframes& r) {
  CascadeRobotInput in;
  in.descriptors.values = Span<const float>(r.descriptors);
  in.descriptors.dim = static_cast<std::size_t>(r.dim);
  in.descriptors.valid = Span<const std::uint8_t>(r.valid);
  in.positions_m = Span<const Eigen::Vector3d>(r.own_frame_m);
  in.stored_points = Span<const std::uint32_t>(r.raw_points);
  return in;
}

TEST_CASE("Cascade: two robots on one street in opposite directions - only true loops, fewer scans per stage") {
  // Street x in [-100, 100]; alpha drives +x from -55, beta drives -x from +55.5 in the same lane (keyframes
  // 0.5 m apart along the road where they overlap): the 80-keyframe paths overlap on x in [-23.5, 24], about 48
  // keyframes each. (A lateral offset of 1 m or more already moves this 16-beam R-SOLiD above tau_inter in the
  // narrow generated street: the descriptor, not the cascade, limits that case.)
  const BoxScene scene = MakeStreetScene(42, 200.0f);
  const SimulatedKeyframes alpha = Drive(scene, -55.0f, 0.0f, 0.0f, 80, 1000);
  const SimulatedKeyframes beta = Drive(scene, 55.5f, 0.0f, kPiF, 80, 2000);

  ExchangeCascadeParams params;
  params.stage_a.tau_area = 400;  // a 20 x 20 keyframe span: the overlap here is ~50 m (the paper: 100 x 100)
  params.policy.min_scans_per_robot = 0;  // the paper's policy: exactly L_K's endpoints (padding: below)
  params.policy.min_points_per_robot = 0;
  auto r = RunExchangeCascade(Input(alpha), Input(beta), params);
  REQUIRE(r.ok());
  INFO("stage A: clusters ", r->stage_a.num_clusters, ", cells below tau ", r->stage_a.num_cells_below_threshold,
       ", reason '", r->no_candidate_reason, "'");
  REQUIRE(r->outcome == CascadeOutcome::kPolicy);

  // Stage A: its cluster lies in the overlap.
  const auto& best = r->stage_a.best;
  MESSAGE("stage A span rows ", best.row_min, "..", best.row_max, " cols ", best.col_min, "..", best.col_max,
          ", |L_seq| = ", r->stage_a.cells.size(), ", stage B selects ", r->stage_b.selected_left.size(), " + ",
          r->stage_b.selected_right.size(), " of ", r->stage_b_vertices_alpha, " + ", r->stage_b_vertices_beta,
          ", |L_V| = ", r->stage_c.candidate_loops.size(), ", |L_K| = ", r->stage_c.selected_loops.size(),
          ", policy ", r->policy.alpha.keyframes.size(), " + ", r->policy.beta.keyframes.size(), " scans");
  const auto gt_distance = [&](const SequentialLoopCell& l) {
    return (alpha.gt_m[l.alpha_index] - beta.gt_m[l.beta_index]).norm();
  };

  // Stage A's loops are mostly true already (the best cluster is the overlap).
  std::size_t true_seq = 0;
  for (const auto& l : r->stage_a.cells) true_seq += gt_distance(l) < 5.0;
  CHECK(static_cast<double>(true_seq) >= 0.9 * static_cast<double>(r->stage_a.cells.size()));

  // Nesting: L_K in L_V in L_seq, with L_V = loops whose two keyframes stage B selected.
  auto key = [](const SequentialLoopCell& l) { return std::make_pair(l.alpha_index, l.beta_index); };
  std::set<std::pair<std::size_t, std::size_t>> l_seq, l_v;
  for (const auto& l : r->stage_a.cells) l_seq.insert(key(l));
  for (const auto& l : r->stage_c.candidate_loops) {
    CHECK(l_seq.count(key(l)) == 1);
    CHECK(std::binary_search(r->stage_b.selected_left.begin(), r->stage_b.selected_left.end(),
                             static_cast<int>(l.alpha_index)));
    CHECK(std::binary_search(r->stage_b.selected_right.begin(), r->stage_b.selected_right.end(),
                             static_cast<int>(l.beta_index)));
    l_v.insert(key(l));
  }
  for (const auto& l : r->stage_c.selected_loops) CHECK(l_v.count(key(l)) == 1);
  // Stage B covers every loop of L_seq.
  for (const auto& l : r->stage_a.cells) {
    const bool covered = std::binary_search(r->stage_b.selected_left.begin(), r->stage_b.selected_left.end(),
                                            static_cast<int>(l.alpha_index)) ||
                         std::binary_search(r->stage_b.selected_right.begin(), r->stage_b.selected_right.end(),
                                            static_cast<int>(l.beta_index));
    CHECK(covered);
  }

  // Every selected loop is a true loop: the two keyframes are within 5 m in ground truth.
  // A minimum cover rarely selects both endpoints of a loop (one of them is usually redundant), so the default
  // loop set is small: at least two loops (one compatible pair) here.
  REQUIRE(r->stage_c.selected_loops.size() >= 2);
  for (const auto& l : r->stage_c.selected_loops) {
    CAPTURE(l.alpha_index);
    CAPTURE(l.beta_index);
    CHECK(gt_distance(l) < 5.0);
  }

  // Fewer scans at every stage; the policy asks for exactly L_K's endpoints.
  const std::size_t scans_a = r->stage_b_vertices_alpha + r->stage_b_vertices_beta;
  const std::size_t scans_b = r->stage_b.selected_left.size() + r->stage_b.selected_right.size();
  CHECK(scans_b < scans_a);
  CHECK(r->policy.scans() <= scans_b);
  std::set<std::uint32_t> want_a, want_b;
  for (const auto& l : r->stage_c.selected_loops) {
    want_a.insert(static_cast<std::uint32_t>(l.alpha_index));
    want_b.insert(static_cast<std::uint32_t>(l.beta_index));
  }
  CHECK(r->policy.alpha.keyframes == std::vector<std::uint32_t>(want_a.begin(), want_a.end()));
  CHECK(r->policy.beta.keyframes == std::vector<std::uint32_t>(want_b.begin(), want_b.end()));
  std::uint64_t bytes = 0;
  for (std::uint32_t k : want_a) bytes += 12 + 6 * std::uint64_t{alpha.raw_points[k]};
  for (std::uint32_t k : want_b) bytes += 12 + 6 * std::uint64_t{beta.raw_points[k]};
  CHECK(r->policy.predicted_bytes() == bytes);

  // With a minimum per robot, the same L_K and its endpoints plus other keyframes of L_seq (stage A's loops:
  // scans of the overlap), up to all of them.
  std::set<std::uint32_t> seq_a, seq_b;
  for (const auto& l : r->stage_a.cells) {
    seq_a.insert(static_cast<std::uint32_t>(l.alpha_index));
    seq_b.insert(static_cast<std::uint32_t>(l.beta_index));
  }
  for (std::uint32_t min_scans : {12u, 200u}) {
    ExchangeCascadeParams padded_params = params;
    padded_params.policy.min_scans_per_robot = min_scans;
    padded_params.policy.min_points_per_robot = 0;
    auto padded = RunExchangeCascade(Input(alpha), Input(beta), padded_params);
    REQUIRE(padded.ok());
    REQUIRE(padded->outcome == CascadeOutcome::kPolicy);
    CHECK(padded->stage_c.selected_loops.size() == r->stage_c.selected_loops.size());
    for (const auto& [request, want, seq] : {std::make_tuple(&padded->policy.alpha, &want_a, &seq_a),
                                             std::make_tuple(&padded->policy.beta, &want_b, &seq_b)}) {
      CHECK(request->keyframes.size() ==
            std::max<std::size_t>(want->size(), std::min<std::size_t>(min_scans, seq->size())));
      CHECK(request->padded_scans == request->keyframes.size() - want->size());
      CHECK(std::includes(request->keyframes.begin(), request->keyframes.end(), want->begin(), want->end()));
      CHECK(std::includes(seq->begin(), seq->end(), request->keyframes.begin(), request->keyframes.end()));
      for (std::uint32_t k : request->keyframes) {  // every padded scan sees the other robot's path
        CAPTURE(k);
        double nearest_m = 1e9;
        const auto& mine = request == &padded->policy.alpha ? alpha.gt_m : beta.gt_m;
        const auto& theirs = request == &padded->policy.alpha ? beta.gt_m : alpha.gt_m;
        for (const auto& p : theirs) nearest_m = std::min(nearest_m, (mine[k] - p).norm());
        CHECK(nearest_m < 5.0);
      }
    }
  }

  // The paper's literal loop set (any endpoint selected) is all of L_seq, since stage B returns a cover; its
  // clique is larger, still true loops only, and asks for more scans.
  params.stage_c.loop_set = StageCLoopSet::kAnyEndpointSelected;
  auto literal = RunExchangeCascade(Input(alpha), Input(beta), params);
  REQUIRE(literal.ok());
  REQUIRE(literal->outcome == CascadeOutcome::kPolicy);
  CHECK(literal->stage_c.candidate_loops.size() == r->stage_a.cells.size());
  CHECK(literal->stage_c.selected_loops.size() >= r->stage_c.selected_loops.size());
  CHECK(literal->policy.scans() >= r->policy.scans());
  for (const auto& l : literal->stage_c.selected_loops) CHECK(gt_distance(l) < 5.0);
  MESSAGE("literal loop set: |L_V| = ", literal->stage_c.candidate_loops.size(), ", |L_K| = ",
          literal->stage_c.selected_loops.size(), ", policy ", literal->policy.scans(), " scans");
}

TEST_CASE("Cascade: degenerate inputs give a reason, not a crash") {
  std::vector<float> one(40, 0.0f);
  one[3] = 1.0f;
  std::vector<Eigen::Vector3d> pos1(1, Eigen::Vector3d::Zero());
  CascadeRobotInput a, b;
  a.descriptors.values = Span<const float>(one);
  a.descriptors.dim = 40;
  a.positions_m = Span<const Eigen::Vector3d>(pos1);
  b.descriptors.dim = 40;  // empty set
  auto r = RunExchangeCascade(a, b, ExchangeCascadeParams{});
  REQUIRE(r.ok());
  CHECK(r->outcome == CascadeOutcome::kNoCandidate);
  CHECK(r->no_candidate_reason.find("stage A") == 0);

  // A single keyframe each, identical: one loop, span 1 x 1 is below tau_area unless tau_area = 1.
  b = a;
  ExchangeCascadeParams params;
  r = RunExchangeCascade(a, b, params);
  REQUIRE(r.ok());
  CHECK(r->outcome == CascadeOutcome::kNoCandidate);
  params.stage_a.tau_area = 1;
  r = RunExchangeCascade(a, b, params);
  REQUIRE(r.ok());
  CHECK(r->outcome == CascadeOutcome::kPolicy);
  CHECK(r->policy.scans() == 2);

  // Positions that do not match the descriptors are an error naming both counts.
  std::vector<Eigen::Vector3d> pos2(2, Eigen::Vector3d::Zero());
  b.positions_m = Span<const Eigen::Vector3d>(pos2);
  auto bad = RunExchangeCascade(a, b, params);
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.status().message().find("positions") != std::string::npos);
}

TEST_CASE("Cascade: a cluster below tau_area is passed on to verify only above the verification fraction") {
  // Orthonormal descriptors: alpha keyframe i is e_i; beta keyframe j is e_j for j in [10, 25) (the same places)
  // and a basis vector of its own otherwise. The only cells below tau_inter are the 15 diagonal cells
  // (10..24, 10..24): one cluster spanning 15 x 15 = 225 cells, against tau_area = 400.
  constexpr std::size_t kN = 40, kDim = 80;
  std::vector<float> da(kN * kDim, 0.0f), db(kN * kDim, 0.0f);
  std::vector<Eigen::Vector3d> pa, pb;
  for (std::size_t i = 0; i < kN; ++i) {
    da[i * kDim + i] = 1.0f;
    db[i * kDim + (i >= 10 && i < 25 ? i : kN + i)] = 1.0f;
    pa.emplace_back(static_cast<double>(i), 0.0, 0.0);
    pb.emplace_back(static_cast<double>(i), 0.0, 0.0);
  }
  CascadeRobotInput a, b;
  a.descriptors.values = Span<const float>(da);
  a.descriptors.dim = kDim;
  a.positions_m = Span<const Eigen::Vector3d>(pa);
  b.descriptors.values = Span<const float>(db);
  b.descriptors.dim = kDim;
  b.positions_m = Span<const Eigen::Vector3d>(pb);
  ExchangeCascadeParams params;  // the paper's stage A at tau_area 400
  params.stage_a.tau_area = 400;
  params.policy.min_scans_per_robot = 0;
  params.policy.min_points_per_robot = 0;

  auto r = RunExchangeCascade(a, b, params);  // verification off: the paper's answer
  REQUIRE(r.ok());
  CHECK(r->outcome == CascadeOutcome::kNoCandidate);
  CHECK_FALSE(r->verification);
  CHECK(r->no_candidate_reason.find("largest was 225") != std::string::npos);

  params.verification_area_fraction = 0.6;  // 225 < 0.6 x 400
  r = RunExchangeCascade(a, b, params);
  REQUIRE(r.ok());
  CHECK(r->outcome == CascadeOutcome::kNoCandidate);
  CHECK_FALSE(r->verification);

  params.verification_area_fraction = 0.5;  // 225 >= 0.5 x 400: the cluster goes on, flagged
  r = RunExchangeCascade(a, b, params);
  REQUIRE(r.ok());
  REQUIRE(r->outcome == CascadeOutcome::kPolicy);
  CHECK(r->verification);
  CHECK(r->verification_reason.find("225 of the 400") != std::string::npos);
  REQUIRE(r->stage_a.cells.size() == 15);
  for (const SequentialLoopCell& l : r->stage_a.cells) {
    CHECK(l.alpha_index == l.beta_index);
    CHECK(l.alpha_index >= 10);
    CHECK(l.alpha_index < 25);
  }
  // The scans asked for are keyframes of that cluster only.
  for (std::uint32_t k : r->policy.alpha.keyframes) CHECK((k >= 10 && k < 25));
  for (std::uint32_t k : r->policy.beta.keyframes) CHECK((k >= 10 && k < 25));

  params.verification_area_fraction = 1.5;
  auto bad = RunExchangeCascade(a, b, params);
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.status().message().find("verification_area_fraction") != std::string::npos);
}

}  // namespace
}  // namespace commerge

namespace commerge {
namespace {

// Independent of StageSolverOutcome: the relative gap from the solver's own incumbent and bound.
double GapOf(double incumbent, double bound) {
  return std::fabs(bound - incumbent) / std::max({std::fabs(incumbent), std::fabs(bound), 1e-12});
}

TEST_CASE("Cascade outcomes: each solver stage's status, incumbent, bound, gap and nodes, with and without a node limit") {
  const BoxScene scene = MakeStreetScene(42, 200.0f);
  const SimulatedKeyframes alpha = Drive(scene, -55.0f, 0.0f, 0.0f, 80, 1000);
  const SimulatedKeyframes beta = Drive(scene, 55.5f, 0.0f, kPiF, 80, 2000);
  ExchangeCascadeParams params;
  params.stage_a.tau_area = 400;
  params.stage_c.loop_set = StageCLoopSet::kAnyEndpointSelected;  // every loop of L_seq: a clique search with work
  auto full = RunExchangeCascade(Input(alpha), Input(beta), params);
  REQUIRE(full.ok());
  REQUIRE(full->outcome == CascadeOutcome::kPolicy);
  const StageSolverOutcome b = StageBOutcome(*full);
  const StageSolverOutcome c = StageCOutcome(*full);
  REQUIRE(b.ran);
  REQUIRE(c.ran);
  CHECK(std::string(b.status) == BalancedCoverStatusName(full->stage_b.status));
  CHECK(b.proven == (full->stage_b.status == BalancedCoverStatus::kOptimal));
  CHECK(b.incumbent == static_cast<double>(full->stage_b.selected_left.size() + full->stage_b.selected_right.size()));
  CHECK(b.bound == full->stage_b.lower_bound_weight);
  CHECK(b.nodes == full->stage_b.nodes_explored);
  CHECK(b.lp_solves == full->stage_b.lp_solves);
  CHECK(std::string(c.status) == CliqueSearchStatusName(full->stage_c.clique.status));
  CHECK(c.incumbent == full->stage_c.clique.objective);
  CHECK(c.bound == full->stage_c.clique.upper_bound);
  CHECK(c.nodes == full->stage_c.clique.nodes);
  CHECK(c.loops_dropped == full->stage_c.loops_dropped);
  if (b.proven) CHECK(b.gap == 0.0);
  if (c.proven) CHECK(c.gap == 0.0);
  CHECK(FormatStageSolverOutcome(c).find(c.status) == 0);

  // Both solvers stopped after one node on graphs they cannot close at the root: a 14 x 14 grid for stage B
  // (share 49 of 196 cells) and a random edge-weighted graph of 60 vertices for stage C.
  ExchangeCascadeResult cut;
  Result<BipartiteGraph> grid = MakeCheckerboardGridGraph(14, 14);
  REQUIRE(grid.ok());
  BalancedCoverParams bp;
  bp.max_nodes = 1;
  Result<BalancedCoverResult> cover = SolveBalancedVertexCover(*grid, bp);
  REQUIRE(cover.ok());
  REQUIRE(cover->status == BalancedCoverStatus::kFeasibleWithGap);
  cut.stage_b = *cover;
  cut.stage_b_vertices_alpha = static_cast<std::size_t>(grid->left_count());
  cut.stage_b_vertices_beta = static_cast<std::size_t>(grid->right_count());
  Result<CliqueGraph> cg = CliqueGraph::Create(60, true);
  REQUIRE(cg.ok());
  std::mt19937 rng(5U);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int u = 0; u < 60; ++u) {
    for (int v = u + 1; v < 60; ++v) {
      if (unit(rng) < 0.6) REQUIRE(cg->AddEdge(u, v, unit(rng)).ok());
    }
  }
  CliqueSearchParams cp;
  cp.max_nodes = 1;
  Result<CliqueSearchResult> clique = SolveMaxClique(*cg, cp);
  REQUIRE(clique.ok());
  REQUIRE(clique->status == CliqueSearchStatus::kLimitReached);
  cut.stage_c.clique = *clique;
  cut.stage_c.candidate_loops.resize(60);
  cut.stage_c.loops_dropped = 7;
  const StageSolverOutcome cb = StageBOutcome(cut);
  const StageSolverOutcome cc = StageCOutcome(cut);
  CHECK(cb.ran);
  CHECK(cb.limit_hit);
  CHECK_FALSE(cb.proven);
  CHECK_FALSE(cb.no_selection);
  CHECK(cb.incumbent == static_cast<double>(cover->objective_scans));
  CHECK(cb.bound == cover->lower_bound_weight);
  CHECK(cb.bound >= 98.0);  // the LP bound of the grid (98 cells per colour)
  CHECK(cb.gap == doctest::Approx(GapOf(cb.incumbent, cb.bound)));
  CHECK(cb.gap > 0.0);
  CHECK(cb.nodes == 1);
  CHECK(cc.limit_hit);
  CHECK(cc.nodes == clique->nodes);
  CHECK(cc.lp_solves == clique->lp_solves);
  CHECK(cc.lp_solves == 1);  // the LP bound certifies the gap at the node limit
  CHECK(cc.gap == doctest::Approx(GapOf(clique->objective, clique->upper_bound)));
  CHECK(cc.gap > 0.0);
  CHECK(cc.loops_dropped == 7);
  const std::string text = FormatStageSolverOutcome(cb);
  CHECK(text.find("feasible with gap: " + std::to_string(cover->objective_scans) + " against bound") == 0);
  CHECK(text.find("1 node,") != std::string::npos);
  CHECK(FormatStageSolverOutcome(cc).find("7 loops dropped") != std::string::npos);
  // Shares that cannot be met: no selection.
  cut.stage_b.status = BalancedCoverStatus::kInfeasible;
  CHECK(StageBOutcome(cut).no_selection);

  // The words server_status_t shows per pair (the numbers merge_result_t carries).
  CHECK(StageSolverText("B", {2, 0.25f, 1, 3}) == "B limit, gap 25.00 %, 1 node, 3 LPs");
  CHECK(StageSolverText("C", {1, 0.0f, 40, 1}) == "C optimal, 40 nodes, 1 LP");
  CHECK(StageSolverText("B", {3, 0.0f, 20000, 9}) == "B no selection, 20000 nodes, 9 LPs");
  CHECK(StageSolverText("C", {}) == "C not run");

  // A stage the cascade never reached.
  ExchangeCascadeResult none;
  CHECK_FALSE(StageBOutcome(none).ran);
  CHECK(FormatStageSolverOutcome(StageCOutcome(none)) == "not run");
}

}  // namespace
}  // namespace commerge
