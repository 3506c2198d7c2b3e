// SPDX-License-Identifier: BSD-3-Clause
// The merge server's pair registrar (core/agent/pair_registrar.hpp): a pair's submaps built from received scans
// register to the ground truth and give the frames, small submaps are voxelised finer while the scans hold more
// detail, a transform at a confirmed ambiguous place is accepted only near its placement, and one that places
// keyframes of unlike descriptors together is refused; BuildSubmap counts the scans it lacks.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/agent/keyframe_database.hpp"
#include "core/agent/merge_server.hpp"
#include "core/agent/pair_registrar.hpp"
#include "core/agent/scan_inbox.hpp"
#include "core/geometry/angles.hpp"
#include "tests/core/agent/keyframe_batch_fixtures.hpp"
#include "tests/core/agent/merge_server_test_support.hpp"
#include "tests/core/agent/scan_chunk_fixtures.hpp"
#include "tests/core/agent/server_fixture.hpp"
#include "tests/core/registration/registration_test_support.hpp"

using namespace commerge;
using commerge::test::AmbiguousShiftedPairBatches;
using commerge::test::ChunksOf;
using commerge::test::EncodeForTest;
using commerge::test::MakeBatch;
using commerge::test::PaperStageA;
using commerge::test::RandomDescriptor;

namespace {

// Robot alpha's and robot beta's keyframes selected for one registration.
PairSelection Selection(int alpha, int beta, std::vector<std::uint32_t> alpha_keyframes,
                        std::vector<std::uint32_t> beta_keyframes) {
  PairSelection sel;
  sel.alpha = alpha;
  sel.beta = beta;
  sel.alpha_keyframes = std::move(alpha_keyframes);
  sel.beta_keyframes = std::move(beta_keyframes);
  return sel;
}

}  // namespace

TEST_CASE("Merge server builds a pair's submaps from received scans and registers them to the ground truth") {
  SyntheticSubmapPair pair;
  REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(41, test::YawOffset(70.0, 12.0, -6.0, 0.3)), &pair).ok());
  // Alpha's keyframe 3 holds the target submap, seen from a pose T_a (so its scan is in that sensor frame);
  // beta's keyframe 0 holds the source submap at the identity.
  const Eigen::Isometry3d T_a = test::YawOffset(-25.0, 4.0, 2.0, 0.0);
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, MergeServerParams{});
  MergeServer& server = *server_owner;
  std::mt19937 rng(3);
  std::vector<std::array<float, kKeyframeDescriptorDim>> d4 = {RandomDescriptor(&rng), RandomDescriptor(&rng),
                                                               RandomDescriptor(&rng), RandomDescriptor(&rng)};
  std::vector<Eigen::Vector3d> p4(4, Eigen::Vector3d::Zero());
  REQUIRE(server.OnKeyframeBatch(MakeBatch(0, 0, d4, p4, 0)).ok());
  REQUIRE(server.OnKeyframeBatch(MakeBatch(1, 0, {d4[0]}, {Eigen::Vector3d::Zero()}, 0)).ok());
  PoseUpdate update;
  update.robot_id = 0;
  update.keyframes = {3};
  update.T_map_sensor = {T_a};
  REQUIRE(server.OnPoseUpdate(update).ok());
  for (const ScanChunk& c : ChunksOf(0, 3, EncodeForTest(test::Transformed(pair.target.points, T_a.inverse())), 1200)) {
    REQUIRE(server.OnScanChunk(c).ok());
  }
  for (const ScanChunk& c : ChunksOf(1, 0, EncodeForTest(pair.source.points), 1200)) REQUIRE(server.OnScanChunk(c).ok());

  PairSelection sel;
  sel.alpha = 0;
  sel.beta = 1;
  sel.alpha_keyframes = {1, 3};  // keyframe 1 was never received: counted as missing
  sel.beta_keyframes = {0};
  auto merged = server.MergePair(sel);
  REQUIRE(merged.ok());
  REQUIRE(merged->attempted);
  CHECK(merged->alpha_scans == 1);
  CHECK(merged->alpha_missing == 1);
  CHECK(merged->beta_scans == 1);
  REQUIRE(merged->registration.success());
  CHECK(test::TranslationErrorM(pair.T_target_source, merged->registration.T_target_source) < 0.2);
  CHECK(test::RotationErrorDeg(pair.T_target_source, merged->registration.T_target_source) < 1.0);

  auto frames = server.SolveFrames(Span<const PairMergeResult>(&*merged, 1));
  REQUIRE(frames.ok());
  REQUIRE(frames->robots.size() == 2);
  CHECK(frames->robots[1].connected_to_robot0);
  CHECK(test::TranslationErrorM(pair.T_target_source, frames->robots[1].T_world_map) < 0.2);

  PairSelection nothing = sel;
  nothing.beta_keyframes.clear();
  auto skipped = server.MergePair(nothing);
  REQUIRE(skipped.ok());
  CHECK_FALSE(skipped->attempted);
  CHECK_FALSE(skipped->reason.empty());
}

namespace {

// The street pair of the test above with scans stored at `scan_voxel_m`, merged by a server with `params`.
PairMergeResult MergeStreetPair(const MergeServerParams& params, double scan_voxel_m, Eigen::Isometry3d* T_truth) {
  StreetPairSpec spec = test::LightStreetSpec(41, test::YawOffset(70.0, 12.0, -6.0, 0.3));
  spec.voxel_size_m = scan_voxel_m;
  SyntheticSubmapPair pair;
  REQUIRE(MakeStreetSubmapPair(spec, &pair).ok());
  *T_truth = pair.T_target_source;
  // Each robot's whole submap arrives as one scan: the server takes scans that large.
  MergeServerParams large_scans = params;
  large_scans.max_scan_points = std::max({params.max_scan_points, pair.target.points.size(), pair.source.points.size()});
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, large_scans);
  MergeServer& server = *server_owner;
  std::mt19937 rng(3);
  const auto d = RandomDescriptor(&rng);
  REQUIRE(server.OnKeyframeBatch(MakeBatch(0, 0, {d}, {Eigen::Vector3d::Zero()}, 0)).ok());
  REQUIRE(server.OnKeyframeBatch(MakeBatch(1, 0, {d}, {Eigen::Vector3d::Zero()}, 0)).ok());
  for (const ScanChunk& c : ChunksOf(0, 0, EncodeForTest(pair.target.points), 1200)) REQUIRE(server.OnScanChunk(c).ok());
  for (const ScanChunk& c : ChunksOf(1, 0, EncodeForTest(pair.source.points), 1200)) REQUIRE(server.OnScanChunk(c).ok());
  auto merged = server.MergePair(Selection(0, 1, {0}, {0}));
  REQUIRE_MESSAGE(merged.ok(), merged.status().ToString());
  REQUIRE(merged->attempted);
  return *merged;
}

}  // namespace

TEST_CASE("Merge server voxelises a small pair's submaps finer while the scans hold more detail, and registers them") {
  Eigen::Isometry3d truth;
  MergeServerParams fixed;
  fixed.min_submap_points = 0;  // the paper: one voxel size
  MergeServerParams wants_more;
  wants_more.min_submap_points = 1000000;  // always below: finer down to the floor while points grow
  const PairMergeResult at_1m = MergeStreetPair(fixed, 0.25, &truth);
  const PairMergeResult finer = MergeStreetPair(wants_more, 0.25, &truth);
  MESSAGE("scans at 0.25 m: submaps " << at_1m.alpha_submap_points << " / " << at_1m.beta_submap_points << " points at "
                                      << at_1m.voxel_size_m << " m, " << finer.alpha_submap_points << " / "
                                      << finer.beta_submap_points << " at " << finer.voxel_size_m << " m");
  CHECK(at_1m.voxel_size_m == 1.0);
  CHECK(finer.voxel_size_m == doctest::Approx(wants_more.min_submap_voxel_size_m));
  CHECK(std::min(finer.alpha_submap_points, finer.beta_submap_points) >
        3 * std::min(at_1m.alpha_submap_points, at_1m.beta_submap_points) / 2);
  for (const PairMergeResult* r : {&at_1m, &finer}) {
    REQUIRE(r->registration.success());
    CHECK(test::TranslationErrorM(truth, r->registration.T_target_source) < 0.2);
    CHECK(test::RotationErrorDeg(truth, r->registration.T_target_source) < 1.0);
  }
  // Scans stored at 1 m hold no finer detail: the ladder stops as soon as a step gains less than 10 %.
  const PairMergeResult coarse_scans = MergeStreetPair(wants_more, 1.0, &truth);
  MESSAGE("scans at 1 m: " << coarse_scans.alpha_submap_points << " / " << coarse_scans.beta_submap_points
                           << " points at " << coarse_scans.voxel_size_m << " m");
  CHECK(coarse_scans.voxel_size_m >= 0.5 - 1e-9);
  REQUIRE(coarse_scans.registration.success());
}

TEST_CASE("Place check of a confirmed ambiguous pair: a transform is accepted within the tolerances of agreement") {
  MergeServerParams params;
  REQUIRE(params.decision.widen_ambiguous_support > 0.0);
  const double tol_m = params.cascade.consensus.agree_m;
  const double tol_deg = params.cascade.consensus.agree_deg;
  ExchangeCascadeResult c;
  c.ambiguous = true;
  c.consensus_measured = true;
  c.consensus_support_chosen = params.decision.widen_ambiguous_support;
  c.consensus_placement.valid = true;
  c.consensus_placement.yaw_rad = 30.0 * kDegToRad;
  c.consensus_placement.t_alpha_beta_m = Eigen::Vector3d(5.0, 3.0, 0.0);
  c.consensus_placement.place_beta_m = Eigen::Vector3d(-10.0, 3.0, 0.0);
  // The placement as an isometry, and the same turned by theta about the place (which it leaves where it was).
  Eigen::Isometry3d T_p = Eigen::Isometry3d::Identity();
  T_p.linear() = Eigen::AngleAxisd(c.consensus_placement.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_p.translation() = c.consensus_placement.t_alpha_beta_m;
  const auto turned = [&](double theta_deg) {
    Eigen::Isometry3d about = Eigen::Isometry3d::Identity();
    about.translate(c.consensus_placement.place_beta_m);
    about.rotate(Eigen::AngleAxisd(theta_deg * kDegToRad, Eigen::Vector3d::UnitZ()));
    about.translate(-c.consensus_placement.place_beta_m);
    return T_p * about;
  };
  const auto shifted = [&](double d_m) {
    Eigen::Isometry3d T = T_p;
    T.translation() += Eigen::Vector3d(0.6, -0.8, 0.0) * d_m;
    return T;
  };
  // What the registrar measures and asks (PairRegistrar::MergePair): the gap to the placement, then DecideAccept.
  const auto accepted = [](const ExchangeCascadeResult& cascade, const MergeServerParams& p,
                           const Eigen::Isometry3d& T_alpha_beta, PlacementGap* gap = nullptr) {
    PairEvidence e = CascadeEvidence(cascade);
    e.registered = true;
    e.verdict = RegistrationVerdict::kSuccess;
    e.gap_measured = AmbiguousPlaceConfirmed(e, p.decision) && cascade.consensus_placement.valid;
    if (e.gap_measured) e.gap = GapToPlacement(cascade.consensus_placement, T_alpha_beta);
    if (gap != nullptr) *gap = e.gap;
    return DecideAccept(e, p.decision, p.cascade.consensus).yes;
  };
  PlacementGap gap;
  CHECK(accepted(c, params, T_p, &gap));
  CHECK(gap.distance_m < 1e-9);
  CHECK(gap.yaw_deg < 1e-9);
  CHECK(accepted(c, params, shifted(0.95 * tol_m), &gap));
  CHECK(gap.distance_m == doctest::Approx(0.95 * tol_m));
  CHECK_FALSE(accepted(c, params, shifted(1.05 * tol_m), &gap));
  CHECK(gap.distance_m == doctest::Approx(1.05 * tol_m));
  CHECK(accepted(c, params, turned(-0.95 * tol_deg), &gap));
  CHECK(gap.yaw_deg == doctest::Approx(0.95 * tol_deg));
  CHECK(gap.distance_m < 1e-9);
  CHECK_FALSE(accepted(c, params, turned(1.05 * tol_deg), &gap));
  CHECK_FALSE(accepted(c, params, turned(180.0), &gap));
  CHECK(gap.yaw_deg == doctest::Approx(180.0));

  // Every other pair is not checked: the same 180 deg turn passes.
  const Eigen::Isometry3d T_off = turned(180.0);
  ExchangeCascadeResult other = c;
  other.ambiguous = false;
  CHECK(accepted(other, params, T_off, &gap));
  CHECK(gap.yaw_deg == 0.0);
  other = c;
  other.consensus_support_chosen = params.decision.widen_ambiguous_support - 1.0;
  CHECK(accepted(other, params, T_off));
  other = c;
  other.consensus_placement.valid = false;
  CHECK(accepted(other, params, T_off));
  MergeServerParams off = params;
  off.decision.widen_ambiguous_support = 0.0;
  CHECK(accepted(c, off, T_off));
}

TEST_CASE("Merge server refuses a registration at a confirmed ambiguous place that lies away from its placement") {
  // Stage A's cluster of AmbiguousShiftedPairBatches pairs alpha keyframe j + 5 at (j + 5, 0, 0) with beta keyframe
  // j at (-j, 3, 0): its placement turns beta's map 180 deg and moves it by (5, 3, 0).
  SyntheticSubmapPair street;
  REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(41, test::YawOffset(70.0, 12.0, -6.0, 0.3)), &street).ok());
  // The fixture's geometry, independently of the consensus: beta's (-j, 3, 0) lands on alpha's (j + 5, 0, 0).
  Eigen::Isometry3d T_fixture = Eigen::Isometry3d::Identity();
  T_fixture.linear() = Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_fixture.translation() = Eigen::Vector3d(5.0, 3.0, 0.0);
  const auto merge = [&](const Eigen::Isometry3d& T_alpha_beta, double widen_ambiguous_support,
                         Eigen::Isometry3d* T_placement) {
    MergeServerParams params = PaperStageA(200);
    params.cascade.max_ambiguous_fraction = 0.1;
    params.decision.min_ambiguous_support = 0.0;
    params.decision.widen_ambiguous_support = widen_ambiguous_support;
    std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, params);
    MergeServer& server = *server_owner;
    for (const KeyframeBatch& b : AmbiguousShiftedPairBatches()) REQUIRE(server.OnKeyframeBatch(b).ok());
    REQUIRE(server.RunCascades().ok());
    const ExchangeCascadeResult* c = server.cascade(0, 1);
    REQUIRE(c != nullptr);
    REQUIRE(c->ambiguous);
    REQUIRE(c->consensus_placement.valid);
    CHECK(AmbiguousPlaceConfirmed(CascadeEvidence(*c), params.decision) == (widen_ambiguous_support > 0.0));
    T_placement->setIdentity();
    T_placement->linear() = Eigen::AngleAxisd(c->consensus_placement.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T_placement->translation() = c->consensus_placement.t_alpha_beta_m;
    // Alpha's keyframe 10 and beta's keyframe 5 (a loop of the cluster) hold the street pair's scans, placed so
    // that alpha's map = T_alpha_beta beta's map: beta's scan is the source, alpha's the target moved by
    // T_alpha_beta after the pair's own truth undone. Alpha's keyframe moves with its scan (a pose update after
    // the cascade, as a loop closure would send), so registration sees the same scene from the same viewpoints
    // whatever T_alpha_beta is.
    const Eigen::Isometry3d T_map_alpha10 = T_alpha_beta * T_fixture.inverse() * Eigen::Translation3d(10.0, 0.0, 0.0);
    const Eigen::Isometry3d T_map_beta5(Eigen::Translation3d(-5.0, 3.0, 0.0));
    PoseUpdate update;
    update.robot_id = 0;
    update.keyframes = {10};
    update.T_map_sensor = {T_map_alpha10};
    REQUIRE(server.OnPoseUpdate(update).ok());
    const Eigen::Isometry3d T_target = T_map_alpha10.inverse() * T_alpha_beta * street.T_target_source.inverse();
    for (const ScanChunk& ch : ChunksOf(0, 10, EncodeForTest(test::Transformed(street.target.points, T_target)), 1200)) {
      REQUIRE(server.OnScanChunk(ch).ok());
    }
    for (const ScanChunk& ch : ChunksOf(1, 5, EncodeForTest(test::Transformed(street.source.points, T_map_beta5.inverse())), 1200)) {
      REQUIRE(server.OnScanChunk(ch).ok());
    }
    auto merged = server.MergePair(Selection(0, 1, {10}, {5}));
    REQUIRE(merged.ok());
    REQUIRE(merged->attempted);
    return *merged;
  };
  Eigen::Isometry3d T_placement;
  const PairMergeResult at_place = merge(T_fixture, 1.0, &T_placement);
  CHECK(test::TranslationErrorM(T_fixture, T_placement) < 0.5);
  CHECK(test::RotationErrorDeg(T_fixture, T_placement) < 2.0);
  REQUIRE(at_place.merged());
  CHECK(test::TranslationErrorM(T_fixture, at_place.registration.T_target_source) < 0.2);

  // The same scans with alpha's turned 180 deg about the place: registration's gates pass, the place check does not.
  Eigen::Isometry3d about = Eigen::Isometry3d::Identity();
  about.translate(Eigen::Vector3d(-12.0, 3.0, 0.0));
  about.rotate(Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitZ()));
  about.translate(Eigen::Vector3d(12.0, -3.0, 0.0));
  const Eigen::Isometry3d T_turned = T_fixture * about;
  const PairMergeResult off_place = merge(T_turned, 1.0, &T_placement);
  CHECK(off_place.stop == PairStop::kOffConfirmedPlace);
  CHECK(off_place.registration.success());  // the gates passed: the decision refused it
  CHECK_FALSE(off_place.merged());
  CHECK(off_place.reason.find("off the confirmed place") == 0);
  CHECK(test::TranslationErrorM(T_turned, off_place.registration.T_target_source) < 0.2);
  CHECK(test::RotationErrorDeg(T_turned, off_place.registration.T_target_source) < 1.0);
  // Without the widening of confirmed ambiguous places there is no such check: the turned transform merges.
  const PairMergeResult unchecked = merge(T_turned, 0.0, &T_placement);
  REQUIRE(unchecked.merged());
  CHECK(test::TranslationErrorM(T_turned, unchecked.registration.T_target_source) < 0.2);
}

namespace {

// Two robots on one road: alpha's keyframe i at (i, 0, 0); beta's keyframe j where T_alpha_beta places it on
// alpha's (j + 10, 0.5, 0). Beta's first 30 keyframes carry alpha's descriptors (stage A's cluster: beta 0..29
// with alpha 10..39); the next 30 either look like alpha's at the same place (a second stretch of the road,
// descriptors near but above tau_inter, so outside the cluster) or like nothing alpha saw. Alpha's keyframe 15
// and beta's keyframe 5 hold the street pair's scans, placed so that registration finds T_alpha_beta.
PairMergeResult MergeRoadPair(bool rest_agrees, const MergeServerParams& params, const Eigen::Isometry3d& T_alpha_beta) {
  SyntheticSubmapPair street;
  REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(41, test::YawOffset(70.0, 12.0, -6.0, 0.3)), &street).ok());
  std::mt19937 rng(11);
  std::vector<std::array<float, kKeyframeDescriptorDim>> da, db;
  std::vector<Eigen::Vector3d> pa, pb;
  for (int i = 0; i < 60; ++i) {
    da.push_back(RandomDescriptor(&rng));
    pa.emplace_back(i, 0.0, 0.0);
  }
  for (int j = 0; j < 60; ++j) {
    std::array<float, kKeyframeDescriptorDim> d = RandomDescriptor(&rng);
    if (j < 30) {
      d = da[static_cast<std::size_t>(j + 10)];
    } else if (rest_agrees && j + 10 < 60) {
      double n = 0.0;
      for (std::size_t k = 0; k < d.size(); ++k) {
        d[k] = 0.6f * da[static_cast<std::size_t>(j + 10)][k] + 0.4f * d[k];
        n += static_cast<double>(d[k]) * static_cast<double>(d[k]);
      }
      for (float& v : d) v = static_cast<float>(static_cast<double>(v) / std::sqrt(n));
    }
    db.push_back(d);
    pb.push_back(T_alpha_beta.inverse() * Eigen::Vector3d(j + 10.0, 0.5, 0.0));
  }
  auto server = commerge::test::MakeTestServer(2, 100, params);
  REQUIRE(server->OnKeyframeBatch(MakeBatch(0, 0, da, pa, 3000)).ok());
  REQUIRE(server->OnKeyframeBatch(MakeBatch(1, 0, db, pb, 3000)).ok());
  REQUIRE(server->RunCascades().ok());
  const ExchangeCascadeResult* c = server->cascade(0, 1);
  REQUIRE(c != nullptr);
  REQUIRE(c->stage_a.found);
  CHECK(c->stage_a.best.col_min == 0);
  CHECK(c->stage_a.best.col_max == 29);
  // Beta's keyframe 5 sees the street's source scan from where T_alpha_beta puts it relative to alpha's keyframe 15
  // (street.T_target_source apart), so the two submaps meet exactly under T_alpha_beta.
  const Eigen::Isometry3d T_map_alpha15(Eigen::Translation3d(15.0, 0.0, 0.0));
  PoseUpdate update;
  update.robot_id = 1;
  update.keyframes = {5};
  update.T_map_sensor = {T_alpha_beta.inverse() * T_map_alpha15 * street.T_target_source};
  REQUIRE(server->OnPoseUpdate(update).ok());
  for (const ScanChunk& ch : ChunksOf(0, 15, EncodeForTest(street.target.points), 1200)) REQUIRE(server->OnScanChunk(ch).ok());
  for (const ScanChunk& ch : ChunksOf(1, 5, EncodeForTest(street.source.points), 1200)) REQUIRE(server->OnScanChunk(ch).ok());
  auto merged = server->MergePair(Selection(0, 1, {15}, {5}));
  REQUIRE_MESSAGE(merged.ok(), merged.status().ToString());
  REQUIRE(merged->attempted);
  return *merged;
}

}  // namespace

TEST_CASE("Merge server refuses a registration where the keyframes it places together have unlike descriptors") {
  const Eigen::Isometry3d T_alpha_beta = test::YawOffset(30.0, 5.0, 2.0, 0.0);
  MergeServerParams params = PaperStageA(100);
  params.decision.max_colocated_chance = 0.3;
  REQUIRE(ValidateMergeServerParams(params).ok());

  // The rest of beta's road looks like alpha's at the same place: merged, and the keyframes the transform puts
  // together outside the cluster (beta 30..51, 0.5 m aside of alpha's road, within 3 m of alpha's 38..59) are
  // each other's nearest.
  const PairMergeResult agrees = MergeRoadPair(true, params, T_alpha_beta);
  REQUIRE(agrees.registration.success());
  CHECK(test::TranslationErrorM(T_alpha_beta, agrees.registration.T_target_source) < 0.2);
  CHECK(agrees.colocated_keyframes == 22);
  CHECK(agrees.colocated_chance == doctest::Approx(0.0));

  // The rest looks like nothing alpha saw there: the same registration is refused, its transform kept.
  const PairMergeResult strangers = MergeRoadPair(false, params, T_alpha_beta);
  CHECK(strangers.stop == PairStop::kDescriptorsDisagree);
  CHECK(strangers.registration.success());  // the gates passed: the decision refused it
  CHECK_FALSE(strangers.merged());
  CHECK(strangers.reason.find("descriptors disagree") == 0);
  CHECK(test::TranslationErrorM(T_alpha_beta, strangers.registration.T_target_source) < 0.2);
  CHECK(strangers.colocated_keyframes == 22);
  CHECK(strangers.colocated_chance > 0.3);
  CHECK(strangers.colocated_chance < 0.9);

  // Too few keyframes placed together to judge, or the check off: merged, the measure still reported.
  MergeServerParams few = params;
  few.decision.min_colocated_keyframes = 23;
  CHECK(MergeRoadPair(false, few, T_alpha_beta).registration.success());
  MergeServerParams off = params;
  off.decision.max_colocated_chance = 0.0;
  const PairMergeResult unchecked = MergeRoadPair(false, off, T_alpha_beta);
  REQUIRE(unchecked.merged());
  CHECK(unchecked.colocated_chance == doctest::Approx(strangers.colocated_chance));

  MergeServerParams bad = params;
  for (double v : {-0.1, 1.5, std::numeric_limits<double>::quiet_NaN()}) {
    bad.decision.max_colocated_chance = v;
    CHECK_FALSE(ValidateMergeServerParams(bad).ok());
  }
  bad = params;
  bad.colocation.near_m = 0.0;
  CHECK_FALSE(ValidateMergeServerParams(bad).ok());
}

TEST_CASE("Pair registrar: BuildSubmap places the received scans by their poses and counts the others as missing") {
  const MergeServerParams params;
  auto db = KeyframeDatabase::Create(2, 10, KeyframeRecordKind::kUnit40);
  REQUIRE(db.ok());
  auto inbox = ScanInbox::Create(2, ScanInboxLimits{});
  REQUIRE(inbox.ok());
  MergeServerStats stats;
  std::mt19937 rng(17);
  // Robot 0's keyframes 0, 1, 2 at x = 0, 50, 100 m; scans of keyframes 0 and 2 only. Robot 1 sent a scan of
  // keyframe 0 but no keyframe.
  const std::vector<std::array<float, kKeyframeDescriptorDim>> d = {RandomDescriptor(&rng), RandomDescriptor(&rng),
                                                                    RandomDescriptor(&rng)};
  const std::vector<Eigen::Vector3d> at = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(50, 0, 0),
                                           Eigen::Vector3d(100, 0, 0)};
  REQUIRE(db->OnKeyframeBatch(MakeBatch(0, 0, d, at, 20), &stats).ok());
  // 20 points: x = 0, 0.5, .., 9.5 (all apart), y = i mod 11, z = i mod 5, whole centimetres (stored exactly).
  std::vector<PointXYZI> lattice;
  for (int i = 0; i < 20; ++i) {
    lattice.push_back({0.5f * static_cast<float>(i), static_cast<float>(i % 11), static_cast<float>(i % 5), 0.0f});
  }
  using Scan = std::pair<int, std::uint32_t>;  // robot, keyframe
  for (const auto& [robot, keyframe] : {Scan{0, 0}, Scan{0, 2}, Scan{1, 0}}) {
    for (const ScanChunk& c : ChunksOf(robot, keyframe, EncodeForTest(lattice))) {
      REQUIRE(inbox->OnScanChunk(c, &stats, [] {}).ok());
    }
  }
  PairRegistrar registrar(params);
  int noted = 0;
  const auto note = [&noted] { ++noted; };
  std::vector<PointXYZI> points;
  std::vector<Eigen::Vector3d> origins;
  std::size_t missing = 99;
  const std::vector<std::uint32_t> wanted = {0, 1, 2, 7};  // 1: no scan; 7: no such keyframe
  const std::size_t used = registrar.BuildSubmap(*db, *inbox, 0, Span<const std::uint32_t>(wanted), 0.25, &points,
                                                 &origins, &missing, note);
  CHECK(used == 2);
  CHECK(missing == 2);
  CHECK(noted == 1);
  REQUIRE(origins.size() == 2);
  CHECK(origins[0].norm() < 0.01);
  CHECK((origins[1] - Eigen::Vector3d(100, 0, 0)).norm() < 0.01);
  // 0.25 m voxels hold one point each: the 20 points of each scan, moved by its keyframe's x.
  REQUIRE(points.size() == 40);
  std::vector<double> xs;
  for (const PointXYZI& p : points) xs.push_back(static_cast<double>(p.x));
  std::sort(xs.begin(), xs.end());
  for (int i = 0; i < 20; ++i) {
    CHECK(std::fabs(xs[static_cast<std::size_t>(i)] - 0.5 * i) < 1e-3);
    CHECK(std::fabs(xs[static_cast<std::size_t>(20 + i)] - (100.0 + 0.5 * i)) < 1e-3);
  }

  // Robot 1 has no keyframe 0: its scan is not used.
  const std::vector<std::uint32_t> first = {0};
  CHECK(registrar.BuildSubmap(*db, *inbox, 1, Span<const std::uint32_t>(first), 0.25, &points, &origins, &missing,
                              note) == 0);
  CHECK(missing == 1);
  CHECK(points.empty());
  CHECK(origins.empty());
  CHECK(noted == 2);

  // Frames from no accepted pair: robot 0 is the world, robot 1 apart; a refused pair does not join them.
  PairMergeResult refused;
  refused.alpha = 0;
  refused.beta = 1;
  refused.attempted = true;
  refused.stop = PairStop::kRegistration;
  auto frames = registrar.SolveFrames(2, Span<const PairMergeResult>(&refused, 1));
  REQUIRE(frames.ok());
  REQUIRE(frames->robots.size() == 2);
  CHECK(frames->robots[0].connected_to_robot0);
  CHECK_FALSE(frames->robots[1].connected_to_robot0);
  CHECK(frames->measurements.empty());
}
