// SPDX-License-Identifier: BSD-3-Clause
// commerge: the server's merge round, transport-free (paper Fig. "main", (d)-(g)), in one place:
//   1. the exchange cascade for every robot pair (MergeServer::RunCascades: affinity + stage A, B, C, policy);
//   2. the plan of one exchange mode (MergeServer::Plan: the paper's ablation modes, send-all .. A+B+C) and the
//      scan requests for the keyframes whose scans the server does not hold yet;
//   3. registration of every pair from the scans that arrived (MergeServer::MergePair: submaps, coarse, fine);
//   4. widening (ours, MergeServer::WidenPlan): a pair that registration refused asks for more of stage A's scans
//      and is registered again, at most MergeServerParams::max_widen_steps times;
//   5. verified pairs (ours, KeepVerifiedPairs): a pair this round could not judge for missing scans keeps the
//      registration an earlier round verified for the same robot sessions;
//   6. the frame solver (MergeServer::SolveFrames): one T_world_map per robot, inconsistent pairs rejected.
// `commerge run` (direct calls, every message LCM-encoded and counted) and `commerge server` (LCM, through
// ServerLink) both drive this round and differ only in how requests and scans travel:
//
//   MergeRound round(&server, params);
//   std::vector<ScanRequest> requests;
//   round.Begin(sessions, &requests);          // steps 1-2
//   do deliver(requests);                      // the driver's business: memq, LCM, retransmission, timeouts
//   while (!*round.Continue(&requests));       // steps 3-6; widening may ask for more scans
//   round.result();                            // selections, registrations, frames
//
// The object lives across rounds (the verified pairs of step 5, the request ids); Begin starts the next round.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/agent/merge_server.hpp"
#include "core/agent/messages.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/merge/frame_solver.hpp"

namespace commerge {

/// A pair registration a round verified, with the robot sessions it holds for.
struct VerifiedPair {
  PairMergeResult result;
  int round = 0;
  std::int64_t alpha_session = 0, beta_session = 0;
};

/// Keeps what earlier rounds verified when a later round lacks the data to judge. For each of this round's
/// `results` (round number `round`; sessions[r] = robot r's current session): a success is recorded in *verified
/// (replacing that pair's earlier one). A pair this round did not register, with selected scans missing
/// (alpha_missing or beta_missing > 0: a robot left, or its scans did not arrive before the driver stopped
/// waiting), gets back the result *verified holds for the same two sessions, marked kept_from_round, its reason
/// naming this round's cause. The frame between two robot maps does not change when they grow, so a verified
/// transform stays valid; a restarted robot (new session, new map frame) invalidates it. A pair registered with
/// every selected scan and refused, or with nothing selected, is left as it is.
void KeepVerifiedPairs(int round, Span<const std::int64_t> sessions, std::vector<VerifiedPair>* verified,
                       std::vector<PairMergeResult>* results);

struct MergeRoundParams {
  ExchangeMode mode = ExchangeMode::kStageABC;
  /// Step 1 runs the cascades. false: plan from the cascades the server ran last (a comparison of exchange modes
  /// on the same data runs them once, then one round per mode).
  bool run_cascades = true;
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
  /// Per pair, in plan.pairs order: the last registration (after KeepVerifiedPairs), how often its selection was
  /// widened, and the seconds its registrations took (steady clock, every attempt).
  std::vector<PairMergeResult> pairs;
  std::vector<int> widenings;
  std::vector<double> registration_s;
  /// Scans the widening steps asked for (not held yet); plan.selected_scans and plan.padded_scans count the
  /// plan's own by origin. On a server that held no scan before the round (each mode of `commerge run`), the three
  /// add up to the scans the round requested.
  std::size_t widened_scans = 0;
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
  /// waited for them; then, while a refused pair can be widened, plans the widening: returns false with the new
  /// *requests when scans must be delivered first (call Continue again afterwards), and registers at once when
  /// every widened scan is held. Returns true when the round is finished (result()).
  /// Errors: Continue without Begin, bad parameters (the round is then abandoned).
  Result<bool> Continue(std::vector<ScanRequest>* requests);

  bool active() const noexcept { return active_; }
  int rounds_finished() const noexcept { return rounds_finished_; }
  /// Pair selections widened so far, over every round of this object.
  std::uint64_t widened_selections() const noexcept { return widened_selections_; }
  /// The last finished round (round 0 = none yet).
  const MergeRoundResult& result() const noexcept { return result_; }
  const std::vector<VerifiedPair>& verified_pairs() const noexcept { return verified_; }
  /// Forgets what the rounds verified (e.g. before a comparison run reuses the object).
  void ClearVerified() { verified_.clear(); }

  void set_observer(MergeRoundObserver* observer) noexcept { observer_ = observer; }

 private:
  /// Registers `selections`; a pair registered before in this round is replaced (and counted as widened).
  Status Register(const std::vector<PairSelection>& selections);
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
  std::vector<PairSelection> pending_;         ///< to register when the requested scans arrived
  MergeRoundResult result_;
  std::vector<VerifiedPair> verified_;
  MergeRoundObserver* observer_ = nullptr;
};

/// The merge_result_t of a finished round: robots `robot_ids` (ascending) with their placement and
/// keyframes[i] (robot_ids[i]'s keyframes when the round started), and every pair's outcome (stage A/C loop
/// counts from `server`'s cascades).
MergeResultMessage MakeMergeResultMessage(const MergeRoundResult& round, const MergeServer& server,
                                          Span<const int> robot_ids, Span<const std::uint32_t> keyframes,
                                          std::int64_t server_session, std::int64_t utime_us);

}  // namespace commerge
