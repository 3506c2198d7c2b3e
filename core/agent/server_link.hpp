// SPDX-License-Identifier: BSD-3-Clause
// commerge: the server's side of reliable delivery and its merge rounds, on a MergeServer. Transport-free: the
// caller decodes messages into the On...() handlers, calls Poll() regularly, and encodes and publishes what it
// returns.
//   * Sessions: each robot process has a session id; a newer session of a robot id replaces that robot's
//     keyframes and scans (the robot restarted), an older one is stale and refused (counted).
//   * Every status_interval_s each robot with a session gets a TransferStatus: which keyframes the server holds
//     (contiguous prefix + gaps), the pose-update sequences it received, and for the robot's active scan request
//     the chunks it still misses. The robot re-announces and retransmits from it (RobotLink). A Poll that did
//     round work sends none (the robots' messages of those seconds still wait in the caller's queue); the next
//     Poll sends the due ones before it may do round work, so rounds longer than their interval cannot starve
//     the robots of statuses.
//   * Rounds: when enough keyframes arrived (or the robots went quiet with new data), the server begins a
//     MergeRound (core/agent/merge_round.hpp: cascade, plan, registration, widening, frames) and sends each robot
//     the round's scan request (its exchange policy, repeated every policy_repeat_s until the scans are complete).
//     When every request is complete, or after request_timeout_s, the round continues; when widening asks for
//     more scans, they are requested and waited for the same way (a fresh request_timeout_s). A finished round
//     is emitted as a MergeResultMessage.
//   * Chunks must belong to the robot's active request; others (stale retransmissions, a previous server's
//     requests) are refused and counted.
//   * Every step of a round (its beginning, and each continuation) is also emitted as a RoundStep record: the
//     messages taken from each robot so far and the requests sent, so a recording replays exactly
//     (core/agent/round_replay.hpp, FollowStep).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <initializer_list>
#include <string>
#include <vector>

#include "core/agent/merge_round.hpp"
#include "core/agent/merge_server.hpp"
#include "core/agent/messages.hpp"
#include "core/agent/round_replay.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

struct ServerLinkParams {
  ExchangeMode mode = ExchangeMode::kStageABC;
  double status_interval_s = 0.5;
  double policy_repeat_s = 1.0;
  /// Rounds start at most this often [s] ...
  double round_interval_s = 10.0;
  /// ... when this many keyframes were delivered since the last round,
  std::size_t round_min_new_keyframes = 200;
  /// ... or when some were and no robot message arrived for this long [s] (the robots finished or paused).
  double round_quiet_s = 3.0;
  /// A round merges with the scans that arrived when its requests are still incomplete after this [s].
  double request_timeout_s = 60.0;
  /// Replay of a recorded mission (`commerge server --replay`): accept the chunks of any keyframe of a robot's
  /// current session, not only those of this server's active request, because the recording server made the
  /// requests. Off in live operation: there, stale retransmissions and a previous server's requests are refused.
  bool accept_unrequested_scans = false;
  /// Start rounds by the rules above. A replaying server turns this off and starts a round (RequestRound) where
  /// the recording has the recording server's merge result, so its rounds see the same data.
  bool automatic_rounds = true;
  /// Replay of a recording with round steps (merge_round_t): rounds neither start nor continue by themselves,
  /// only at FollowStep (no request timeout either), so they run where the recorded ones ran.
  bool follow_recorded_steps = false;
  /// What a round asks of pairs earlier rounds answered (core/agent/pair_exchange.hpp).
  PairExchangeParams exchange;
};

Status ValidateServerLinkParams(const ServerLinkParams& params);

struct ServerOutgoing {
  enum class Kind : std::uint8_t { kTransferStatus, kScanRequest, kMergeResult, kRoundStep };
  Kind kind = Kind::kTransferStatus;
  TransferStatus status;
  ScanRequest request;
  MergeResultMessage result;
  RoundStep step;
};

struct ServerLinkStats {
  std::uint64_t stale_messages = 0;     ///< older sessions, chunks outside the active request
  std::uint64_t robot_restarts = 0;     ///< newer sessions that replaced a robot's keyframes
  std::uint64_t rounds_started = 0, rounds_merged = 0, rounds_timed_out = 0;
  std::uint64_t statuses = 0, policies = 0;
  std::uint64_t widened_pairs = 0;      ///< pair selections widened after registration refused them
  std::string last_rejection;
};

class ServerLink {
 public:
  /// `server` is not owned. `session` > 0 (e.g. the process start time in us).
  ServerLink(std::int64_t session, const ServerLinkParams& params, MergeServer* server);

  /// Message handlers: refused messages (malformed, unknown robot, stale session) return an error and are
  /// counted; they never change the state.
  Status OnKeyframeBatch(const KeyframeBatch& batch, std::int64_t now_us);
  Status OnPoseUpdate(const PoseUpdate& update, std::int64_t now_us);
  Status OnScanChunk(const ScanChunk& chunk, std::int64_t now_us);

  /// Appends what is due now: transfer statuses, (repeated) scan requests, and a merge result when a round
  /// finished. A call that started or continued a round sends no status (the messages that arrived meanwhile are
  /// not in it yet: the next call, after the caller handed them over, does). Errors come from the cascade or the
  /// registration (bad parameters); the round is then abandoned.
  Status Poll(std::int64_t now_us, std::vector<ServerOutgoing>* out);

  /// Starts a round at the next Poll() whatever the triggers say (when any robot has keyframes).
  void RequestRound() noexcept { round_requested_ = true; }

  /// Replay (follow_recorded_steps): runs the step `recorded` describes now, on the messages handed over so far:
  /// step 0 begins a round, a later step continues the waiting one. Robots the record says left are treated as
  /// left first. Appends what the step sends (its RoundStep record first, then requests or the merge result).
  /// Returns an error naming the difference when this server's step differs from the recorded one
  /// (RoundStepMismatch) or cannot run (a continuation with no round waiting), or when the round failed.
  Status FollowStep(const RoundStep& recorded, std::int64_t now_us, std::vector<ServerOutgoing>* out);
  /// Turns follow_recorded_steps off and accept_unrequested_scans on: a replay of a log without round steps
  /// (rounds begin at RequestRound and continue when their scans arrived or timed out).
  void FollowRecordedRequests() noexcept;

  /// What the server has taken of each robot id 0..max_robots-1 (messages handed to the On...() handlers, by
  /// kind, over every session), as a round step records it.
  std::vector<RoundRobotInput> TakenInputs() const;

  /// Robot `robot_id`'s process said it is leaving (its status "merged": `commerge robot --exit-when-merged`
  /// exits). Its open scan request is withdrawn and later rounds ask it for nothing: they use the scans held
  /// (a round used to wait request_timeout_s for scans nobody would send). Ignored unless `session` is the
  /// robot's current one; a restart (a newer session) is asked again.
  void OnRobotLeft(int robot_id, std::int64_t session);
  bool robot_left(int robot) const;

  /// The status of one robot now (also what Poll() sends).
  TransferStatus MakeStatus(int robot, std::int64_t now_us) const;

  std::int64_t session() const noexcept { return session_; }
  int rounds_merged() const noexcept { return round_; }
  bool round_active() const noexcept { return round_active_; }
  /// Chunks of robot r's active request still missing (0 when none is active).
  std::size_t chunks_missing(int robot) const;
  std::int64_t robot_session(int robot) const;
  /// Appends server_status_t's per-robot columns for every robot with a session, in robot order: its id,
  /// keyframes held, complete scans held, chunks_missing() and its descriptor parameter id (0: none yet).
  void AppendRobotStatus(ServerStatus* status) const;
  /// The last merge result (round 0 = none yet).
  const MergeResultMessage& last_result() const noexcept { return last_result_; }
  /// The round behind last_result(): selections, pairwise results, frames.
  const MergeRoundResult& last_round() const noexcept { return merge_round_.result(); }
  const std::vector<PairMergeResult>& last_pairs() const noexcept { return merge_round_.result().pairs; }
  const FrameSolution& last_frames() const noexcept { return merge_round_.result().frames; }
  const ServerLinkStats& stats() const noexcept { return stats_; }
  /// "collecting", "waiting for scans (n chunks)", "merged k/n robots".
  std::string state() const;
  /// Nothing left to do for now: a round has merged, none is running, every keyframe delivered so far was in
  /// the last round, and no robot message arrived for round_quiet_s. (`commerge server --exit-when-merged`.)
  bool Settled(std::int64_t now_us) const;

 private:
  struct RobotState {
    std::int64_t session = 0;            ///< 0: never heard of
    std::deque<std::int32_t> pose_acks;  ///< most recent pose-update sequences
    ScanRequest request;                 ///< active (request_id -1: none)
    bool request_complete = false;
    std::int64_t last_policy_us = -1, last_status_us = -1;
    std::int64_t left_session = 0;       ///< the session that said it is leaving (0: none)
  };
  Status CheckSession(int robot_id, std::int64_t session, const char* what);
  Status Refuse(Status status);
  bool RequestComplete(int robot) const;
  Status StartRound(std::int64_t now_us, std::vector<ServerOutgoing>* out);
  /// Continues the round until it waits for scans it asked for, or is finished (then emits the result).
  Status ContinueRound(std::int64_t now_us, std::vector<ServerOutgoing>* out);
  Status AdvanceRound(std::int64_t now_us, std::vector<ServerOutgoing>* out, bool* worked);
  /// Withdraws the robots' incomplete requests (the robot stops sending once its status shows no request).
  void WithdrawIncompleteRequests();
  /// Sends `requests` (not to robots that left); returns how many it sent.
  std::size_t SendRequests(const std::vector<ScanRequest>& requests, std::int64_t now_us,
                           std::vector<ServerOutgoing>* out);
  /// Inserts the RoundStep record of the step that began at out[first] (its requests are those sent since).
  void EmitStep(int round, int step, bool finished, std::size_t first, std::int64_t now_us,
                std::vector<ServerOutgoing>* out) const;
  /// Counts a message handed to a handler; `ids` identify it within its kind (RoundRobotInput::digest).
  void CountTaken(int robot_id, RobotMessageKind kind, std::initializer_list<std::int64_t> ids);
  /// Keyframes delivered by every robot, or by `only_robot` alone.
  std::size_t DeliveredKeyframes(int only_robot = -1) const;

  std::int64_t session_;
  ServerLinkParams params_;
  Status params_status_;
  MergeServer* server_;
  std::vector<RobotState> robots_;
  MergeRound merge_round_;
  std::vector<ScanRequest> round_requests_;
  bool round_active_ = false, round_requested_ = false;
  bool statuses_owed_ = false;  ///< the last Poll did round work: the next sends due statuses before any round work
  std::int64_t round_start_us_ = -1, last_round_us_ = -1, last_message_us_ = -1, last_round_check_us_ = -1;
  std::size_t delivered_at_last_round_ = 0;
  std::vector<std::uint32_t> round_keyframes_;  ///< per robot: delivered keyframes when the round started
  /// Per robot id: messages handed to the handlers (over every session; RobotState resets with a session).
  std::vector<RoundRobotInput> taken_;
  int round_step_ = 0;  ///< steps of the current round so far
  int round_ = 0;
  MergeResultMessage last_result_;
  ServerLinkStats stats_;
};

}  // namespace commerge
