// SPDX-License-Identifier: BSD-3-Clause
// commerge: the server's merge round, transport-free (paper Fig. "main", (d)-(g)), in one place:
//   1. the exchange cascade for every robot pair (MergeServer::RunCascades: affinity + stage A, B, C, policy);
//   2. the plan of one exchange mode (MergeServer::Plan: the paper's ablation modes, send-all .. A+B+C), and per
//      pair what this round asks of it (ours, pair_exchange.hpp: a pair answered by earlier rounds keeps its
//      result and costs no scans unless its robots' poses in the verified overlap moved, a new overlap could
//      check a bridge, a verification failed or a robot restarted; pairs with an unplaced robot are always
//      registered); the scan requests for the registered pairs' keyframes whose scans the server does not hold;
//   3. registration of those pairs from the scans that arrived (MergeServer::MergePair: submaps, coarse, fine);
//   4. widening (ours, MergeServer::WidenPlan): a pair that registration refused asks for more of stage A's scans
//      and is registered again, at most MergeServerParams::max_widen_steps times;
//   4b. the final refinement (ours, pair_refinement.hpp; MergeServerParams::refine): each pair accepted this round
//      asks for a few scans spread along the path its robots share and refines its transform on them;
//   5. the pair histories: what each pair's registrations verified, where it was tried, for the robot sessions
//      (a pair registered with selected scans missing and refused keeps the registration verified before);
//   6. the frame solver (MergeServer::SolveFrames): one T_world_map per robot, inconsistent pairs rejected (a
//      rejected verified registration is dropped at the next round).
// `commerge run` (direct calls, every message LCM-encoded and counted) and `commerge server` (LCM, through
// ServerLink) both drive this round and differ only in how requests and scans travel:
//
//   MergeRound round(&server, params);
//   std::vector<ScanRequest> requests;
//   round.Begin(sessions, &requests);          // steps 1-2
//   do deliver(requests);                      // the driver's business: memq, LCM, retransmission, timeouts
//   while (!*round.Continue(&requests));       // steps 3-6; widening and refinement may ask for more scans
//   round.result();                            // selections, decisions, registrations, frames
//
// The object lives across rounds (the pair histories, the request ids); Begin starts the next round. Its first
// round registers every pair (no robot is placed yet): a comparison of modes (`commerge run`) uses one object per
// mode.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/agent/merge_server.hpp"
#include "core/agent/messages.hpp"
#include "core/agent/pair_exchange.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/merge/frame_solver.hpp"

namespace commerge {

struct MergeRoundParams {
  ExchangeMode mode = ExchangeMode::kStageABC;
  /// Step 1 runs the cascades. false: plan from the cascades the server ran last (a comparison of exchange modes
  /// on the same data runs them once, then one round per mode).
  bool run_cascades = true;
  /// What a round asks of pairs earlier rounds answered (pair_exchange.hpp); not in mode send-all, the baseline
  /// that ships every stored scan every round.
  PairExchangeParams exchange;
};

/// Called after every registration of a pair (also a widened retry), e.g. for progress lines.
class MergeRoundObserver {
 public:
  virtual ~MergeRoundObserver() = default;
  virtual void OnPairRegistered(const PairMergeResult& result) = 0;
};

/// What a finished round produced.
struct MergeRoundResult {
  int round = 0;  ///< 1, 2, ... per MergeRound object
  /// pairs: every pair's final selection (widened ones replaced); requests: every request the round made, in
  /// order (the plan's, then each widening step's), only keyframes whose scans the server did not hold;
  /// predicted_scan_bytes: of those requests.
  ExchangePlan plan;
  /// Per plan pair, in plan.pairs order: what the round asked of it (its reason, the scans requested for it).
  std::vector<PairExchangeDecision> decisions;
  /// Per pair, in plan.pairs order, its result: this round's last registration, or the verified one it keeps
  /// (kept_from_round > 0), or why it was not attempted; a pair with a second verified region has two entries,
  /// next to each other (the frame solver gets both). How often each was widened, and the seconds its
  /// registrations took (steady clock, every attempt).
  std::vector<PairMergeResult> pairs;
  std::vector<int> widenings;
  std::vector<double> registration_s;
  /// Pairs registered this round, pairs that kept a verified result.
  std::size_t pairs_registered = 0, pairs_kept = 0;
  /// Scans the widening steps asked for (not held yet); plan.selected_scans and plan.padded_scans count the
  /// plan's own by origin. On a server that held no scan before the round (each mode of `commerge run`), the three
  /// add up to the scans the round requested.
  std::size_t widened_scans = 0;
  /// Scans the final refinement asked for (not held yet); on such a server the four add up.
  std::size_t refined_scans = 0;
  bool frames_ok = false;
  FrameSolution frames;       ///< when frames_ok
  std::string frames_error;   ///< when !frames_ok
  /// Robot r is in the world frame (robot 0's map frame); robot 0 always is when frames_ok.
  bool in_world(int robot) const;
  /// T_world_map of robot r (identity when not in the world frame).
  Eigen::Isometry3d T_world_map(int robot) const;
};

class MergeRound {
 public:
  /// `server` is not owned and must outlive the round.
  MergeRound(MergeServer* server, const MergeRoundParams& params);

  /// Starts the next round: the cascades (unless params.run_cascades is false) and the plan of params.mode.
  /// *requests: the scans to ask for (per robot, only keyframes not held; empty when every scan is held).
  /// `sessions[r]`: robot r's current session (any non-zero value per robot where sessions do not change).
  Status Begin(Span<const std::int64_t> sessions, std::vector<ScanRequest>* requests);

  /// The scans of the last requests arrived, or the driver stopped waiting for them. Registers the pairs that
  /// waited for them; then, while a refused pair can be widened, plans the widening; then the final refinement of
  /// the pairs accepted this round (step 4b). Returns false with the new *requests when scans must be delivered
  /// first (call Continue again afterwards), and goes on at once when every scan asked for is held. Returns true
  /// when the round is finished (result()).
  /// Errors: Continue without Begin, bad parameters (the round is then abandoned).
  Result<bool> Continue(std::vector<ScanRequest>* requests);

  bool active() const noexcept { return active_; }
  int rounds_finished() const noexcept { return rounds_finished_; }
  /// Pair selections widened so far, over every round of this object.
  std::uint64_t widened_selections() const noexcept { return widened_selections_; }
  /// The last finished round (round 0 = none yet).
  const MergeRoundResult& result() const noexcept { return result_; }
  /// What the rounds know of each pair (for the robots' current sessions).
  const std::vector<PairHistory>& histories() const noexcept { return histories_; }
  /// The history of pair (alpha, beta), alpha < beta; nullptr when there is none.
  const PairHistory* history(int alpha, int beta) const;

  void set_observer(MergeRoundObserver* observer) noexcept { observer_ = observer; }

 private:
  /// One registration of the round: a selection and the slot of current_.pairs it fills.
  struct Job {
    PairSelection selection;
    std::size_t slot = 0;
    std::size_t decision = 0;  ///< index into current_.decisions
    /// A verified region registered again at moved poses was refused with every scan present (not for missing
    /// scans): those poses are judged.
    bool refused_with_scans = false;
    /// A refinement job (step 4b): the keyframes added to the selection for it.
    std::size_t spread_alpha = 0, spread_beta = 0;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> places;  ///< its spread places (SpreadKeyframes::places)
  };
  /// Step 4b: the refinement jobs of the pairs accepted this round (their selections plus the spread keyframes).
  std::vector<Job> RefineJobs() const;
  /// Refines each job's pair from the scans that arrived.
  Status Refine(const std::vector<Job>& jobs);
  /// Step 2 for one plan pair: its decision; then (AddPair) its slot(s) in current_.pairs and its job when it is
  /// registered.
  PairExchangeDecision DecidePair(const PairSelection& plan_pair) const;
  void AddPair(const PairSelection& plan_pair, std::size_t decision, std::vector<Job>* jobs);
  /// Registers `jobs` into their slots (a slot filled before in this round counts as widened); a verified region
  /// re-registered at moved poses and refused keeps its earlier result.
  Status Register(std::vector<Job>* jobs);
  /// Step 5 for one job, once its result is final.
  void RecordJob(const Job& job);
  /// Per-pair history bookkeeping at Begin: sessions (a restart voids it), verified registrations the last
  /// round's frame solver rejected.
  void RefreshHistories();
  PairHistory* MutableHistory(int alpha, int beta);
  RobotPoses PosesOf(int robot) const;
  /// Counts each job's requested keyframes into its decision (a scan two jobs share counts for the first).
  void AttributeRequests(const std::vector<Job>& jobs, const std::vector<ScanRequest>& requests, bool widened);
  /// Moves `planned` into *requests and the round's plan, without the scans held, with fresh request ids.
  void Request(const std::vector<ScanRequest>& planned, std::uint64_t predicted_bytes,
               std::vector<ScanRequest>* requests);
  Status Finish();

  MergeServer* server_;
  MergeRoundParams params_;
  bool active_ = false;
  int rounds_finished_ = 0;
  int widen_step_ = 0;
  std::uint64_t widened_selections_ = 0;
  std::int32_t next_request_id_ = 1;
  std::vector<std::int64_t> sessions_;
  MergeRoundResult current_;                   ///< the round in progress
  std::vector<Job> jobs_;                      ///< every registration of the round in progress (widened ones updated)
  std::vector<Job> pending_;                   ///< to register when the requested scans arrived
  bool refining_ = false;                      ///< pending_ are refinement jobs (step 4b)
  /// Per entry of current_.pairs: the verified region of its pair it is or becomes (-1: none).
  std::vector<int> entry_region_;
  MergeRoundResult result_;
  std::vector<PairHistory> histories_;
  MergeRoundObserver* observer_ = nullptr;
};

/// The merge_result_t of a finished round: robots `robot_ids` (ascending) with their placement and
/// keyframes[i] (robot_ids[i]'s keyframes when the round started), and every pair's outcome (stage A/C loop
/// counts from `server`'s cascades).
MergeResultMessage MakeMergeResultMessage(const MergeRoundResult& round, const MergeServer& server,
                                          Span<const int> robot_ids, Span<const std::uint32_t> keyframes,
                                          std::int64_t server_session, std::int64_t utime_us);

}  // namespace commerge
