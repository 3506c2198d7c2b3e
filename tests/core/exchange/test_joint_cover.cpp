// SPDX-License-Identifier: BSD-3-Clause
// The joint stage B over several robot pairs (SolveJointStageB, `--cover joint`) against brute force: every
// pair's part covers its L_seq, the joint selection is a minimum cover of all pairs' loops meeting a share of
// ceil(N_MM / 3) per robot (N_MM by exhaustive matching), a keyframe two pairs share is one scan; and
// RunCascadeFromStageB taking a joint cover as stage B (refusing one that leaves a loop uncovered).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/exchange/exchange_cascade.hpp"

namespace commerge {
namespace {

using Vertex = std::pair<int, std::size_t>;  // (robot id, keyframe)
using Edge = std::pair<Vertex, Vertex>;

// Largest matching of a small edge list, exhaustively.
int BruteMatching(const std::vector<Edge>& edges, std::size_t from, std::set<Vertex>* used) {
  if (from == edges.size()) return 0;
  int best = BruteMatching(edges, from + 1, used);  // edge `from` left out
  const Edge& e = edges[from];
  if (used->count(e.first) == 0 && used->count(e.second) == 0) {
    used->insert(e.first);
    used->insert(e.second);
    best = std::max(best, 1 + BruteMatching(edges, from + 1, used));
    used->erase(e.first);
    used->erase(e.second);
  }
  return best;
}

struct Instance {
  std::vector<int> robots;  // ascending
  std::vector<std::pair<int, int>> pair_robots;
  std::vector<std::vector<SequentialLoopCell>> cells;
};

Instance RandomInstance(std::mt19937* rng) {
  Instance in;
  in.robots = {1, 3, 4};  // not 0..N-1: the solver compacts the ids
  in.pair_robots = {{1, 3}, {1, 4}, {3, 4}};
  std::uniform_int_distribution<int> count(1, 5), keyframe(0, 3);
  for (std::size_t p = 0; p < in.pair_robots.size(); ++p) {
    std::set<std::pair<std::size_t, std::size_t>> set;
    const int n = count(*rng);
    while (static_cast<int>(set.size()) < n) {
      set.insert({static_cast<std::size_t>(keyframe(*rng)), static_cast<std::size_t>(keyframe(*rng))});
    }
    std::vector<SequentialLoopCell> c;
    for (const auto& ij : set) c.push_back({ij.first, ij.second, 0.05f});
    in.cells.push_back(std::move(c));
  }
  return in;
}

TEST_CASE("Joint stage B: each pair's part covers its L_seq, the whole is a minimum balanced cover (brute force)") {
  std::mt19937 rng(2026);
  int strictly_shared = 0;
  for (int trial = 0; trial < 120; ++trial) {
    CAPTURE(trial);
    const Instance in = RandomInstance(&rng);
    std::vector<JointCoverPair> pairs;
    std::vector<Edge> edges;
    std::set<Vertex> universe;
    for (std::size_t p = 0; p < in.cells.size(); ++p) {
      pairs.push_back({in.pair_robots[p].first, in.pair_robots[p].second, Span<const SequentialLoopCell>(in.cells[p])});
      for (const SequentialLoopCell& l : in.cells[p]) {
        const Vertex a{in.pair_robots[p].first, l.alpha_index}, b{in.pair_robots[p].second, l.beta_index};
        edges.push_back({a, b});
        universe.insert(a);
        universe.insert(b);
      }
    }
    auto r = SolveJointStageB(Span<const JointCoverPair>(pairs), BalancedCoverParams{});
    REQUIRE_MESSAGE(r.ok(), r.status().ToString());
    REQUIRE(r->robots == in.robots);
    REQUIRE(r->pairs.size() == pairs.size());
    REQUIRE(r->cover.status == BalancedCoverStatus::kOptimal);

    // The share: ceil(N_MM / 2^H(p)) with p uniform over 3 robots, clamped to each robot's candidates.
    std::set<Vertex> used;
    const int n_mm = BruteMatching(edges, 0, &used);
    CHECK(r->cover.max_matching_size == n_mm);
    std::map<int, int> candidates;
    for (const Vertex& v : universe) ++candidates[v.first];
    std::map<int, int> share;
    for (int robot : in.robots) {
      share[robot] = std::min(candidates[robot], static_cast<int>(std::ceil(n_mm / 3.0 - 1e-9)));
    }

    // Brute force: the fewest vertices covering every edge with at least `share` per robot.
    const std::vector<Vertex> vs(universe.begin(), universe.end());
    REQUIRE(vs.size() <= 12);
    int best = 1 << 30;
    for (std::uint32_t mask = 0; mask < (1u << vs.size()); ++mask) {
      std::set<Vertex> in_set;
      std::map<int, int> per_robot;
      for (std::size_t k = 0; k < vs.size(); ++k) {
        if ((mask >> k) & 1u) {
          in_set.insert(vs[k]);
          ++per_robot[vs[k].first];
        }
      }
      bool ok = std::all_of(edges.begin(), edges.end(),
                            [&](const Edge& e) { return in_set.count(e.first) > 0 || in_set.count(e.second) > 0; });
      for (int robot : in.robots) ok = ok && per_robot[robot] >= share[robot];
      if (ok) best = std::min(best, static_cast<int>(in_set.size()));
    }
    CHECK(r->cover.objective_scans == best);

    // Each pair's part: within the pair's keyframes, a cover of its loops, the joint figures; together the joint
    // selection, a keyframe shared by two pairs counted once.
    std::set<Vertex> from_pairs;
    for (std::size_t p = 0; p < pairs.size(); ++p) {
      const BalancedCoverResult& b = r->pairs[p];
      CHECK(b.status == r->cover.status);
      CHECK(b.objective_scans == r->cover.objective_scans);
      CHECK(b.max_matching_size == n_mm);
      CHECK(std::is_sorted(b.selected_left.begin(), b.selected_left.end()));
      CHECK(std::is_sorted(b.selected_right.begin(), b.selected_right.end()));
      const auto has = [](const std::vector<int>& v, std::size_t k) {
        return std::find(v.begin(), v.end(), static_cast<int>(k)) != v.end();
      };
      for (const SequentialLoopCell& l : in.cells[p]) {
        CHECK((has(b.selected_left, l.alpha_index) || has(b.selected_right, l.beta_index)));
      }
      for (int k : b.selected_left) {
        CHECK(std::any_of(in.cells[p].begin(), in.cells[p].end(),
                          [&](const SequentialLoopCell& l) { return l.alpha_index == static_cast<std::size_t>(k); }));
        from_pairs.insert({in.pair_robots[p].first, static_cast<std::size_t>(k)});
      }
      for (int k : b.selected_right) {
        CHECK(std::any_of(in.cells[p].begin(), in.cells[p].end(),
                          [&](const SequentialLoopCell& l) { return l.beta_index == static_cast<std::size_t>(k); }));
        from_pairs.insert({in.pair_robots[p].second, static_cast<std::size_t>(k)});
      }
    }
    CHECK(static_cast<int>(from_pairs.size()) == r->cover.objective_scans);
    int sum_of_parts = 0;
    for (const BalancedCoverResult& b : r->pairs) {
      sum_of_parts += static_cast<int>(b.selected_left.size() + b.selected_right.size());
    }
    strictly_shared += sum_of_parts > r->cover.objective_scans ? 1 : 0;
  }
  CHECK(strictly_shared > 10);  // instances where one scan serves two pairs occur
}

TEST_CASE("Joint stage B refuses bad pairs and weights") {
  const std::vector<SequentialLoopCell> cells = {{0, 0, 0.05f}};
  const Span<const SequentialLoopCell> l(cells);
  const std::vector<JointCoverPair> same = {{2, 2, l}};
  CHECK(SolveJointStageB(Span<const JointCoverPair>(same), {}).status().code() == StatusCode::kInvalidArgument);
  const std::vector<JointCoverPair> negative = {{-1, 2, l}};
  CHECK(SolveJointStageB(Span<const JointCoverPair>(negative), {}).status().code() == StatusCode::kInvalidArgument);
  const std::vector<JointCoverPair> twice = {{0, 1, l}, {1, 0, l}};
  const Status s = SolveJointStageB(Span<const JointCoverPair>(twice), {}).status();
  CHECK(s.code() == StatusCode::kInvalidArgument);
  CHECK(s.message().find("given twice") != std::string::npos);
  BalancedCoverParams weighted;
  weighted.vertex_weights = {1.0, 1.0};
  const std::vector<JointCoverPair> one = {{0, 1, l}};
  CHECK(SolveJointStageB(Span<const JointCoverPair>(one), weighted).status().code() == StatusCode::kInvalidArgument);
}

// Unit descriptors and positions of a robot driving along x; keyframe k at x = k m.
struct Robot {
  std::vector<float> descriptors;
  std::vector<Eigen::Vector3d> positions;
  CascadeRobotInput Input() const {
    return {{Span<const float>(descriptors), 4, {}}, Span<const Eigen::Vector3d>(positions), {}};
  }
};

Robot Straight(std::size_t n) {
  Robot r;
  for (std::size_t k = 0; k < n; ++k) {
    r.descriptors.insert(r.descriptors.end(), {1.0f, 0.0f, 0.0f, 0.0f});
    r.positions.emplace_back(static_cast<double>(k), 0.0, 0.0);
  }
  return r;
}

TEST_CASE("RunCascadeFromStageB takes a joint cover as stage B and refuses one that leaves a loop uncovered") {
  const Robot alpha = Straight(12), beta = Straight(12);
  ExchangeCascadeParams params;
  ExchangeCascadeResult awaiting;
  awaiting.stage_a.found = true;
  for (std::size_t k = 2; k < 10; ++k) awaiting.stage_a.cells.push_back({k, k, 0.01f});
  REQUIRE(CascadeAwaitsStageB(awaiting));

  BalancedCoverResult cover;
  cover.status = BalancedCoverStatus::kOptimal;
  for (int k = 2; k < 10; ++k) (k % 2 == 0 ? cover.selected_left : cover.selected_right).push_back(k);
  cover.objective_scans = 8;
  cover.objective_weight = cover.lower_bound_weight = 8.0;

  ExchangeCascadeResult result = awaiting;
  REQUIRE(RunCascadeFromStageB(alpha.Input(), beta.Input(), params, &cover, 3, &result).ok());
  CHECK(result.stage_b.selected_left == cover.selected_left);
  CHECK(result.stage_b.selected_right == cover.selected_right);
  CHECK(result.stage_b_joint_robots == 3);
  CHECK_FALSE(CascadeAwaitsStageB(result));
  CHECK(FormatStageSolverOutcome(StageBOutcome(result)).rfind("joint cover of 3 robots, optimal: 8", 0) == 0);
  CHECK(result.outcome == CascadeOutcome::kPolicy);
  // A second stage B on the same result is refused.
  CHECK(RunCascadeFromStageB(alpha.Input(), beta.Input(), params, &cover, 3, &result).code() ==
        StatusCode::kInvalidArgument);

  BalancedCoverResult holed = cover;
  holed.selected_right.pop_back();  // loop (9, 9) uncovered
  result = awaiting;
  const Status s = RunCascadeFromStageB(alpha.Input(), beta.Input(), params, &holed, 3, &result);
  CHECK(s.code() == StatusCode::kInvalidArgument);
  CHECK(s.message().find("(9, 9)") != std::string::npos);
  BalancedCoverResult outside = cover;
  outside.selected_left.push_back(11);  // keyframe 11 is in no loop of L_seq
  result = awaiting;
  CHECK(RunCascadeFromStageB(alpha.Input(), beta.Input(), params, &outside, 3, &result).code() ==
        StatusCode::kInvalidArgument);
  result = awaiting;
  CHECK(RunCascadeFromStageB(alpha.Input(), beta.Input(), params, &cover, 1, &result).code() ==
        StatusCode::kInvalidArgument);

  // A joint solve that found no cover ends the pair as a solver failure, like the pair's own.
  BalancedCoverResult none;
  none.status = BalancedCoverStatus::kLimitWithoutSolution;
  result = awaiting;
  REQUIRE(RunCascadeFromStageB(alpha.Input(), beta.Input(), params, &none, 3, &result).ok());
  CHECK(result.outcome == CascadeOutcome::kSolverFailure);
  CHECK(result.no_candidate_reason.find("joint cover") != std::string::npos);

  // Without a joint cover: the pair's own, as RunExchangeCascade solves it.
  result = awaiting;
  REQUIRE(RunCascadeFromStageB(alpha.Input(), beta.Input(), params, nullptr, 0, &result).ok());
  CHECK(result.stage_b_joint_robots == 0);
  CHECK(result.stage_b.status == BalancedCoverStatus::kOptimal);
  CHECK(result.stage_b.objective_scans == 8);  // a perfect matching of 8 loops: 8 scans, 4 + 4 by the share
}

}  // namespace
}  // namespace commerge
