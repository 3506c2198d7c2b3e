// SPDX-License-Identifier: BSD-3-Clause
// The server's named parameter sets (MergeProfileParams): commerge is MergeServerParams{}; paper is the paper's
// cascade as its text states it (stage A B_ij = [A_ij <= tau_inter] over span areas of 10 000 cells, tau_inter of
// the sensor's scan pattern, exactly the scans of L_K, one exchange) with every check of ours off.
#include <doctest/doctest.h>

#include <string>

#include "core/agent/merge_server_params.hpp"

namespace commerge {
namespace {

TEST_CASE("Merge profiles: names round-trip, an unknown name lists the known ones") {
  for (MergeProfile p : {MergeProfile::kCommerge, MergeProfile::kPaper}) {
    REQUIRE(MergeProfileFromName(MergeProfileName(p)).ok());
    CHECK(*MergeProfileFromName(MergeProfileName(p)) == p);
  }
  const auto bad = MergeProfileFromName("fast");
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.status().message().find("'fast' (commerge, paper)") != std::string::npos);
}

TEST_CASE("Merge profiles: commerge is the defaults, paper the paper's cascade with our checks off") {
  const LidarScanTraits spinning;  // 360 deg, repetitive
  LidarScanTraits avia;
  avia.horizontal_fov_deg = 70.4;
  avia.non_repetitive = true;
  const MergeServerParams ours = MergeProfileParams(MergeProfile::kCommerge, spinning);
  const MergeServerParams defaults;
  CHECK(ours.cascade.stage_a.neighbour_rank == defaults.cascade.stage_a.neighbour_rank);
  CHECK(ours.cascade.stage_a.tau_area == defaults.cascade.stage_a.tau_area);
  CHECK(ours.decision.min_ambiguous_support == defaults.decision.min_ambiguous_support);
  CHECK(ours.max_widen_steps == defaults.max_widen_steps);
  CHECK(ours.refine.scans_per_robot == defaults.refine.scans_per_robot);
  CHECK(ours.refine.scans_per_robot > 0);
  // Forward-looking sensors are not refined on spread scans (decision 031).
  CHECK(MergeProfileParams(MergeProfile::kCommerge, avia).refine.scans_per_robot == 0);
  LidarScanTraits aeva;
  aeva.horizontal_fov_deg = 120.0;
  CHECK(MergeProfileParams(MergeProfile::kCommerge, aeva).refine.scans_per_robot == 0);
  CHECK(ValidateMergeServerParams(ours).ok());

  for (const LidarScanTraits& traits : {spinning, avia}) {
    const MergeServerParams paper = MergeProfileParams(MergeProfile::kPaper, traits);
    CHECK(ValidateMergeServerParams(paper).ok());
    const SequentialMatchParams& a = paper.cascade.stage_a;
    // The paper's Table of thresholds: 0.10 for a spinning sensor, 0.05 for a non-repetitive one.
    CHECK(a.tau_inter == (traits.non_repetitive ? 0.05 : 0.10));
    CHECK(a.tau_area == 10000);
    CHECK(a.neighbour_rank == 0);
    CHECK(a.sequence_half_window == 0);
    CHECK(a.tau_area_fraction == 0.0);
    CHECK(paper.cascade.verification_area_fraction == 0.0);
    CHECK(paper.cascade.max_ambiguous_fraction == 1.0);
    CHECK(paper.cascade.consensus_max_cells == 0);
    CHECK(paper.cascade.policy.min_scans_per_robot == 0);
    CHECK(paper.cascade.policy.min_points_per_robot == 0);
    CHECK(paper.decision.min_ambiguous_support == 0.0);
    CHECK(paper.decision.widen_ambiguous_support == 0.0);
    CHECK(paper.decision.chain_check_support == 0.0);
    CHECK(paper.decision.max_colocated_chance == 0.0);
    CHECK(paper.decision.disagree_odds == 0.0);
    CHECK(paper.max_widen_steps == 0);
    CHECK(paper.refine.scans_per_robot == 0);
    CHECK(paper.cover == StageBCover::kPairwise);
    CHECK(paper.min_submap_points == 0);
  }
}

}  // namespace
}  // namespace commerge
