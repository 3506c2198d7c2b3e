// SPDX-License-Identifier: BSD-3-Clause
// commerge: the server's exchange planner (budget modules "affinity" and "solvers"): the cascade of every robot
// pair (affinity + stage A, stage B per pair or joint, stage C, policy), the place check across pairs, and the plans
// that turn selections into scan requests (per exchange mode, widened after a refusal). Pure over the keyframe
// database and the scan inbox; what a pair's evidence allows is DecideRequest's and DecideWiden's
// (pair_decision.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/agent/keyframe_database.hpp"
#include "core/agent/merge_server_params.hpp"
#include "core/agent/pair_decision.hpp"
#include "core/agent/scan_inbox.hpp"
#include "core/exchange/transform_agreement.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/exchange/exchange_cascade.hpp"

namespace commerge {

/// Scans one pair asks for in one mode.
struct PairSelection {
  int alpha = 0, beta = 0;
  std::vector<std::uint32_t> alpha_keyframes, beta_keyframes;  ///< ascending
  std::size_t loops = 0;           ///< loops behind the selection (|L_seq|, |L_K|, ...)
  /// Why it is empty: the stop (kNone when it is not) and its words (the cascade's reason).
  PairStop stop = PairStop::kNone;
  std::string no_selection_reason;
};

struct ExchangePlan {
  ExchangeMode mode = ExchangeMode::kStageABC;
  std::vector<PairSelection> pairs;
  /// One request per robot with something to send (the union over its pairs), request ids from 1 upwards.
  std::vector<ScanRequest> requests;
  std::uint64_t predicted_scan_bytes = 0;  ///< 12 + 6 n per requested scan, n as the robots reported
  /// Scans of `requests` by origin (Plan; 0 in a WidenPlan): the mode's own selection (send-all: every stored
  /// scan; A: L_seq's endpoints; A+B: the cover; A+C: the clique's endpoints; A+B+C: L_K's endpoints), and the
  /// keyframes padding added on top (ExchangePolicyParams::min_scans_per_robot, the same rule in every mode).
  std::size_t selected_scans = 0;
  std::size_t padded_scans = 0;
};

/// Replaces the selection of every pair in `pairs` that `adopted` has (matched by robot pair) with that one.
void AdoptSelections(Span<const PairSelection> adopted, std::vector<PairSelection>* pairs);

/// One pair's registration outcome as the planner needs it to widen: registered and refused, or merged.
struct PairOutcome {
  int alpha = 0, beta = 0;
  bool attempted = false;  ///< registration ran
  bool merged = false;     ///< and the transform was accepted
};

class ExchangePlanner {
 public:
  /// Parameters as MergeServer holds them (checked by ValidateMergeServerParams).
  explicit ExchangePlanner(const MergeServerParams& params) : params_(params) {}

  /// Runs the cascade for every pair of robots that sent keyframes (alpha < beta), asks DecideRequest after stage A
  /// (stage B runs only for pairs it passes) and after the place check. Results stay until the next call.
  Status RunCascades(const KeyframeDatabase& db);
  /// Forgets the pairs of one robot.
  void ForgetRobot(int robot);

  /// Pairs the last RunCascades() left out because their robots' descriptor ids differ.
  const std::vector<std::pair<int, int>>& incomparable_pairs() const noexcept { return incomparable_pairs_; }
  /// Cascade of pair (alpha, beta) from the last RunCascades(); nullptr when it did not run.
  const ExchangeCascadeResult* cascade(int alpha, int beta) const;
  /// The pair's evidence before registration (cascade and chains); nullptr when its cascade did not run.
  const PairEvidence* evidence(int alpha, int beta) const;
  /// The descriptor agreement at each placed cluster of the pair's last cascade (ExchangeCascadeResult::
  /// placed_clusters, in its order; transform_agreement.hpp), measured when asked: a round measures only the
  /// passed-on cluster's (PairEvidence::placement_agreement) and should not pay 16 x 256 rankings against every
  /// keyframe of alpha per pair for the rest. Errors: the pair's
  /// cascade did not run, MeasurePlacementAgreement's.
  Result<std::vector<PlacementAgreement>> MeasurePlacementAgreement(const KeyframeDatabase& db, int alpha,
                                                                    int beta) const;
  /// Stage C over all of L_seq (the A+C ablation) of the pair; nullptr when it did not run.
  const StageCResult* stage_ac(int alpha, int beta) const;

  /// The plan of one mode from the last RunCascades(). A pair DecideRequest refused for its place (ambiguous and
  /// unconfirmed, descriptors that disagree at the placement, or the place check) selects nothing in any mode but
  /// send-all.
  Result<ExchangePlan> Plan(ExchangeMode mode, const KeyframeDatabase& db) const;
  /// The next exchange for the pairs of `plan` whose registration was refused and DecideWiden allows: each robot's
  /// keyframes grow to twice their number with endpoints of the pair's L_seq nearest in index to those selected.
  /// Left out as well: a pair where neither robot can grow. Requests name only scans `inbox` does not hold, ids
  /// from `first_request_id`. An empty plan: nothing to widen.
  Result<ExchangePlan> WidenPlan(const ExchangePlan& plan, Span<const PairOutcome> outcomes,
                                 std::int32_t first_request_id, const KeyframeDatabase& db,
                                 const ScanInbox& inbox) const;
  /// The requests for registering `selections`: per robot the union of its keyframes whose scans `inbox` does not
  /// hold (ExchangePlan::requests and predicted_scan_bytes; its pairs are empty).
  ExchangePlan RequestsFor(Span<const PairSelection> selections, std::int32_t first_request_id,
                           const KeyframeDatabase& db, const ScanInbox& inbox) const;

  /// Bytes of the cascade inputs built here and each pair's L_seq and placed clusters (module "affinity"), and
  /// of each pair's stage B, C and policy results and the A+C run (module "solvers").
  std::size_t AffinityBytes() const;
  std::size_t SolverBytes() const;

 private:
  struct PairState {
    int alpha = 0, beta = 0;
    ExchangeCascadeResult cascade;
    PairEvidence evidence;
    PairStop stop = PairStop::kNone;  ///< DecideRequest's
    StageCResult stage_ac;
    bool stage_ac_ran = false;
  };
  const PairState* FindPair(int alpha, int beta) const;
  CascadeRobotInput Input(const KeyframeDatabase& db, int robot) const;
  // Stage A, DecideRequest, and (pairwise) stage B to the policy; the A+C ablation.
  Status RunPair(const KeyframeDatabase& db, int a, int b);
  Status RunJointStageB(const KeyframeDatabase& db);
  // The descriptor agreement at placed cluster c of pair (alpha, beta).
  Result<PlacementAgreement> AgreementAt(const KeyframeDatabase& db, int alpha, int beta, const PlacedCluster& c) const;
  // The descriptor agreement at the placement of the cluster the cascade passed on, into state->evidence.
  Status MeasurePassedOnPlacement(const KeyframeDatabase& db, PairState* state) const;
  // The evidence from the cascade again (after stage B; the placement agreement kept), and DecideRequest.
  void RefreshEvidence(PairState* state) const;
  // The place check across pairs (decision.chain_check_support) over pairs_, then DecideRequest once more.
  void ApplyPlaceCheck(int max_robots);
  // One request per robot with the keyframes of `wanted[r]` (sorted and de-duplicated here; without the scans
  // `inbox` holds when given), ids from `request_id` upwards; adds their predicted bytes to the plan.
  void AddRequests(std::vector<std::vector<std::uint32_t>>* wanted, std::int32_t request_id,
                   const KeyframeDatabase& db, const ScanInbox* inbox, ExchangePlan* plan) const;

  MergeServerParams params_;
  std::vector<PairState> pairs_;
  std::vector<std::pair<int, int>> incomparable_pairs_;
  std::vector<std::vector<Eigen::Vector3d>> positions_;  ///< per robot, the cascade's keyframe positions
};

}  // namespace commerge
