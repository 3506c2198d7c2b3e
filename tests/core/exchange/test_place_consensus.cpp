// SPDX-License-Identifier: BSD-3-Clause
// Place consensus among stage A's clusters (core/exchange/place_consensus.hpp) on two robots whose answer is
// known: beta's map lies in alpha's at yaw 30 deg, t = (50, -20, 1) m. Beta drives two stretches of alpha's
// L-shaped path (two true places) and, between them, a place alpha never saw that looks like alpha's keyframes
// 35..54 (exact descriptor copies, so stage A's lowest mean picks it). Each cluster's placement is checked
// against that transform (and the repeated place's against the one its pairs imply); the consensus against
// supports summed by hand; the cascade end to end on descriptors built from orthonormal places.
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/exchange/exchange_cascade.hpp"
#include "core/exchange/place_consensus.hpp"
#include "core/geometry/angles.hpp"

namespace commerge {
namespace {

constexpr double kYawDeg = 30.0;
const Eigen::Vector3d kT(50.0, -20.0, 1.0);

// Alpha's map: keyframes 0..59 along x, 60..119 along y from (59, 0).
Eigen::Vector3d AlphaPosition(std::size_t i) {
  return i < 60 ? Eigen::Vector3d(static_cast<double>(i), 0.0, 0.0)
                : Eigen::Vector3d(59.0, static_cast<double>(i) - 59.0, 0.0);
}

// Beta keyframe j in alpha's frame: j < 20 at alpha's 10 + j, 20 <= j < 40 at (180 + j, 50) (never seen by
// alpha), j >= 40 at alpha's 40 + j.
Eigen::Vector3d BetaInAlpha(std::size_t j) {
  if (j < 20) return AlphaPosition(10 + j);
  if (j < 40) return Eigen::Vector3d(180.0 + static_cast<double>(j), 50.0, 0.0);
  return AlphaPosition(40 + j);
}

Eigen::Vector3d ToBetaFrame(const Eigen::Vector3d& p_alpha) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(kYawDeg * kDegToRad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return r.transpose() * (p_alpha - kT);
}

struct ConsensusScene {
  std::vector<Eigen::Vector3d> pa, pb;
  ConsensusScene() {
    for (std::size_t i = 0; i < 120; ++i) pa.push_back(AlphaPosition(i));
    for (std::size_t j = 0; j < 60; ++j) pb.push_back(ToBetaFrame(BetaInAlpha(j)));
  }
};

// One cluster of `len` diagonal cells from (i0, j0), with `width` cells per column (i, i + 1, ...).
void AddCluster(SequentialClusterSet* set, std::size_t i0, std::size_t j0, std::size_t len, std::size_t width,
                float distance) {
  if (set->begin.empty()) set->begin.push_back(0);
  SequentialCluster c;
  c.row_min = i0;
  c.row_max = i0 + len - 1 + width - 1;
  c.col_min = j0;
  c.col_max = j0 + len - 1;
  for (std::size_t k = 0; k < len; ++k) {
    for (std::size_t w = 0; w < width; ++w) {
      set->cells.push_back({i0 + k + w, j0 + k, distance});
      ++c.cell_count;
      c.distance_sum += static_cast<double>(distance);
    }
  }
  set->clusters.push_back(c);
  set->begin.push_back(set->cells.size());
}

// [true place at alpha 10..29, the look-alike at alpha 35..54, true place at alpha 80..99], as stage A orders
// them (by first cell).
SequentialClusterSet ThreeClusters(std::size_t width) {
  SequentialClusterSet set;
  AddCluster(&set, 10, 0, 20, width, 0.14f);
  AddCluster(&set, 35, 20, 20, width, 0.0f);
  AddCluster(&set, 80, 40, 20, width, 0.14f);
  return set;
}

TEST_CASE("Place consensus: a cluster's placement is the transform its keyframe pairs imply") {
  const ConsensusScene s;
  const SequentialClusterSet set = ThreeClusters(1);
  PlaceConsensusParams params;
  for (const std::size_t k : {std::size_t{0}, std::size_t{2}}) {  // the true places: the true transform, exactly
    auto p = PlaceCluster(set.CellsOf(k), set.clusters[k], s.pa, s.pb, params);
    REQUIRE(p.ok());
    REQUIRE(p->valid);
    CHECK(p->yaw_rad * kRadToDeg == doctest::Approx(kYawDeg).epsilon(1e-9));
    CHECK((p->t_alpha_beta_m - kT).norm() < 1e-9);
    CHECK(p->rms_m < 1e-9);
    CHECK(p->weight == 20.0);
    for (const SequentialLoopCell& c : set.CellsOf(k)) CHECK((p->Apply(s.pb[c.beta_index]) - s.pa[c.alpha_index]).norm() < 1e-9);
  }
  // The look-alike: alpha's (35 + k, 0) for beta's place (200 + k, 50): the true rotation, shifted by (-165, -50).
  auto wrong = PlaceCluster(set.CellsOf(1), set.clusters[1], s.pa, s.pb, params);
  REQUIRE(wrong.ok());
  REQUIRE(wrong->valid);
  CHECK(wrong->yaw_rad * kRadToDeg == doctest::Approx(kYawDeg).epsilon(1e-9));
  CHECK((wrong->t_alpha_beta_m - (kT + Eigen::Vector3d(-165.0, -50.0, 0.0))).norm() < 1e-9);

  // A band two cells wide (each beta keyframe also paired with alpha's next one, 1 m on): close, not exact.
  const SequentialClusterSet wide = ThreeClusters(2);
  auto p = PlaceCluster(wide.CellsOf(0), wide.clusters[0], s.pa, s.pb, params);
  REQUIRE(p.ok());
  CHECK(std::abs(p->yaw_rad * kRadToDeg - kYawDeg) < 1.0);
  CHECK((p->t_alpha_beta_m - kT).norm() < 1.0);
  CHECK(p->rms_m > 0.1);
  CHECK(p->rms_m < 1.0);

  // Three keyframes 2 m apart: too short a stretch to fix the yaw, no placement (and no vote).
  SequentialClusterSet tiny;
  AddCluster(&tiny, 10, 0, 3, 1, 0.1f);
  auto t = PlaceCluster(tiny.CellsOf(0), tiny.clusters[0], s.pa, s.pb, params);
  REQUIRE(t.ok());
  CHECK_FALSE(t->valid);
  params.min_extent_m = 1.5;
  t = PlaceCluster(tiny.CellsOf(0), tiny.clusters[0], s.pa, s.pb, params);
  REQUIRE(t.ok());
  CHECK(t->valid);
}

TEST_CASE("Place consensus: placements agree within the drift tolerance, not across a repeated place") {
  PlaceConsensusParams params;  // 4 m + 5 % of the distance between the places, 10 deg
  ClusterPlacement a;
  a.valid = true;
  a.yaw_rad = 0.3;
  a.t_alpha_beta_m = Eigen::Vector3d(10.0, 5.0, 0.0);
  a.place_beta_m = Eigen::Vector3d(0.0, 0.0, 0.0);
  ClusterPlacement b = a;
  b.place_beta_m = Eigen::Vector3d(100.0, 0.0, 0.0);  // 100 m on: 9 m allowed
  CHECK(PlacementsAgree(a, b, params));
  b.t_alpha_beta_m += Eigen::Vector3d(8.5, 0.0, 0.0);  // drifted 8.5 m
  CHECK(PlacementsAgree(a, b, params));
  CHECK(PlacementsAgree(b, a, params));
  b.t_alpha_beta_m += Eigen::Vector3d(1.0, 0.0, 0.0);  // 9.5 m
  CHECK_FALSE(PlacementsAgree(a, b, params));
  b.t_alpha_beta_m = a.t_alpha_beta_m;
  b.yaw_rad = a.yaw_rad + 11.0 * kDegToRad;  // 11 deg: refused by the angle alone ...
  b.place_beta_m = a.place_beta_m;          // ... even at one place (no lever arm)
  CHECK_FALSE(PlacementsAgree(a, b, params));
  b.yaw_rad = a.yaw_rad + 2.0 * kPi - 5.0 * kDegToRad;  // wraps to -5 deg
  CHECK(PlacementsAgree(a, b, params));
  b.valid = false;
  CHECK_FALSE(PlacementsAgree(a, b, params));
  CHECK(PlacementsAgree(a, a, params));
}

TEST_CASE("Place consensus: the look-alike place gives way to the cluster the other true place confirms") {
  const ConsensusScene s;
  const SequentialClusterSet set = ThreeClusters(1);
  PlaceConsensusParams params;
  auto c = RunPlaceConsensus(set, /*preferred=*/1, /*min_span_area=*/100, s.pa, s.pb, params);
  REQUIRE(c.ok());
  REQUIRE(c->support.size() == 3);
  CHECK(c->support[0] == 40.0);  // itself and the other true place, 20 keyframes each
  CHECK(c->support[1] == 20.0);  // only itself
  CHECK(c->support[2] == 40.0);
  CHECK(c->switched);
  CHECK(c->chosen == 0);  // tie between the true places: the first
  CHECK(c->reason.find("support 20") != std::string::npos);

  params.switch_ratio = 2.5;  // 40 < 2.5 x 20: S* stays
  c = RunPlaceConsensus(set, 1, 100, s.pa, s.pb, params);
  REQUIRE(c.ok());
  CHECK_FALSE(c->switched);
  CHECK(c->chosen == 1);

  params.switch_ratio = 2.0;
  c = RunPlaceConsensus(set, 1, 401, s.pa, s.pb, params);  // the true places span 400 cells: not candidates
  REQUIRE(c.ok());
  CHECK_FALSE(c->switched);
  CHECK(c->support[0] == 40.0);  // they still vote

  c = RunPlaceConsensus(set, 0, 100, s.pa, s.pb, params);  // S* a true place already: nothing to change
  REQUIRE(c.ok());
  CHECK_FALSE(c->switched);
  CHECK(c->chosen == 0);

  // Errors name what is wrong.
  CHECK(RunPlaceConsensus(set, 3, 100, s.pa, s.pb, params).status().message().find("preferred cluster 3 of 3") !=
        std::string::npos);
  std::vector<Eigen::Vector3d> short_pb(s.pb.begin(), s.pb.begin() + 50);
  CHECK(RunPlaceConsensus(set, 1, 100, s.pa, short_pb, params).status().message().find("outside the 120 x 50") !=
        std::string::npos);
  std::vector<Eigen::Vector3d> nan_pa = s.pa;
  nan_pa[12].x() = std::nan("");
  CHECK(RunPlaceConsensus(set, 1, 100, nan_pa, s.pb, params).status().message().find("not finite (alpha 12") !=
        std::string::npos);
  params.switch_ratio = 0.5;
  CHECK(RunPlaceConsensus(set, 1, 100, s.pa, s.pb, params).status().message().find("switch_ratio") !=
        std::string::npos);
  params.switch_ratio = 2.0;
  params.agree_m = -1.0;
  CHECK(RunPlaceConsensus(set, 1, 100, s.pa, s.pb, params).status().message().find("agree_m") != std::string::npos);
}

// Descriptors: alpha keyframe i is basis vector i; beta keyframe j sees alpha's place (10 + j, 40 + j) tilted by
// 0.14 towards a basis vector of its own, and at j = 20..39 an exact copy of alpha's keyframe 15 + j.
struct Descriptors {
  static constexpr std::size_t kDim = 200;
  std::vector<float> da, db;
  Descriptors() : da(120 * kDim, 0.0f), db(60 * kDim, 0.0f) {
    for (std::size_t i = 0; i < 120; ++i) da[i * kDim + i] = 1.0f;
    const double norm = std::sqrt(0.99 * 0.99 + 0.14 * 0.14);
    for (std::size_t j = 0; j < 60; ++j) {
      if (j >= 20 && j < 40) {
        db[j * kDim + 15 + j] = 1.0f;
        continue;
      }
      db[j * kDim + (j < 20 ? 10 + j : 40 + j)] = static_cast<float>(0.99 / norm);
      db[j * kDim + 120 + j] = static_cast<float>(0.14 / norm);
    }
  }
};

TEST_CASE("Cascade: with place consensus, stage A passes on a true place instead of the closer look-alike") {
  const ConsensusScene s;
  const Descriptors d;
  CascadeRobotInput a, b;
  a.descriptors = {Span<const float>(d.da), Descriptors::kDim, {}};
  a.positions_m = Span<const Eigen::Vector3d>(s.pa);
  b.descriptors = {Span<const float>(d.db), Descriptors::kDim, {}};
  b.positions_m = Span<const Eigen::Vector3d>(s.pb);
  ExchangeCascadeParams params;  // the paper's stage A: three 20 x 20 clusters at 0 and 0.14 <= tau_inter
  params.stage_a.tau_inter = 0.2;
  params.stage_a.tau_area = 100;
  params.policy.min_scans_per_robot = 0;
  params.policy.min_points_per_robot = 0;

  auto off = RunExchangeCascade(a, b, params);  // off (the paper): the look-alike, mean distance 0
  REQUIRE(off.ok());
  REQUIRE(off->outcome == CascadeOutcome::kPolicy);
  CHECK_FALSE(off->consensus_measured);
  CHECK(off->stage_a.best.row_min == 35);
  CHECK(off->stage_a.num_clusters == 3);

  params.consensus_max_cells = 1000;
  auto on = RunExchangeCascade(a, b, params);
  REQUIRE(on.ok());
  REQUIRE(on->outcome == CascadeOutcome::kPolicy);
  REQUIRE(on->consensus_measured);
  CHECK(on->consensus_switched);
  CHECK(on->consensus_clusters_placed == 3);
  CHECK(on->consensus_support_lowest_mean == 20.0);
  CHECK(on->consensus_support_chosen == 40.0);
  CHECK(on->stage_a.best.row_min == 10);
  CHECK(on->stage_a.best.col_min == 0);
  REQUIRE(on->stage_a.cells.size() == 20);
  for (std::size_t k = 0; k < 20; ++k) {  // L_seq is the true place's cells, so every later stage works on them
    CHECK(on->stage_a.cells[k].alpha_index == 10 + k);
    CHECK(on->stage_a.cells[k].beta_index == k);
  }
  for (const SequentialLoopCell& l : on->stage_c.selected_loops) CHECK(l.alpha_index == 10 + l.beta_index);
  CHECK(on->stage_a.clusters.clusters.empty());  // released after use
  // The placed clusters kept: the one passed on first, then the others by support (40, then 20), with the
  // placements and supports the consensus computed.
  REQUIRE(on->placed_clusters.size() == 3);
  CHECK(on->placed_clusters[0].passed_on);
  CHECK(on->placed_clusters[0].cluster.row_min == 10);
  CHECK(on->placed_clusters[0].support == 40.0);
  CHECK(on->placed_clusters[0].placement.valid);
  CHECK_FALSE(on->placed_clusters[1].passed_on);
  CHECK(on->placed_clusters[1].support == 40.0);  // the other true place
  CHECK(on->placed_clusters[1].cluster.row_min != 35);
  CHECK(on->placed_clusters[2].cluster.row_min == 35);  // the look-alike, supported by itself alone
  CHECK(on->placed_clusters[2].support == 20.0);
  CHECK_FALSE(PlacementsAgree(on->placed_clusters[0].placement, on->placed_clusters[2].placement, params.consensus));
  CHECK(PlacementsAgree(on->placed_clusters[0].placement, on->placed_clusters[1].placement, params.consensus));
  params.max_placed_clusters = 2;  // at most two: the passed-on one and the best supported other
  auto two = RunExchangeCascade(a, b, params);
  REQUIRE(two.ok());
  REQUIRE(two->placed_clusters.size() == 2);
  CHECK(two->placed_clusters[0].passed_on);
  CHECK(two->placed_clusters[1].support == 40.0);
  params.max_placed_clusters = 0;
  CHECK(RunExchangeCascade(a, b, params).status().message().find("max_placed_clusters") != std::string::npos);
  params.max_placed_clusters = 16;
  params.stage_a.tau_area = 401;  // no cluster spans that: nothing is passed on, the clusters are still placed
  auto none = RunExchangeCascade(a, b, params);
  REQUIRE(none.ok());
  CHECK_FALSE(none->stage_a.found);
  CHECK_FALSE(none->consensus_measured);
  REQUIRE(none->placed_clusters.size() == 3);
  for (const PlacedCluster& c : none->placed_clusters) CHECK_FALSE(c.passed_on);
  CHECK(none->placed_clusters[0].support == 40.0);
  CHECK(none->placed_clusters[2].support == 20.0);
  params.stage_a.tau_area = 100;

  params.consensus_max_cells = 59;  // 60 cells below threshold: over the cap, stage A's own choice stands
  auto capped = RunExchangeCascade(a, b, params);
  REQUIRE(capped.ok());
  CHECK(capped->stage_a.best.row_min == 35);
  // No other cluster votes: the look-alike is placed alone, its support its own weight (20 keyframes, the least
  // the consensus could have found; 20 as well with the consensus, 40 for the true place), and the cap is said.
  CHECK(capped->consensus_measured);
  CHECK(capped->consensus_capped);
  CHECK_FALSE(capped->consensus_switched);
  CHECK(capped->consensus_support_chosen == 20.0);
  CHECK(capped->consensus_support_chosen == on->placed_clusters[2].support);
  CHECK(capped->consensus_clusters_placed == 1);
  CHECK(capped->consensus_placement.valid);
  CHECK(PlacementsAgree(capped->consensus_placement, on->placed_clusters[2].placement, params.consensus));
  CHECK(capped->consensus_reason.find("60 cells below threshold > 59 (--consensus-max-cells)") != std::string::npos);
  REQUIRE(capped->placed_clusters.size() == 1);
  CHECK(capped->placed_clusters[0].passed_on);
  CHECK(capped->placed_clusters[0].cluster.row_min == 35);
  CHECK_FALSE(on->consensus_capped);

  params.consensus_max_cells = 1000;
  params.consensus.switch_ratio = 0.0;
  auto bad = RunExchangeCascade(a, b, params);
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.status().message().find("switch_ratio") != std::string::npos);
}

// ---- Placements composed and the place check across pairs ----

// Robot r's map in the world: yaw and translation about z (ground truth of the check's tests).
struct PlanarPose {
  double yaw_deg;
  Eigen::Vector3d t;
  Eigen::Isometry3d T() const {
    Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
    out.linear() = Eigen::AngleAxisd(yaw_deg * kDegToRad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    out.translation() = t;
    return out;
  }
};

// The placement of robot b's map in robot a's that the ground truth implies, with its place at `place_b`.
ClusterPlacement TruePlacement(const PlanarPose& a, const PlanarPose& b, const Eigen::Vector3d& place_b) {
  const Eigen::Isometry3d T_a_b = a.T().inverse() * b.T();
  ClusterPlacement p;
  p.valid = true;
  p.yaw_rad = std::atan2(T_a_b.linear()(1, 0), T_a_b.linear()(0, 0));
  p.t_alpha_beta_m = T_a_b.translation();
  p.place_beta_m = place_b;
  p.weight = 20.0;
  return p;
}

TEST_CASE("Placements: inverse and composition act as the isometries they stand for") {
  const PlanarPose a{20.0, {3.0, -4.0, 0.5}}, b{-75.0, {-40.0, 12.0, 1.0}}, c{160.0, {7.0, 90.0, -0.3}};
  const ClusterPlacement a_b = TruePlacement(a, b, {1.0, 2.0, 0.0});
  const ClusterPlacement b_c = TruePlacement(b, c, {-5.0, 8.0, 0.0});
  const ClusterPlacement a_c = ComposePlacements(a_b, b_c);
  const ClusterPlacement b_a = InvertPlacement(a_b);
  const Eigen::Isometry3d T_a_c = a.T().inverse() * c.T(), T_b_a = b.T().inverse() * a.T();
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(12.5, -3.0, 1.0), Eigen::Vector3d(-80, 40, 2)}) {
    CHECK((a_c.Apply(x) - T_a_c * x).norm() < 1e-9);
    CHECK((b_a.Apply(x) - T_b_a * x).norm() < 1e-9);
    CHECK((b_a.Apply(a_b.Apply(x)) - x).norm() < 1e-9);
  }
  CHECK(a_c.valid);
  CHECK(a_c.place_beta_m == b_c.place_beta_m);
  CHECK((b_a.place_beta_m - a_b.Apply(a_b.place_beta_m)).norm() < 1e-12);
  ClusterPlacement none;
  CHECK_FALSE(ComposePlacements(a_b, none).valid);
  CHECK_FALSE(InvertPlacement(none).valid);
}

TEST_CASE("Placements: the gap of a registered transform is its offset at the place and its yaw difference") {
  const PlanarPose a{20.0, {3.0, -4.0, 0.5}}, b{-75.0, {-40.0, 12.0, 1.0}};
  const Eigen::Vector3d place(6.0, -2.0, 0.0);
  const ClusterPlacement a_b = TruePlacement(a, b, place);
  const Eigen::Isometry3d T_a_b = a.T().inverse() * b.T();
  const PlacementGap same = GapToPlacement(a_b, T_a_b);
  CHECK(same.distance_m < 1e-9);
  CHECK(same.yaw_deg < 1e-9);
  // A registration turned by 30 deg about the place and then moved 5 m: 5 m and 30 deg off at the place.
  for (double turn_deg : {30.0, -150.0, 179.0}) {
    CAPTURE(turn_deg);
    Eigen::Isometry3d about_place = Eigen::Isometry3d::Identity();
    const Eigen::Vector3d q = T_a_b * place;  // the place in a's frame
    about_place.translate(q + Eigen::Vector3d(3.0, 4.0, 0.0));
    about_place.rotate(Eigen::AngleAxisd(turn_deg * kDegToRad, Eigen::Vector3d::UnitZ()));
    about_place.translate(-q);
    const PlacementGap gap = GapToPlacement(a_b, about_place * T_a_b);
    CHECK(gap.distance_m == doctest::Approx(5.0).epsilon(1e-9));
    CHECK(gap.yaw_deg == doctest::Approx(std::abs(turn_deg)).epsilon(1e-9));
  }
  // Roll of a few degrees (a wobbling sensor) leaves the yaw difference near zero.
  Eigen::Isometry3d tilted = T_a_b;
  tilted.rotate(Eigen::AngleAxisd(3.0 * kDegToRad, Eigen::Vector3d::UnitX()));
  CHECK(GapToPlacement(a_b, tilted).yaw_deg < 0.5);
}

TEST_CASE("Place check across pairs: a weak pair is refused only when strong chains exist and none agrees") {
  // Four robots; pairs placed from the ground truth unless made wrong (a look-alike 35 m away, turned 90 deg).
  const std::vector<PlanarPose> world = {{0.0, {0, 0, 0}}, {90.0, {60, 20, 0}}, {-30.0, {-10, 80, 0}},
                                         {180.0, {120, -40, 0}}};
  const Eigen::Vector3d place(5.0, 5.0, 0.0);
  auto pair = [&](int a, int b, double support, bool wrong = false) {
    PairPlacement p{a, b, true, support, TruePlacement(world[static_cast<std::size_t>(a)],
                                                       world[static_cast<std::size_t>(b)], place)};
    if (wrong) {
      p.placement.yaw_rad += 90.0 * kDegToRad;
      p.placement.t_alpha_beta_m += Eigen::Vector3d(35.0, 0.0, 0.0);
    }
    return p;
  };
  const PlaceConsensusParams agreement = [] {
    PlaceConsensusParams p;
    p.agree_m = 8.0;
    p.agree_deg = 20.0;
    return p;
  }();
  auto check = [&](const std::vector<PairPlacement>& pairs) {
    return CheckPlacesAcrossPairs(Span<const PairPlacement>(pairs), 4, 40.0, agreement);
  };

  // The weak pair 0-1 is right: the chain through robot 2 (pairs 0-2 and 1-2, stored alpha < beta) agrees.
  auto v = check({pair(0, 1, 22), pair(0, 2, 100), pair(1, 2, 80)});
  CHECK(v[0].checked);
  CHECK(v[0].chains == 1);
  CHECK(v[0].agreeing == 1);
  CHECK_FALSE(v[0].refused());
  CHECK_FALSE(v[1].checked);  // strong pairs are not checked
  // The weak pair at a look-alike place: the chain through robot 2 disagrees, so it is refused.
  v = check({pair(0, 1, 22, true), pair(0, 2, 100), pair(1, 2, 80)});
  CHECK(v[0].refused());
  REQUIRE(v[0].via.size() == 1);
  CHECK(v[0].via[0] == 2);
  // No chain of strong pairs (1-2 weak): nothing to compare with, the pair stays.
  v = check({pair(0, 1, 22, true), pair(0, 2, 100), pair(1, 2, 30)});
  CHECK(v[0].chains == 0);
  CHECK_FALSE(v[0].refused());
  // Two chains, one through a wrong strong pair (2-1 at a look-alike): the right weak pair agrees with the other.
  v = check({pair(0, 1, 22), pair(0, 2, 100), pair(1, 2, 80, true), pair(0, 3, 90), pair(1, 3, 70)});
  CHECK(v[0].chains == 2);
  CHECK(v[0].agreeing == 1);
  CHECK_FALSE(v[0].refused());
  // Both chains right, the weak pair wrong: refused through both.
  v = check({pair(0, 1, 22, true), pair(0, 2, 100), pair(1, 2, 80), pair(0, 3, 90), pair(1, 3, 70)});
  CHECK(v[0].chains == 2);
  CHECK(v[0].refused());
  // A pair without a placement (no cluster, or one too short to place) is neither checked nor a chain leg.
  std::vector<PairPlacement> unplaced = {pair(0, 1, 22, true), pair(0, 2, 100), pair(1, 2, 80)};
  unplaced[2].placed = false;
  v = check(unplaced);
  CHECK(v[0].chains == 0);
  unplaced[0].placement.valid = false;
  v = check(unplaced);
  CHECK_FALSE(v[0].checked);
}

}  // namespace
}  // namespace commerge
