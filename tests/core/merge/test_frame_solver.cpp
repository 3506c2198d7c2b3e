// SPDX-License-Identifier: BSD-3-Clause
// Multi-robot frame solver against independent references: ground-truth robot frames with noisy inlier
// measurements and injected outliers, a brute force over every spanning forest of small graphs (written here
// from scratch: subset enumeration, breadth-first poses, Eigen's AngleAxis for the angle), bridges, separate
// components, the weight tie-break and the input checks.
#include <doctest/doctest.h>

#include <algorithm>
#include <bitset>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/merge/frame_solver.hpp"

namespace commerge {
namespace {

// A robot map frame within +-extent_m of the ground-truth origin (z within a fifth of that).
Eigen::Isometry3d RandomFrame(std::mt19937& rng, double extent_m = 60.0) {
  std::uniform_real_distribution<double> pos(-extent_m, extent_m), yaw(-kPi, kPi), tilt(-0.1, 0.1);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = RotationFromYawPitchRoll(yaw(rng), tilt(rng), tilt(rng));
  T.translation() = Eigen::Vector3d(pos(rng), pos(rng), 0.2 * pos(rng));
  return T;
}

// Small random perturbation: translation sigma [m], rotation sigma [deg] per axis.
Eigen::Isometry3d Noise(std::mt19937& rng, double sigma_m, double sigma_deg) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  xi << sigma_m * n(rng), sigma_m * n(rng), sigma_m * n(rng), sigma_deg * kPi / 180.0 * n(rng),
      sigma_deg * kPi / 180.0 * n(rng), sigma_deg * kPi / 180.0 * n(rng);
  return ExpSE3(xi);
}

// A wrong transform: the truth moved by 8..30 m and turned by 20..120 deg (far outside the thresholds).
Eigen::Isometry3d Outlier(std::mt19937& rng, const Eigen::Isometry3d& truth) {
  std::uniform_real_distribution<double> dist(8.0, 30.0), angle(20.0, 120.0), u(-1.0, 1.0);
  Eigen::Isometry3d off = Eigen::Isometry3d::Identity();
  off.translation() = dist(rng) * Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  off.linear() = Eigen::AngleAxisd(angle(rng) * kPi / 180.0, Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized())
                     .toRotationMatrix();
  return truth * off;
}

// A measurement of the ground truth, given in a random direction.
FrameMeasurement Measure(std::mt19937& rng, const std::vector<Eigen::Isometry3d>& gt, int a, int b,
                         const Eigen::Isometry3d& error, double weight) {
  FrameMeasurement m;
  if (rng() % 2) std::swap(a, b);
  m.robot_a = a;
  m.robot_b = b;
  m.T_a_b = gt[static_cast<std::size_t>(a)].inverse() * gt[static_cast<std::size_t>(b)] * error;
  m.weight = weight;
  return m;
}

double AngleDeg(const Eigen::Matrix3d& R) { return Eigen::AngleAxisd(R).angle() * 180.0 / kPi; }

// ---- Independent reference for the rule ----------------------------------------------------------------

struct ForestScore {
  int count = -1;
  double weight = 0.0;
  std::vector<bool> consistent;
};

// Transform from the higher robot into the lower one.
Eigen::Isometry3d LoHi(const FrameMeasurement& m) {
  return m.robot_a < m.robot_b ? m.T_a_b : m.T_a_b.inverse();
}

int FindRoot(std::vector<int>& parent, int v) {
  while (parent[static_cast<std::size_t>(v)] != v) v = parent[static_cast<std::size_t>(v)];
  return v;
}

// Score of the forest `chosen` (indices), or count -1 when it has a cycle or does not span the components.
ForestScore ScoreForest(int n, const std::vector<FrameMeasurement>& ms, const std::vector<int>& chosen,
                        int components, double max_t, double max_r_deg) {
  ForestScore score;
  std::vector<int> parent(static_cast<std::size_t>(n));
  for (int v = 0; v < n; ++v) parent[static_cast<std::size_t>(v)] = v;
  for (int k : chosen) {
    const int a = FindRoot(parent, ms[static_cast<std::size_t>(k)].robot_a);
    const int b = FindRoot(parent, ms[static_cast<std::size_t>(k)].robot_b);
    if (a == b) return score;  // cycle
    parent[static_cast<std::size_t>(a)] = b;
  }
  if (n - static_cast<int>(chosen.size()) != components) return score;
  // Breadth-first poses from each tree's first robot.
  std::vector<Eigen::Isometry3d> X(static_cast<std::size_t>(n), Eigen::Isometry3d::Identity());
  std::vector<bool> placed(static_cast<std::size_t>(n), false);
  for (int root = 0; root < n; ++root) {
    if (placed[static_cast<std::size_t>(root)]) continue;
    placed[static_cast<std::size_t>(root)] = true;
    std::vector<int> queue{root};
    for (std::size_t q = 0; q < queue.size(); ++q) {
      const int u = queue[q];
      for (int k : chosen) {
        const FrameMeasurement& m = ms[static_cast<std::size_t>(k)];
        int other = -1;
        Eigen::Isometry3d T_u_other;
        if (m.robot_a == u) {
          other = m.robot_b;
          T_u_other = m.T_a_b;
        } else if (m.robot_b == u) {
          other = m.robot_a;
          T_u_other = m.T_a_b.inverse();
        }
        if (other < 0 || placed[static_cast<std::size_t>(other)]) continue;
        X[static_cast<std::size_t>(other)] = X[static_cast<std::size_t>(u)] * T_u_other;
        placed[static_cast<std::size_t>(other)] = true;
        queue.push_back(other);
      }
    }
  }
  score.count = 0;
  score.consistent.assign(ms.size(), false);
  for (std::size_t k = 0; k < ms.size(); ++k) {
    const FrameMeasurement& m = ms[k];
    const int lo = std::min(m.robot_a, m.robot_b), hi = std::max(m.robot_a, m.robot_b);
    const Eigen::Isometry3d implied = X[static_cast<std::size_t>(lo)].inverse() * X[static_cast<std::size_t>(hi)];
    const Eigen::Isometry3d measured = LoHi(m);
    const bool in_chosen = std::find(chosen.begin(), chosen.end(), static_cast<int>(k)) != chosen.end();
    if (in_chosen || ((implied.translation() - measured.translation()).norm() <= max_t &&
                      AngleDeg(measured.linear().transpose() * implied.linear()) <= max_r_deg)) {
      score.consistent[k] = true;
      ++score.count;
      score.weight += m.weight;
    }
  }
  return score;
}

int CountComponents(int n, const std::vector<FrameMeasurement>& ms) {
  std::vector<int> parent(static_cast<std::size_t>(n));
  for (int v = 0; v < n; ++v) parent[static_cast<std::size_t>(v)] = v;
  int c = n;
  for (const auto& m : ms) {
    const int a = FindRoot(parent, m.robot_a), b = FindRoot(parent, m.robot_b);
    if (a != b) {
      parent[static_cast<std::size_t>(a)] = b;
      --c;
    }
  }
  return c;
}

// Best (count, weight) over every subset of the measurements that is a spanning forest.
ForestScore BruteForce(int n, const std::vector<FrameMeasurement>& ms, double max_t, double max_r_deg) {
  const int components = CountComponents(n, ms);
  ForestScore best;
  const std::size_t m = ms.size();
  for (std::uint32_t mask = 0; mask < (1U << m); ++mask) {
    if (static_cast<int>(std::bitset<32>(mask).count()) != n - components) continue;
    std::vector<int> chosen;
    for (std::size_t k = 0; k < m; ++k) {
      if ((mask >> k) & 1U) chosen.push_back(static_cast<int>(k));
    }
    const ForestScore s = ScoreForest(n, ms, chosen, components, max_t, max_r_deg);
    if (s.count > best.count || (s.count == best.count && s.weight > best.weight + 1e-9)) best = s;
  }
  return best;
}

// T_world_map of robot r relative to robot 0, from the ground truth.
Eigen::Isometry3d Relative(const std::vector<Eigen::Isometry3d>& gt, int anchor, int r) {
  return gt[static_cast<std::size_t>(anchor)].inverse() * gt[static_cast<std::size_t>(r)];
}

void CheckFrame(const Eigen::Isometry3d& got, const Eigen::Isometry3d& expected, double max_t, double max_deg) {
  CHECK((got.translation() - expected.translation()).norm() < max_t);
  CHECK(AngleDeg(expected.linear().transpose() * got.linear()) < max_deg);
}

// The size-limit tests run the default node budget in optimised builds; Debug builds (the sanitizer
// configuration, with Eigen unoptimised and ~500x slower) use a small one.
#ifdef NDEBUG
constexpr std::size_t kSizeLimitBudget = FrameSolverParams{}.max_search_nodes;
#else
constexpr std::size_t kSizeLimitBudget = 3000;
#endif

}  // namespace

TEST_CASE("Frame solver recovers ground-truth frames from noisy inliers and rejects injected outliers") {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 3; ++trial) {
    const int n = 5;
    std::vector<Eigen::Isometry3d> gt;
    for (int r = 0; r < n; ++r) gt.push_back(RandomFrame(rng, 25.0));
    std::vector<FrameMeasurement> ms;
    std::vector<bool> is_outlier;
    // Inliers: every pair once, some twice (noise 2 cm, 0.03 deg per axis; a rotation error also moves the
    // other robot by the lever arm between the frames, up to ~70 m here).
    for (int a = 0; a < n; ++a) {
      for (int b = a + 1; b < n; ++b) {
        const int copies = (a + b + trial) % 3 == 0 ? 2 : 1;
        for (int c = 0; c < copies; ++c) {
          ms.push_back(Measure(rng, gt, a, b, Noise(rng, 0.02, 0.03), 20.0 + static_cast<double>(rng() % 30)));
          is_outlier.push_back(false);
        }
      }
    }
    // Outliers, some of them with more weight than any inlier.
    for (int k = 0; k < 5; ++k) {
      const int a = static_cast<int>(rng() % n);
      const int b = (a + 1 + static_cast<int>(rng() % (n - 1))) % n;
      FrameMeasurement m = Measure(rng, gt, a, b, Eigen::Isometry3d::Identity(), 80.0);
      m.T_a_b = Outlier(rng, m.T_a_b);
      ms.push_back(m);
      is_outlier.push_back(true);
    }
    std::shuffle(ms.begin(), ms.end(), rng);  // keep is_outlier aligned: recompute from the truth below
    for (std::size_t k = 0; k < ms.size(); ++k) {
      const Eigen::Isometry3d truth = gt[static_cast<std::size_t>(ms[k].robot_a)].inverse() *
                                      gt[static_cast<std::size_t>(ms[k].robot_b)];
      is_outlier[k] = (ms[k].T_a_b.translation() - truth.translation()).norm() > 1.0;
    }

    const Result<FrameSolution> sol = SolveRobotFrames(n, ms);
    REQUIRE_MESSAGE(sol.ok(), sol.status().ToString());
    CHECK(sol->search_exhaustive);
    CHECK(sol->num_components == 1);
    REQUIRE(sol->measurements.size() == ms.size());
    for (std::size_t k = 0; k < ms.size(); ++k) {
      const MeasurementOutcome& o = sol->measurements[k];
      CHECK(o.verdict == (is_outlier[k] ? MeasurementVerdict::kRejected : MeasurementVerdict::kAccepted));
      if (is_outlier[k]) CHECK((o.cycle_translation_m > 2.0 || o.cycle_rotation_deg > 5.0));
      if (!is_outlier[k]) CHECK(o.residual_translation_m < 0.3);
    }
    CHECK(sol->rejected == 5);
    CHECK(sol->accepted == ms.size() - 5);
    CHECK(sol->unverified == 0);
    for (int r = 0; r < n; ++r) {
      const RobotFrame& f = sol->robots[static_cast<std::size_t>(r)];
      CHECK(f.component == 0);
      CHECK(f.anchor_robot == 0);
      CHECK(f.connected_to_robot0);
      CheckFrame(f.T_world_map, Relative(gt, 0, r), 0.1, 0.5);
    }
    CHECK(sol->robots[0].T_world_map.isApprox(Eigen::Isometry3d::Identity()));
  }
}

TEST_CASE("Frame solver refinement averages parallel measurements to their weighted mean") {
  // Two robots, three parallel measurements differing only in x: the least-squares frame is the weighted
  // mean of the three translations (equal rotations, so the whitened residuals are linear in x).
  std::vector<FrameMeasurement> ms(3);
  const double xs[] = {10.0, 10.6, 9.7};
  const double ws[] = {1.0, 2.0, 3.0};
  for (int k = 0; k < 3; ++k) {
    ms[static_cast<std::size_t>(k)].robot_a = 0;
    ms[static_cast<std::size_t>(k)].robot_b = 1;
    ms[static_cast<std::size_t>(k)].T_a_b.translation() = Eigen::Vector3d(xs[k], -3.0, 0.5);
    ms[static_cast<std::size_t>(k)].weight = ws[k];
  }
  const Result<FrameSolution> sol = SolveRobotFrames(2, ms);
  REQUIRE(sol.ok());
  const double mean = (10.0 * 1.0 + 10.6 * 2.0 + 9.7 * 3.0) / 6.0;
  CHECK(sol->robots[1].T_world_map.translation().x() == doctest::Approx(mean).epsilon(1e-9));
  CHECK(sol->robots[1].T_world_map.translation().y() == doctest::Approx(-3.0).epsilon(1e-9));
  CHECK(sol->accepted == 3);
  CHECK(sol->refine_iterations_run >= 1);
}

TEST_CASE("Frame solver refinement reaches a minimum of the whitened weighted least-squares cost") {
  // Reference: the documented cost sum_m w_m |LogSE3(T_lo_hi^-1 X_lo^-1 X_hi)|^2 whitened by the thresholds,
  // evaluated here; central differences along every box-plus direction of every non-anchor robot must show a
  // zero gradient and no descent.
  std::mt19937 rng(21);
  const int n = 4;
  std::vector<Eigen::Isometry3d> gt;
  for (int r = 0; r < n; ++r) gt.push_back(RandomFrame(rng, 15.0));
  std::vector<FrameMeasurement> ms;
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      for (int c = 0; c < 2; ++c) {
        ms.push_back(Measure(rng, gt, a, b, Noise(rng, 0.25, 0.8), 1.0 + static_cast<double>(rng() % 9)));
      }
    }
  }
  FrameSolverParams params;
  params.refine_iterations = 20;
  const Result<FrameSolution> sol = SolveRobotFrames(n, ms, params);
  REQUIRE(sol.ok());
  REQUIRE(sol->rejected == 0);
  const double sigma_t = params.max_translation_m, sigma_r = params.max_rotation_deg * kPi / 180.0;
  auto cost = [&](const std::vector<Eigen::Isometry3d>& X) {
    double c = 0.0;
    for (const FrameMeasurement& m : ms) {
      const int lo = std::min(m.robot_a, m.robot_b), hi = std::max(m.robot_a, m.robot_b);
      const Vector6d e =
          LogSE3(LoHi(m).inverse() * X[static_cast<std::size_t>(lo)].inverse() * X[static_cast<std::size_t>(hi)]);
      c += m.weight * (e.head<3>().squaredNorm() / (sigma_t * sigma_t) + e.tail<3>().squaredNorm() / (sigma_r * sigma_r));
    }
    return c;
  };
  std::vector<Eigen::Isometry3d> X;
  for (const RobotFrame& f : sol->robots) X.push_back(f.T_world_map);
  const double c0 = cost(X);
  const double h = 1e-5;
  for (int r = 1; r < n; ++r) {
    for (int i = 0; i < 6; ++i) {
      Vector6d d = Vector6d::Zero();
      d(i) = h;
      std::vector<Eigen::Isometry3d> plus = X, minus = X;
      plus[static_cast<std::size_t>(r)] = X[static_cast<std::size_t>(r)] * ExpSE3(d);
      minus[static_cast<std::size_t>(r)] = X[static_cast<std::size_t>(r)] * ExpSE3(-d);
      const double cp = cost(plus), cm = cost(minus);
      CHECK(std::abs(cp - cm) / (2.0 * h) < 1e-4 * (1.0 + c0));
      CHECK(cp >= c0 - 1e-9 * c0);
      CHECK(cm >= c0 - 1e-9 * c0);
    }
  }
  // The forest alone (no refinement) has a higher cost.
  params.refine_iterations = 0;
  const Result<FrameSolution> unrefined = SolveRobotFrames(n, ms, params);
  REQUIRE(unrefined.ok());
  std::vector<Eigen::Isometry3d> X0;
  for (const RobotFrame& f : unrefined->robots) X0.push_back(f.T_world_map);
  CHECK(cost(X0) > c0);
  CHECK(unrefined->refine_iterations_run == 0);
}

TEST_CASE("Frame solver maximises the consistent count like a brute force over all spanning forests") {
  std::mt19937 rng(11);
  const double max_t = 2.0, max_r = 5.0;
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 3 + trial % 4;  // 3..6 robots
    std::vector<Eigen::Isometry3d> gt;
    for (int r = 0; r < n; ++r) gt.push_back(RandomFrame(rng));
    // A second, wrong set of placements that a group of outliers agrees on (perceptual aliasing), so that the
    // forests compete: consistent outlier cliques against inliers.
    std::vector<Eigen::Isometry3d> alias = gt;
    for (int r = 1; r < n; ++r) alias[static_cast<std::size_t>(r)] = Outlier(rng, gt[static_cast<std::size_t>(r)]);
    std::vector<FrameMeasurement> ms;
    const int count = 5 + static_cast<int>(rng() % 8);  // 5..12 measurements
    for (int k = 0; k < count; ++k) {
      const int a = static_cast<int>(rng() % n);
      const int b = (a + 1 + static_cast<int>(rng() % (n - 1))) % n;
      const double w = 1.0 + static_cast<double>(rng() % 4);  // integer weights: ties happen
      const int kind = static_cast<int>(rng() % 10);
      if (kind < 5) {
        ms.push_back(Measure(rng, gt, a, b, Noise(rng, 0.4, 1.0), w));  // inlier, sometimes near the threshold
      } else if (kind < 8) {
        ms.push_back(Measure(rng, alias, a, b, Noise(rng, 0.4, 1.0), w));  // aliased
      } else {
        FrameMeasurement m = Measure(rng, gt, a, b, Eigen::Isometry3d::Identity(), w);
        m.T_a_b = Outlier(rng, m.T_a_b);
        ms.push_back(m);
      }
    }
    const ForestScore best = BruteForce(n, ms, max_t, max_r);
    const Result<FrameSolution> sol = SolveRobotFrames(n, ms);
    REQUIRE_MESSAGE(sol.ok(), sol.status().ToString());
    CHECK(sol->search_exhaustive);
    CHECK(sol->consistent_count == static_cast<std::size_t>(best.count));
    CHECK(sol->consistent_weight == doctest::Approx(best.weight).epsilon(1e-12));
    CHECK(sol->num_components == CountComponents(n, ms));
    // The reported verdicts are those of one optimal forest: its forest edges, re-scored by the reference,
    // give the same consistent set.
    std::vector<int> forest;
    for (std::size_t k = 0; k < ms.size(); ++k) {
      if (sol->measurements[k].in_forest) forest.push_back(static_cast<int>(k));
    }
    const ForestScore own = ScoreForest(n, ms, forest, sol->num_components, max_t, max_r);
    REQUIRE(own.count == best.count);
    std::size_t accepted_or_unverified = 0;
    for (std::size_t k = 0; k < ms.size(); ++k) {
      const bool rejected = sol->measurements[k].verdict == MeasurementVerdict::kRejected;
      CHECK(rejected == !own.consistent[k]);
      accepted_or_unverified += rejected ? 0 : 1;
    }
    CHECK(accepted_or_unverified == sol->consistent_count);
  }
}

TEST_CASE("Frame solver reports bridges as unverified and parallel measurements as cycle-checked") {
  std::mt19937 rng(5);
  std::vector<Eigen::Isometry3d> gt;
  for (int r = 0; r < 4; ++r) gt.push_back(RandomFrame(rng));
  // 0-1 twice (a 2-cycle, each checks the other), then the chain 1-2, 2-3: two bridges.
  std::vector<FrameMeasurement> ms;
  ms.push_back(Measure(rng, gt, 0, 1, Noise(rng, 0.05, 0.2), 10.0));
  ms.push_back(Measure(rng, gt, 0, 1, Noise(rng, 0.05, 0.2), 12.0));
  ms.push_back(Measure(rng, gt, 1, 2, Noise(rng, 0.05, 0.2), 7.0));
  ms.push_back(Measure(rng, gt, 3, 2, Noise(rng, 0.05, 0.2), 9.0));
  const Result<FrameSolution> sol = SolveRobotFrames(4, ms);
  REQUIRE(sol.ok());
  CHECK(sol->measurements[0].verdict == MeasurementVerdict::kAccepted);
  CHECK(sol->measurements[1].verdict == MeasurementVerdict::kAccepted);
  CHECK(sol->measurements[2].verdict == MeasurementVerdict::kUnverified);
  CHECK(sol->measurements[3].verdict == MeasurementVerdict::kUnverified);
  CHECK(sol->unverified == 2);
  CHECK(sol->accepted == 2);
  CHECK(sol->measurements[2].in_forest);
  CHECK(sol->measurements[3].in_forest);
  // One of the parallel pair is the forest edge, corroborated by the other.
  const int forest_edge = sol->measurements[0].in_forest ? 0 : 1;
  CHECK(sol->measurements[static_cast<std::size_t>(1 - forest_edge)].in_forest == false);
  CHECK(sol->measurements[static_cast<std::size_t>(forest_edge)].support == 1);
  CHECK(sol->measurements[2].support == 0);
  for (int r = 0; r < 4; ++r) CheckFrame(sol->robots[static_cast<std::size_t>(r)].T_world_map, Relative(gt, 0, r), 0.3, 1.0);
  CHECK(std::string(MeasurementVerdictName(MeasurementVerdict::kUnverified)) == "unverified");
  CHECK(std::string(MeasurementVerdictName(MeasurementVerdict::kAccepted)) == "accepted");
  CHECK(std::string(MeasurementVerdictName(MeasurementVerdict::kRejected)) == "rejected");
}

TEST_CASE("Frame solver reports two components with their own anchors") {
  std::mt19937 rng(8);
  std::vector<Eigen::Isometry3d> gt;
  for (int r = 0; r < 6; ++r) gt.push_back(RandomFrame(rng));
  // Component {0, 2, 4} (a triangle) and {1, 5} (a bridge); robot 3 alone.
  std::vector<FrameMeasurement> ms;
  ms.push_back(Measure(rng, gt, 0, 2, Noise(rng, 0.03, 0.1), 5.0));
  ms.push_back(Measure(rng, gt, 2, 4, Noise(rng, 0.03, 0.1), 5.0));
  ms.push_back(Measure(rng, gt, 4, 0, Noise(rng, 0.03, 0.1), 5.0));
  ms.push_back(Measure(rng, gt, 5, 1, Noise(rng, 0.03, 0.1), 5.0));
  const Result<FrameSolution> sol = SolveRobotFrames(6, ms);
  REQUIRE(sol.ok());
  CHECK(sol->num_components == 3);
  const int expected_component[] = {0, 1, 0, 2, 0, 1};
  const int expected_anchor[] = {0, 1, 0, 3, 0, 1};
  for (int r = 0; r < 6; ++r) {
    const RobotFrame& f = sol->robots[static_cast<std::size_t>(r)];
    CHECK(f.component == expected_component[r]);
    CHECK(f.anchor_robot == expected_anchor[r]);
    CHECK(f.connected_to_robot0 == (expected_anchor[r] == 0));
    CheckFrame(f.T_world_map, Relative(gt, expected_anchor[r], r), 0.1, 0.5);
  }
  CHECK(sol->robots[1].T_world_map.isApprox(Eigen::Isometry3d::Identity()));
  CHECK(sol->robots[3].T_world_map.isApprox(Eigen::Isometry3d::Identity()));
  CHECK(sol->accepted == 3);
  CHECK(sol->unverified == 1);
  CHECK(sol->measurements[3].verdict == MeasurementVerdict::kUnverified);

  // No measurements at all: every robot is its own component.
  const Result<FrameSolution> empty = SolveRobotFrames(3, Span<const FrameMeasurement>());
  REQUIRE(empty.ok());
  CHECK(empty->num_components == 3);
  CHECK(empty->robots[2].component == 2);
  CHECK(empty->robots[2].anchor_robot == 2);
  CHECK_FALSE(empty->robots[2].connected_to_robot0);
}

TEST_CASE("Frame solver breaks a count tie by weight and reports the rejecting cycle error") {
  // Two robots, two measurements 3 m apart in x: either forest has one consistent measurement, so the heavier
  // one wins and the other is rejected with a cycle error of exactly 3 m and 0 deg.
  std::vector<FrameMeasurement> ms(2);
  ms[0].T_a_b.translation() = Eigen::Vector3d(4.0, 1.0, 0.0);
  ms[0].weight = 3.0;
  ms[1].robot_a = 1;
  ms[1].robot_b = 0;  // given the other way round
  Eigen::Isometry3d T_0_1 = Eigen::Isometry3d::Identity();
  T_0_1.translation() = Eigen::Vector3d(7.0, 1.0, 0.0);
  ms[1].T_a_b = T_0_1.inverse();
  ms[1].weight = 5.0;
  const Result<FrameSolution> sol = SolveRobotFrames(2, ms);
  REQUIRE(sol.ok());
  // Parallel measurements form a 2-cycle: neither is a bridge, so the kept one is accepted (with no support).
  CHECK(sol->measurements[1].verdict == MeasurementVerdict::kAccepted);
  CHECK(sol->measurements[1].support == 0);
  CHECK(sol->measurements[0].verdict == MeasurementVerdict::kRejected);
  CHECK(sol->measurements[0].cycle_translation_m == doctest::Approx(3.0).epsilon(1e-12));
  CHECK(sol->measurements[0].cycle_rotation_deg < 1e-6);
  CHECK(sol->consistent_count == 1);
  CHECK(sol->consistent_weight == 5.0);
  CHECK(sol->robots[1].T_world_map.translation().isApprox(Eigen::Vector3d(7.0, 1.0, 0.0)));
}

TEST_CASE("Frame solver rejects invalid inputs naming the field and value") {
  std::vector<FrameMeasurement> ms(1);
  auto message = [](const Result<FrameSolution>& r) {
    REQUIRE_FALSE(r.ok());
    CHECK(r.status().code() == StatusCode::kInvalidArgument);
    return r.status().message();
  };
  std::string m = message(SolveRobotFrames(1, ms));
  CHECK(m.find("num_robots") != std::string::npos);
  CHECK(m.find("got 1") != std::string::npos);
  CHECK(message(SolveRobotFrames(9, ms)).find("got 9") != std::string::npos);

  ms[0].robot_b = 4;
  m = message(SolveRobotFrames(4, ms));
  CHECK(m.find("measurement 0 robot_b = 4") != std::string::npos);
  ms[0].robot_b = 1;
  ms[0].robot_a = -1;
  CHECK(message(SolveRobotFrames(4, ms)).find("robot_a = -1") != std::string::npos);
  ms[0].robot_a = 2;
  ms[0].robot_b = 2;
  CHECK(message(SolveRobotFrames(4, ms)).find("self-loop") != std::string::npos);
  ms[0].robot_b = 3;

  std::vector<FrameMeasurement> two(2);
  two[1].T_a_b.translation().z() = std::numeric_limits<double>::quiet_NaN();
  m = message(SolveRobotFrames(2, two));
  CHECK(m.find("measurement 1 T_a_b") != std::string::npos);
  CHECK(m.find("non-finite") != std::string::npos);
  two[1].T_a_b = Eigen::Isometry3d::Identity();
  two[1].T_a_b.linear()(0, 0) = 1.5;
  CHECK(message(SolveRobotFrames(2, two)).find("not a rigid transform") != std::string::npos);
  two[1].T_a_b = Eigen::Isometry3d::Identity();
  two[1].T_a_b.linear()(0, 0) = 1.0 + 1e-7;  // rounding is tolerated (and projected away)
  CHECK(SolveRobotFrames(2, two).ok());
  two[1].T_a_b = Eigen::Isometry3d::Identity();
  two[1].weight = 0.0;
  m = message(SolveRobotFrames(2, two));
  CHECK(m.find("measurement 1 weight = 0") != std::string::npos);
  two[1].weight = -2.0;
  CHECK(message(SolveRobotFrames(2, two)).find("weight = -2") != std::string::npos);
  two[1].weight = std::numeric_limits<double>::infinity();
  CHECK(message(SolveRobotFrames(2, two)).find("weight = inf") != std::string::npos);

  std::vector<FrameMeasurement> many(65);
  CHECK(message(SolveRobotFrames(2, many)).find("got 65") != std::string::npos);

  FrameSolverParams params;
  params.max_translation_m = -1.0;
  CHECK(message(SolveRobotFrames(2, Span<const FrameMeasurement>(), params)).find("max_translation_m") !=
        std::string::npos);
  params = FrameSolverParams{};
  params.max_rotation_deg = 0.0;
  CHECK(ValidateFrameSolverParams(params).message().find("max_rotation_deg") != std::string::npos);
  params = FrameSolverParams{};
  params.refine_iterations = -1;
  CHECK(ValidateFrameSolverParams(params).message().find("refine_iterations") != std::string::npos);
  params = FrameSolverParams{};
  params.max_search_nodes = 0;
  CHECK(ValidateFrameSolverParams(params).message().find("max_search_nodes") != std::string::npos);
  CHECK(ValidateFrameSolverParams(FrameSolverParams{}).ok());
}

TEST_CASE("Frame solver at the size limits recovers the inliers within its node budget") {
  // 8 robots, 64 measurements: 48 noisy inliers and 16 outliers on random pairs. Too many forests for the
  // exact proof within the budget, so this checks the budgeted answer against the ground truth.
  std::mt19937 rng(41);
  const int n = kFrameSolverMaxRobots;
  std::vector<Eigen::Isometry3d> gt;
  for (int r = 0; r < n; ++r) gt.push_back(RandomFrame(rng, 25.0));
  std::vector<FrameMeasurement> ms;
  std::vector<bool> is_outlier;
  for (int a = 1; a < n; ++a) {  // a spanning chain of inliers, so that every robot is observable
    ms.push_back(Measure(rng, gt, a - 1, a, Noise(rng, 0.03, 0.05), 10.0));
    is_outlier.push_back(false);
  }
  while (ms.size() < kFrameSolverMaxMeasurements) {
    const int a = static_cast<int>(rng() % n);
    const int b = (a + 1 + static_cast<int>(rng() % (n - 1))) % n;
    const bool outlier = ms.size() % 4 == 0;
    FrameMeasurement m = Measure(rng, gt, a, b, Noise(rng, 0.03, 0.05), 1.0 + static_cast<double>(rng() % 20));
    if (outlier) m.T_a_b = Outlier(rng, m.T_a_b);
    ms.push_back(m);
    is_outlier.push_back(outlier);
  }
  FrameSolverParams params;
  params.max_search_nodes = kSizeLimitBudget;
  const auto start = std::chrono::steady_clock::now();
  const Result<FrameSolution> sol = SolveRobotFrames(n, ms, params);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  REQUIRE(sol.ok());
  MESSAGE("8 robots, 64 measurements (16 outliers): " << sol->search_nodes << " nodes, exhaustive "
                                                       << sol->search_exhaustive << ", " << seconds * 1e3 << " ms");
  CHECK(sol->search_nodes <= kSizeLimitBudget);
  for (std::size_t k = 0; k < ms.size(); ++k) {
    CHECK(sol->measurements[k].verdict == (is_outlier[k] ? MeasurementVerdict::kRejected : MeasurementVerdict::kAccepted));
  }
  for (int r = 0; r < n; ++r) CheckFrame(sol->robots[static_cast<std::size_t>(r)].T_world_map, Relative(gt, 0, r), 0.1, 0.5);

  // Even a budget of one node yields a complete forest (the Kruskal incumbent), flagged as not exhaustive.
  FrameSolverParams tiny;
  tiny.max_search_nodes = 1;
  const Result<FrameSolution> rushed = SolveRobotFrames(n, ms, tiny);
  REQUIRE(rushed.ok());
  CHECK_FALSE(rushed->search_exhaustive);
  CHECK(rushed->search_nodes <= 1);
  std::size_t in_forest = 0;
  for (const MeasurementOutcome& o : rushed->measurements) in_forest += o.in_forest ? 1 : 0;
  CHECK(in_forest == static_cast<std::size_t>(n - 1));
  CHECK(rushed->consistent_count >= static_cast<std::size_t>(n - 1));
}

TEST_CASE("Frame solver on 64 mutually inconsistent measurements keeps the maximum-weight spanning tree") {
  // Every forest has exactly n - 1 consistent measurements (its own edges) when no two measurements agree,
  // so the weight tie-break decides: the maximum-weight spanning tree, computed here by Kruskal.
  std::mt19937 rng(43);
  const int n = kFrameSolverMaxRobots;
  std::vector<Eigen::Isometry3d> gt;
  for (int r = 0; r < n; ++r) gt.push_back(RandomFrame(rng, 25.0));
  std::vector<FrameMeasurement> ms;
  for (std::size_t k = 0; k < kFrameSolverMaxMeasurements; ++k) {
    const int a = static_cast<int>(rng() % n);
    const int b = (a + 1 + static_cast<int>(rng() % (n - 1))) % n;
    FrameMeasurement m = Measure(rng, gt, a, b, Eigen::Isometry3d::Identity(), 1.0 + static_cast<double>(rng() % 1000));
    m.T_a_b = Outlier(rng, m.T_a_b);
    ms.push_back(m);
  }
  std::vector<std::size_t> order(ms.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return ms[x].weight > ms[y].weight; });
  std::vector<int> parent(static_cast<std::size_t>(n));
  for (int v = 0; v < n; ++v) parent[static_cast<std::size_t>(v)] = v;
  double mst_weight = 0.0;
  for (std::size_t k : order) {
    const int a = FindRoot(parent, ms[k].robot_a), b = FindRoot(parent, ms[k].robot_b);
    if (a == b) continue;
    parent[static_cast<std::size_t>(a)] = b;
    mst_weight += ms[k].weight;
  }
  REQUIRE(CountComponents(n, ms) == 1);

  FrameSolverParams params;
  params.max_search_nodes = kSizeLimitBudget;
  const auto start = std::chrono::steady_clock::now();
  const Result<FrameSolution> sol = SolveRobotFrames(n, ms, params);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  REQUIRE(sol.ok());
  MESSAGE("8 robots, 64 inconsistent measurements: " << sol->search_nodes << " nodes, exhaustive "
                                                     << sol->search_exhaustive << ", " << seconds * 1e3 << " ms");
  CHECK(sol->search_nodes <= kSizeLimitBudget);
  CHECK(sol->consistent_count == static_cast<std::size_t>(n - 1));
  CHECK(sol->consistent_weight == doctest::Approx(mst_weight).epsilon(1e-12));
  CHECK(sol->rejected == ms.size() - static_cast<std::size_t>(n - 1));
}

}  // namespace commerge
