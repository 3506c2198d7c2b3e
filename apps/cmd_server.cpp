// SPDX-License-Identifier: BSD-3-Clause
// `commerge server`: the merge server process on LCM. It receives keyframe batches, pose updates and scan
// chunks (decoded with the bounded decoders; malformed, foreign, stale and unknown-robot messages are counted),
// sends transfer statuses and exchange policies, runs merge rounds (core/agent/server_link), publishes
// merge_result_t and server_status_t, and after every round writes transforms.txt, trajectories/ and the merged
// map of the scans it holds (platform/io/merge_outputs.hpp; the same writers as `commerge run`), and what the
// robots sent it: a row of exchange_rounds.tsv and exchange_bytes.png, at exit exchange_summary.tsv with the
// paper's d_exch and t_comm (platform/io/exchange_outputs.hpp, counted by core/eval/mission_traffic.hpp).
// With --exit-when-merged N it ends (exit 0) once N robots are in the world frame after a round that saw every
// delivered keyframe, and every placed robot's robot_status_t said "merged" (or --linger-s passed; the result is
// re-sent every second meanwhile); otherwise it runs until SIGINT / SIGTERM. At exit it prints, per robot, a
// digest of the descriptors it holds (compare with the robot's own line: equal = every descriptor arrived).
// --replay takes a mission recorded with `commerge record` and played back with lcm-logplayer: the robots'
// messages wait in a queue, and at each recorded round step (merge_round_t) the round gets exactly the messages
// the recording server had taken by then, runs the same step and is checked against it (core/agent/round_replay).
// A log without round steps replays as before: rounds begin at the recording's first scan request of a round,
// and scan chunks are accepted without this server's own request.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <deque>
#include <filesystem>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "apps/app_auth.hpp"
#include "apps/app_common.hpp"
#include "apps/app_descriptor_flags.hpp"
#include "apps/app_memory.hpp"
#include "apps/commands.hpp"
#include "apps/merge_flags.hpp"
#include "core/agent/delivery_digest.hpp"
#include "core/agent/round_replay.hpp"
#include "core/agent/server_link.hpp"
#include "core/cloud/scan_codec.hpp"
#include "core/common/bytes.hpp"
#include "core/exchange/exchange_policy.hpp"
#include "core/merge/merged_map.hpp"
#include "core/eval/mission_traffic.hpp"
#include "platform/io/exchange_outputs.hpp"
#include "platform/io/merge_outputs.hpp"
#include "platform/lcm/lcm_bus.hpp"
#include "platform/lcm/message_codec.hpp"
#include "platform/lcm/round_codec.hpp"
#include "platform/lcm/status_codec.hpp"
#include "platform/memory/peak_rss.hpp"

namespace commerge::app {

namespace {

/// Replay: a recorded result and this replay's agree when every T_world_map entry is within this.
constexpr double kReplayResultTolerance = 1e-3;

struct ServerOptions {
  std::string out_dir = "commerge-server-out";
  std::string mode = "A+B+C";
  std::string lcm_url;
  std::string lidar = "hdl-64e";  ///< the robots' --lidar: heading tolerance of descriptor agreement
  std::string descriptor = "ring";  ///< the robots' --descriptor: the keyframe records taken
  double round_interval_s = 10.0;
  double round_quiet_s = 3.0;
  double request_timeout_s = 60.0;
  std::int64_t round_min_new_keyframes = 200;
  /// What rounds ask of pairs earlier rounds answered (core/agent/pair_exchange.hpp); every_round turns it off.
  PairExchangeParams exchange;
  bool every_round = false;
  /// The flags `server` shares with `run` (apps/merge_flags.hpp); max_submap_points comes from the memory flags.
  MergeServerParams server;
  std::string profile = "commerge";  ///< --profile: what the merge flags not given take (ApplyMergeProfile)
  int exit_when_merged = 0;
  double max_runtime_s = 0.0;
  double linger_s = 10.0;
  bool replay = false;
  double delay_ms = 0.0, jitter_ms = 0.0, duplicate_pct = 0.0;
  bool quiet = false;
  MemoryFlags memory;
  AuthFlags auth;
};

// The server process: its configuration, the transport-free server (MergeServer + ServerLink) and the LCM bus;
// Run() is its loop.
class ServerProcess {
 public:
  explicit ServerProcess(const ServerOptions& o) : o_(o) {}
  /// Flags, memory budget, parameters, authentication; kExitOk when Run may follow (also after --check: see checked()).
  int Configure();
  bool checked() const { return o_.auth.check; }
  int Run();

 private:
  /// What an accepted robot message brought: its robot (-1: none) and its bytes by kind.
  struct Received {
    int robot = -1;
    TrafficKind kind = TrafficKind::kKeyframeRecords;
    std::uint64_t resent_bytes = 0;  ///< of the message, records or chunks the server held already
    bool queued = false;             ///< a replayed robot message kept for the round step that takes it
  };
  /// How a replay starts its rounds: at the recorded round steps (exact), or at the recording's scan requests
  /// and merge results (a log without round steps); undecided until the log shows one of them.
  enum class ReplayMode : std::uint8_t { kUndecided, kSteps, kRequests };
  struct QueuedMessage {
    platform::BusMessage message;
    QueuedRobotMessage ref;
  };
  /// Replay: keeps a robot message for the round step that takes it (true), or leaves it to HandleMessage.
  bool QueueReplayed(const platform::BusMessage& message);
  /// Replay: hands the link the queued messages in `due` (indices, ascending), or every one (`all`).
  void ApplyQueued(const std::vector<std::size_t>& due, bool all, std::int64_t wall);
  /// Replay: hands one robot message to the link now (and counts it, or its rejection).
  void HandleQueued(const platform::BusMessage& message, std::int64_t wall);
  void OnRecordedStep(const RoundStep& step, std::int64_t wall);
  void OnRecordedResult(const MergeResultMessage& result);
  void SwitchToRequestReplay(const char* what);
  Status HandleRecorded(const platform::BusMessage& message, std::int64_t wall);
  /// Queues a replayed robot message for the round step that takes it, else HandleNow.
  Status HandleMessage(const platform::BusMessage& message, std::int64_t wall, Received* received);
  /// Hands a message to the link now (robot data, robot status) or follows the recording (replay).
  Status HandleNow(const platform::BusMessage& message, std::int64_t wall, Received* received);
  void CountReceived(const platform::BusMessage& message, const Received& received);
  /// Counts an accepted message's bytes, or the rejection (last_rejection_).
  void Account(const platform::BusMessage& message, const Status& st, const Received& received);
  /// A row of exchange_rounds.tsv and the chart, for the round just finished.
  void WriteExchangeRound(const MergeResultMessage& result);
  void WriteExchangeSummary();
  double MissionSeconds() const;
  void SayIncomparablePairs();
  void Publish(const ServerOutgoing& o_msg);
  void WriteRoundFiles(const MergeResultMessage& result);
  void PublishStatus(std::int64_t wall);
  bool PlacedRobotsConfirmed() const;
  int InWorld() const;
  std::vector<ModuleMemory> MemoryUse() const;
  int Finish(int exit_code);

  static constexpr const char* kTag = "commerge server";
  const ServerOptions& o_;
  MemorySetup setup_;
  int robots_ = 0;
  ExchangeMode mode_ = ExchangeMode::kStageABC;
  MergeServerParams server_params_;
  ServerLinkParams link_params_;
  platform::LcmBusParams bus_params_;
  std::int64_t session_ = 0;
  std::unique_ptr<MergeServer> server_;
  std::unique_ptr<ServerLink> link_;
  std::unique_ptr<platform::LcmBus> bus_;
  std::int64_t rejected_ = 0;
  /// What the robots sent, by kind and over time (exchange_rounds.tsv, exchange_summary.tsv, exchange_bytes.png).
  std::unique_ptr<MissionTraffic> traffic_;
  /// Exchange policies (scan requests, repeats included) published, encoded: the server's outgoing traffic.
  std::uint64_t policies_sent_bytes_ = 0;
  std::int64_t start_us_ = 0;
  std::vector<double> round_end_s_;  ///< the chart's marks (at most kMaxChartMarks; then every other is dropped)
  std::int64_t merged_map_high_water_ = 0;  ///< the merged_map budget module: the builder's buffers
  std::vector<std::pair<int, int>> reported_incomparable_;  ///< the last incomparable pairs said on stderr
  /// Replay: the recording server's (session, round) results and (session, request id) requests already followed,
  /// the recording server session whose round began (a request) and has no result yet (0: none), and when the
  /// recording last spoke.
  std::set<std::pair<std::int64_t, std::int32_t>> recorded_rounds_;
  std::set<std::pair<std::int64_t, std::int32_t>> recorded_requests_;
  std::int64_t recorded_open_session_ = 0;
  std::int64_t last_recorded_us_ = 0;
  ReplayMode replay_mode_ = ReplayMode::kUndecided;
  std::deque<QueuedMessage> replay_queue_;
  std::size_t replay_queue_bytes_ = 0;
  std::int64_t followed_session_ = 0;  ///< the recording server session whose steps are followed exactly
  std::int64_t restarted_session_ = 0;  ///< a later recording server session, said once (followed approximately)
  std::int64_t steps_after_restart_ = 0;
  std::int64_t steps_followed_ = 0, step_mismatches_ = 0, results_compared_ = 0, result_mismatches_ = 0;
  std::int64_t replay_overflow_ = 0;   ///< messages handed over early because the queue was full
  double largest_result_difference_ = 0.0;
  std::string last_rejection_;
  std::vector<std::int64_t> confirmed_session_;  ///< per robot: the session whose status said "merged"
  std::vector<std::uint8_t> buffer_;
};

int ServerProcess::Configure() {
  MemoryFlags memory = o_.memory;
  memory.descriptor_floats = DescriptorFloatsFor(o_.descriptor);
  if (int rc = SetUpMemory(AppKind::kServer, memory, &setup_, false); rc != kExitOk) return rc;
  // Robot ids 0..--robots-1 are accepted (the memory flag that also sizes the budget).
  robots_ = setup_.config.max_robots;
  if (robots_ < 2 || robots_ > 8) {
    std::fprintf(stderr, "%s: --robots = %d is outside 2..8 (the frame solver's limit)\n", kTag, robots_);
    return kExitUsage;
  }
  auto mode = ExchangeModeFromName(o_.mode);
  if (!mode.ok()) {
    std::fprintf(stderr, "%s: --mode: %s\n", kTag, mode.status().message().c_str());
    return kExitUsage;
  }
  mode_ = *mode;
  server_params_ = o_.server;
  server_params_.record_kind = RecordKindForDescriptor(o_.descriptor);
  server_params_.max_submap_points = static_cast<std::size_t>(setup_.config.max_submap_points);
  server_params_.max_scan_points = static_cast<std::size_t>(setup_.config.max_points_per_stored_scan);
  server_params_.stage_ac_ablation = mode_ == ExchangeMode::kStageAC;
  if (Result<LidarSensor> sensor = LidarSensorFor(o_.lidar); !sensor.ok()) {
    std::fprintf(stderr, "%s: --lidar: %s\n", kTag, sensor.status().message().c_str());
    return kExitUsage;
  }
  server_params_.colocation.max_heading_deg = ColocationHeadingDeg(ScanTraitsFor(o_.lidar));
  link_params_.mode = mode_;
  link_params_.round_interval_s = o_.round_interval_s;
  link_params_.round_quiet_s = o_.round_quiet_s;
  link_params_.request_timeout_s = o_.request_timeout_s;
  link_params_.round_min_new_keyframes = static_cast<std::size_t>(std::max<std::int64_t>(1, o_.round_min_new_keyframes));
  link_params_.exchange = o_.exchange;
  link_params_.exchange.enabled = !o_.every_round;
  // A replay runs its rounds at the recorded round steps; a log without them switches to the recorded requests
  // (SwitchToRequestReplay).
  link_params_.automatic_rounds = !o_.replay;
  link_params_.follow_recorded_steps = o_.replay;
  for (const Status& st : {ValidateMergeServerParams(server_params_), ValidateServerLinkParams(link_params_)}) {
    if (!st.ok()) {
      std::fprintf(stderr, "%s: %s\n", kTag, st.message().c_str());
      return kExitUsage;
    }
  }
  session_ = platform::WallTimeUs();
  bus_params_.url = o_.lcm_url;
  bus_params_.delay_ms = o_.delay_ms;
  bus_params_.jitter_ms = o_.jitter_ms;
  bus_params_.duplicate_pct = o_.duplicate_pct;
  bus_params_.fault_seed = static_cast<std::uint32_t>(session_);
  bus_params_.receive_thread = true;  // a round registers for seconds: robots' messages queue meanwhile
  // A replay has nobody to re-send a chunk LCM dropped: lcm-logplayer publishes faster than a live team, so
  // besides the receive thread let LCM hold as many messages per channel as this bus's own queue.
  if (o_.replay) bus_params_.lcm_queue_capacity = static_cast<int>(bus_params_.max_queued_messages);
  if (int rc = SetUpAuth(kTag, o_.auth, platform::kAuthServerSender, session_, robots_, &bus_params_); rc != kExitOk) {
    return rc;
  }
  if (o_.auth.check) {
    std::printf("%s: configuration OK (--check): board %s, memory budget %s of %s; robots 0..%d, mode %s, "
                "profile %s, descriptor %s, %s, output %s; LCM %s; %s\n",
                kTag, o_.memory.board.c_str(), FormatBytes(setup_.table.total_bytes()).c_str(),
                FormatBytes(setup_.limit_bytes).c_str(), robots_ - 1, ExchangeModeName(mode_), o_.profile.c_str(),
                o_.descriptor.c_str(), CascadeSettingsText(server_params_).c_str(), o_.out_dir.c_str(),
                o_.lcm_url.empty() ? "LCM_DEFAULT_URL" : o_.lcm_url.c_str(), AuthDescription(o_.auth, bus_params_).c_str());
  }
  return kExitOk;
}

Status ServerProcess::HandleMessage(const platform::BusMessage& message, std::int64_t wall, Received* received) {
  if (o_.replay && replay_mode_ != ReplayMode::kRequests && QueueReplayed(message)) {
    received->queued = true;
    return Status::Ok();
  }
  return HandleNow(message, wall, received);
}

Status ServerProcess::HandleNow(const platform::BusMessage& message, std::int64_t wall, Received* received) {
  if (message.channel == platform::kPolicyChannel || message.channel == platform::kMergeResultChannel ||
      message.channel == platform::kRoundChannel) {
    return HandleRecorded(message, wall);
  }
  const Span<const std::uint8_t> bytes(message.bytes.data(), message.bytes.size());
  const MergeServerStats before = server_->stats();
  if (message.channel == platform::kKeyframesChannel) {
    auto m = platform::DecodeKeyframeBatch(bytes);
    Status st = !m.ok() ? m.status() : CheckSigner(message, m->robot_id);
    if (st.ok()) st = link_->OnKeyframeBatch(*m, wall);
    if (!st.ok()) return st;
    // Records of keyframes the server held already are re-sends: their share of the message's bytes.
    const std::uint64_t records = server_->stats().records - before.records;
    const std::uint64_t repeated = server_->stats().records_repeated - before.records_repeated;
    *received = Received{m->robot_id, TrafficKind::kKeyframeRecords,
                         records > 0 ? message.bytes.size() * repeated / records : 0};
    return st;
  }
  if (message.channel == platform::kPosesChannel) {
    auto m = platform::DecodePoseUpdate(bytes);
    Status st = !m.ok() ? m.status() : CheckSigner(message, m->robot_id);
    if (st.ok()) st = link_->OnPoseUpdate(*m, wall);
    if (st.ok()) *received = Received{m->robot_id, TrafficKind::kPoseUpdates, 0};
    return st;
  }
  if (message.channel == platform::kScansChannel) {
    auto m = platform::DecodeScanChunk(bytes);
    Status st = !m.ok() ? m.status() : CheckSigner(message, m->robot_id);
    if (st.ok()) st = link_->OnScanChunk(*m, wall);
    const bool duplicate = server_->stats().duplicate_chunks > before.duplicate_chunks;
    if (st.ok()) *received = Received{m->robot_id, TrafficKind::kScans, duplicate ? message.bytes.size() : 0};
    return st;
  }
  if (message.channel == platform::kRobotStatusChannel) {
    auto m = platform::DecodeRobotStatus(bytes);
    Status st = !m.ok() ? m.status() : CheckSigner(message, m->robot_id);
    if (st.ok() && (m->robot_id < 0 || m->robot_id >= robots_)) {
      st = InvalidArgument("robot status of robot " + std::to_string(m->robot_id) + ", not one of --robots " +
                           std::to_string(robots_));
    }
    if (st.ok()) *received = Received{m->robot_id, TrafficKind::kRobotStatus, 0};
    if (st.ok() && m->state == "merged" && m->session != 0 && m->session == link_->robot_session(m->robot_id)) {
      confirmed_session_[static_cast<std::size_t>(m->robot_id)] = m->session;
      link_->OnRobotLeft(m->robot_id, m->session);  // "merged" is a robot's last status: it exits
    }
    return st;
  }
  return Status::Ok();
}

// A recorded server message (replay): a round step, a scan request or a merge result of the recording server.
Status ServerProcess::HandleRecorded(const platform::BusMessage& message, std::int64_t wall) {
  const Span<const std::uint8_t> bytes(message.bytes.data(), message.bytes.size());
  if (message.channel == platform::kRoundChannel) {
    auto m = platform::DecodeRoundStep(bytes);
    if (!m.ok()) return m.status();
    Status st = CheckSigner(message, platform::kAuthServerSender);
    if (st.ok() && m->server_session != session_) OnRecordedStep(*m, wall);
    return st;
  }
  if (message.channel == platform::kPolicyChannel) {
    auto m = platform::DecodeScanRequest(bytes);
    if (!m.ok()) return m.status();
    Status st = CheckSigner(message, platform::kAuthServerSender);
    if (!st.ok() || m->server_session == session_) return st;
    if (replay_mode_ == ReplayMode::kUndecided) SwitchToRequestReplay("a scan request");
    if (replay_mode_ == ReplayMode::kRequests && recorded_requests_.size() < 100000 &&
        recorded_requests_.insert({m->server_session, m->request_id}).second &&
        recorded_open_session_ != m->server_session) {
      // The recording server sent a round's first request right after it began the round: begin one here, on
      // the keyframes logged up to its start. Its later requests (other robots, widening) belong to that round.
      recorded_open_session_ = m->server_session;
      link_->RequestRound();
    }
    return st;
  }
  auto m = platform::DecodeMergeResult(bytes);
  if (!m.ok()) return m.status();
  Status st = CheckSigner(message, platform::kAuthServerSender);
  if (!st.ok() || m->server_session == session_) return st;
  if (replay_mode_ == ReplayMode::kUndecided) SwitchToRequestReplay("a merge result");
  if (recorded_rounds_.size() < 100000 && recorded_rounds_.insert({m->server_session, m->round}).second) {
    if (replay_mode_ == ReplayMode::kSteps) {
      OnRecordedResult(*m);
    } else {
      // A recorded round that requested no scans shows only by its result: merge on the data logged up to it.
      if (recorded_open_session_ != m->server_session) link_->RequestRound();
      recorded_open_session_ = 0;
    }
  }
  return st;
}

bool ServerProcess::QueueReplayed(const platform::BusMessage& message) {
  QueuedRobotMessage ref;
  const Span<const std::uint8_t> bytes(message.bytes.data(), message.bytes.size());
  if (message.channel == platform::kKeyframesChannel) {
    auto m = platform::DecodeKeyframeBatch(bytes);
    if (!m.ok()) return false;
    ref = {m->robot_id, RobotMessageKind::kKeyframeBatch};
  } else if (message.channel == platform::kPosesChannel) {
    auto m = platform::DecodePoseUpdate(bytes);
    if (!m.ok()) return false;
    ref = {m->robot_id, RobotMessageKind::kPoseUpdate};
  } else if (message.channel == platform::kScansChannel) {
    auto m = platform::DecodeScanChunk(bytes);
    if (!m.ok()) return false;
    ref = {m->robot_id, RobotMessageKind::kScanChunk};
  } else {
    return false;
  }
  // Only what reaches the link (and counts there): refused messages are handled, and counted, at once.
  if (ref.robot_id < 0 || ref.robot_id >= robots_ || !CheckSigner(message, ref.robot_id).ok()) return false;
  replay_queue_bytes_ += message.bytes.size();
  replay_queue_.push_back(QueuedMessage{message, ref});
  // Bounded by the inbox budget (--queue-mb): beyond it the oldest goes to the link now. The step that should
  // have taken it later differs, and says so.
  const auto limit = static_cast<std::size_t>(setup_.config.message_queue_bytes);
  while (replay_queue_bytes_ > limit && replay_queue_.size() > 1) {
    if (replay_overflow_++ == 0) {
      std::fprintf(stderr, "%s: replay: more than --queue-mb %lld MiB of robot messages wait for a recorded round "
                           "step; the oldest are handed over early (this replay may differ from the recording)\n",
                   kTag, static_cast<long long>(setup_.config.message_queue_bytes >> 20));
    }
    QueuedMessage oldest = std::move(replay_queue_.front());
    replay_queue_.pop_front();
    replay_queue_bytes_ -= oldest.message.bytes.size();
    HandleQueued(oldest.message, platform::WallTimeUs());
  }
  return true;
}

void ServerProcess::HandleQueued(const platform::BusMessage& message, std::int64_t wall) {
  Received received;
  const Status st = HandleNow(message, wall, &received);
  Account(message, st, received);
}

void ServerProcess::Account(const platform::BusMessage& message, const Status& st, const Received& received) {
  if (st.ok()) {
    CountReceived(message, received);
    return;
  }
  ++rejected_;
  last_rejection_ = message.channel + ": " + st.message();
  if (last_rejection_.size() > kMaxStatusTextBytes) last_rejection_.resize(kMaxStatusTextBytes);
}

void ServerProcess::ApplyQueued(const std::vector<std::size_t>& due, bool all, std::int64_t wall) {
  std::deque<QueuedMessage> kept;
  std::size_t next = 0;
  for (std::size_t i = 0; i < replay_queue_.size(); ++i) {
    const bool take = all || (next < due.size() && due[next] == i);
    if (!take) {
      kept.push_back(std::move(replay_queue_[i]));
      continue;
    }
    if (!all) ++next;
    replay_queue_bytes_ -= replay_queue_[i].message.bytes.size();
    HandleQueued(replay_queue_[i].message, wall);
  }
  replay_queue_ = std::move(kept);
}

void ServerProcess::SwitchToRequestReplay(const char* what) {
  std::fprintf(stderr, "%s: replay: warning: the log shows %s before any round step (merge_round_t): a recording "
                       "from before round steps; rounds begin at the recording's first scan request of a round and "
                       "see the data logged up to there, so this replay can differ from the recording\n",
               kTag, what);
  replay_mode_ = ReplayMode::kRequests;
  ApplyQueued({}, true, platform::WallTimeUs());
  link_->FollowRecordedRequests();
}

void ServerProcess::OnRecordedStep(const RoundStep& step, std::int64_t wall) {
  if (replay_mode_ == ReplayMode::kRequests) return;
  replay_mode_ = ReplayMode::kSteps;
  if (followed_session_ == 0) followed_session_ = step.server_session;
  const bool exact = step.server_session == followed_session_;
  if (!exact) {
    // A recording server that restarted counted the robots' messages from its own start: not comparable. Its
    // steps run on every message logged up to them, and their differences are said but not failures.
    if (restarted_session_ != step.server_session) {
      restarted_session_ = step.server_session;
      std::fprintf(stderr, "%s: replay: warning: round %d step %d comes from recording server session %lld, not "
                           "%lld (it restarted): its rounds replay on every message logged up to each step\n",
                   kTag, step.round, step.step, static_cast<long long>(step.server_session),
                   static_cast<long long>(followed_session_));
    }
    ApplyQueued({}, true, wall);
  } else {
    const std::vector<RoundRobotInput> taken = link_->TakenInputs();
    std::vector<QueuedRobotMessage> refs;
    refs.reserve(replay_queue_.size());
    for (const QueuedMessage& q : replay_queue_) refs.push_back(q.ref);
    ApplyQueued(MessagesDue(Span<const QueuedRobotMessage>(refs), Span<const RoundRobotInput>(step.robots),
                            Span<const RoundRobotInput>(taken)),
                false, wall);
  }
  std::vector<ServerOutgoing> out;
  const Status st = link_->FollowStep(step, wall, &out);
  ++(exact ? steps_followed_ : steps_after_restart_);
  if (!st.ok() && exact) {
    ++step_mismatches_;
    std::fprintf(stderr, "%s: replay: MISMATCH: %s\n", kTag, st.message().c_str());
  } else if (!st.ok()) {
    std::fprintf(stderr, "%s: replay: differs after the recording server restarted: %s\n", kTag, st.message().c_str());
  }
  for (const ServerOutgoing& o_msg : out) Publish(o_msg);
}

// The recorded result of a round this replay followed: the same robots placed, the same T_world_map.
void ServerProcess::OnRecordedResult(const MergeResultMessage& result) {
  if (result.server_session != followed_session_) return;
  const MergeResultMessage& mine = link_->last_result();
  ++results_compared_;
  double largest = 0.0;
  bool same = mine.round == result.round && mine.robot_ids == result.robot_ids && mine.in_world == result.in_world;
  for (std::size_t i = 0; same && i < result.T_world_map.size(); ++i) {
    largest = std::max(largest, (mine.T_world_map[i].matrix() - result.T_world_map[i].matrix()).cwiseAbs().maxCoeff());
  }
  largest_result_difference_ = std::max(largest_result_difference_, largest);
  if (same && largest <= kReplayResultTolerance) return;
  ++result_mismatches_;
  std::fprintf(stderr, "%s: replay: MISMATCH: recorded round %d: %s\n", kTag, result.round,
               same ? ("T_world_map differs by " + std::to_string(largest) + " (largest entry)").c_str()
                    : ("this replay's round " + std::to_string(mine.round) +
                       " placed other robots or has other robots").c_str());
}

// Said once per change: a robot started with another --lidar / --solid-min-z-m than the others.
void ServerProcess::SayIncomparablePairs() {
  if (server_->incomparable_pairs() == reported_incomparable_) return;
  reported_incomparable_ = server_->incomparable_pairs();
  for (const auto& [a, b] : reported_incomparable_) {
    std::fprintf(stderr,
                 "%s: robots %d and %d are not compared: their descriptor parameter ids differ (0x%08X, 0x%08X); "
                 "start every robot with the same --lidar and --solid-min-z-m\n",
                 kTag, a, b, static_cast<unsigned>(server_->robot(a).descriptor_id),
                 static_cast<unsigned>(server_->robot(b).descriptor_id));
  }
}

// transforms.txt, trajectories/ and merged_map.pcd/.ply of a round: the robots in the world frame from the scans
// the server holds (the robots keep the rest). Keyframe records carry no time: trajectories use the keyframe index.
void ServerProcess::WriteRoundFiles(const MergeResultMessage& result) {
  const MergeRoundResult& round = link_->last_round();
  Status st = platform::WriteTransforms(o_.out_dir + "/transforms.txt", result,
                                        std::string(kTag) + ", round " + std::to_string(result.round));
  MergedMapBuilder map{MergedMapParamsForBytes(setup_.config.merged_map_bytes)};
  std::vector<PointXYZI> scan;
  std::error_code ec;
  std::filesystem::create_directories(o_.out_dir + "/trajectories", ec);
  for (int r : result.robot_ids) {
    const RobotKeyframeDb& db = server_->robot(r);
    platform::RobotTrajectory t;
    t.robot = r;
    t.in_world = round.in_world(r);
    t.T_world_map = round.T_world_map(r);
    if (t.in_world) map.BeginRobot(static_cast<std::uint16_t>(r), t.T_world_map);
    for (std::size_t k = 0; k < db.size(); ++k) {
      if (!db.pose_known[k]) continue;
      t.T_map_sensor.push_back(db.T_map_sensor[k]);
      t.times_s.push_back(static_cast<double>(k));
      const std::vector<std::uint8_t>* bytes = t.in_world ? server_->scan_bytes(r, static_cast<std::uint32_t>(k)) : nullptr;
      if (bytes != nullptr && DecodeScan(Span<const std::uint8_t>(*bytes), &scan).ok()) {
        map.AddScan(Span<const PointXYZI>(scan), db.T_map_sensor[k]);
      }
    }
    if (st.ok() && !ec) st = platform::WriteTrajectory(o_.out_dir + "/trajectories", t);
  }
  map.Finish();
  merged_map_high_water_ = std::max(merged_map_high_water_, static_cast<std::int64_t>(map.memory_bytes()));
  if (st.ok()) st = platform::WriteMergedMap(o_.out_dir, map);
  if (ec) st = IoError("cannot create " + o_.out_dir + "/trajectories: " + ec.message());
  if (!st.ok()) std::fprintf(stderr, "%s: %s\n", kTag, st.message().c_str());
  if (!o_.quiet) {
    std::string left_out;
    if (map.scans_left_out() > 0) {
      left_out = " (" + std::to_string(map.scans_left_out()) + " scans left out: the map is full at --merged-map-mb " +
                 std::to_string(setup_.config.merged_map_bytes / kMiB) + ")";
    }
    std::fprintf(stderr, "%s: %s; merged_map.pcd/.ply %zu points%s\n", kTag, link_->state().c_str(),
                 map.points().size(), left_out.c_str());
  }
}

void ServerProcess::Publish(const ServerOutgoing& o_msg) {
  Status st;
  const char* channel = platform::kStatusChannel;
  switch (o_msg.kind) {
    case ServerOutgoing::Kind::kTransferStatus: st = platform::EncodeTransferStatus(o_msg.status, &buffer_); break;
    case ServerOutgoing::Kind::kScanRequest:
      st = platform::EncodeScanRequest(o_msg.request, &buffer_);
      channel = platform::kPolicyChannel;
      break;
    case ServerOutgoing::Kind::kMergeResult:
      st = platform::EncodeMergeResult(o_msg.result, &buffer_);
      channel = platform::kMergeResultChannel;
      break;
    case ServerOutgoing::Kind::kRoundStep:
      st = platform::EncodeRoundStep(o_msg.step, &buffer_);
      channel = platform::kRoundChannel;
      break;
  }
  if (st.ok()) st = bus_->Publish(channel, buffer_);
  if (!st.ok()) std::fprintf(stderr, "%s: %s\n", kTag, st.message().c_str());
  if (st.ok() && o_msg.kind == ServerOutgoing::Kind::kScanRequest) policies_sent_bytes_ += buffer_.size();
  if (o_msg.kind == ServerOutgoing::Kind::kMergeResult) {
    WriteRoundFiles(o_msg.result);
    WriteExchangeRound(o_msg.result);
  }
}

double ServerProcess::MissionSeconds() const { return static_cast<double>(platform::MonotonicUs() - start_us_) * 1e-6; }

void ServerProcess::CountReceived(const platform::BusMessage& message, const Received& received) {
  const double t = MissionSeconds();
  const std::uint64_t bytes = message.bytes.size();
  if (received.robot < 0) {
    traffic_->Record(-1, TrafficKind::kKeyframeRecords, bytes, t);  // not a robot's (a replayed merge result)
    return;
  }
  const std::uint64_t resent = std::min(received.resent_bytes, bytes);
  if (resent > 0) traffic_->Record(received.robot, TrafficKind::kResends, resent, t);
  if (bytes > resent) traffic_->Record(received.robot, received.kind, bytes - resent, t);
}

void ServerProcess::WriteExchangeRound(const MergeResultMessage& result) {
  const MergeRoundResult& round = link_->last_round();
  platform::ExchangeRoundRow row;
  row.round = result.round;
  row.time_s = MissionSeconds();
  for (std::size_t i = 0; i < result.robot_ids.size(); ++i) {
    if (!result.in_world[i]) continue;
    ++row.robots_placed;
    row.placed.push_back(result.robot_ids[i]);
  }
  row.robots = static_cast<int>(result.robot_ids.size());
  for (const MergePairOutcome& p : result.pairs) row.pairs_merged += p.success ? 1 : 0;
  row.pairs_registered = round.pairs_registered;
  row.pairs_kept = round.pairs_kept;
  for (const PairExchangeDecision& d : round.decisions) {
    row.scans_requested += d.scans_requested;
    row.scans_widened += d.scans_widened;
  }
  row.scans_refined = round.refined_scans;
  for (std::size_t k = 0; k < kTrafficKinds; ++k) row.bytes[k] = traffic_->KindTotal(static_cast<TrafficKind>(k));
  for (int r = 0; r < robots_; ++r) row.robot_bytes.push_back(traffic_->RobotTotal(r));
  row.pairs = ExchangeDecisionsText(Span<const PairExchangeDecision>(round.decisions));
  const std::string dir = o_.out_dir + "/";
  Status st = platform::AppendExchangeRound(dir + "exchange_rounds.tsv", row);
  // The chart's marks are bounded like its series: past the limit every other mark goes.
  constexpr std::size_t kMaxChartMarks = 512;
  if (round_end_s_.size() == kMaxChartMarks) {
    for (std::size_t i = 0; i < kMaxChartMarks / 2; ++i) round_end_s_[i] = round_end_s_[2 * i + 1];
    round_end_s_.resize(kMaxChartMarks / 2);
  }
  round_end_s_.push_back(row.time_s);
  if (st.ok()) {
    st = platform::WriteExchangeBytesPng(dir + "exchange_bytes.png", *traffic_, robots_,
                                         Span<const double>(round_end_s_));
  }
  if (!st.ok()) std::fprintf(stderr, "%s: %s\n", kTag, st.message().c_str());
}

void ServerProcess::WriteExchangeSummary() {
  platform::ExchangeSummary summary;
  summary.rounds = link_->rounds_merged();
  for (int r = 0; r < robots_; ++r) {
    const RobotKeyframeDb& db = server_->robot(r);
    std::uint32_t scans = 0;
    for (std::size_t k = 0; k < db.size(); ++k) {
      scans += server_->has_scan(r, static_cast<std::uint32_t>(k)) ? 1 : 0;
      if (db.stored_points[k] > 0) summary.send_all_bytes += EncodedScanBytes(db.stored_points[k]);
    }
    summary.keyframes.push_back(static_cast<std::uint32_t>(db.size()));
    summary.scans_received.push_back(scans);
  }
  summary.send_all_bytes += traffic_->KindTotal(TrafficKind::kKeyframeRecords);
  summary.policies_sent_bytes = policies_sent_bytes_;
  const std::string dir = o_.out_dir + "/";
  Status st = platform::WriteExchangeSummary(dir + "exchange_summary.tsv", *traffic_, summary);
  if (st.ok()) {
    st = platform::WriteExchangeBytesPng(dir + "exchange_bytes.png", *traffic_, robots_,
                                         Span<const double>(round_end_s_));
  }
  if (!st.ok()) std::fprintf(stderr, "%s: %s\n", kTag, st.message().c_str());
  const auto mb = [](std::uint64_t b) { return FormatFixed(static_cast<double>(b) / 1e6, 2) + " MB"; };
  std::printf("server: d_exch %s (keyframe records %s, pose updates %s, scans %s, re-sends %s), robot status %s, "
              "t_comm %.1f s; every stored scan with the records would have been %s; sent policies %s B\n",
              mb(traffic_->ExchangedBytes()).c_str(), mb(traffic_->KindTotal(TrafficKind::kKeyframeRecords)).c_str(),
              mb(traffic_->KindTotal(TrafficKind::kPoseUpdates)).c_str(),
              mb(traffic_->KindTotal(TrafficKind::kScans)).c_str(), mb(traffic_->KindTotal(TrafficKind::kResends)).c_str(),
              mb(traffic_->KindTotal(TrafficKind::kRobotStatus)).c_str(), traffic_->CommSeconds(),
              mb(summary.send_all_bytes).c_str(), std::to_string(summary.policies_sent_bytes).c_str());
}

std::vector<ModuleMemory> ServerProcess::MemoryUse() const {
  std::vector<ModuleMemory> modules = server_->MemoryUse();
  modules.push_back(ModuleMemory{"merged_map", 0, 0, merged_map_high_water_});
  return modules;
}

void ServerProcess::PublishStatus(std::int64_t wall) {
  ServerStatus status;
  status.utime_us = wall;
  status.session = session_;
  status.peak_rss_bytes = platform::ReadRss().peak_bytes;
  status.budget_total_bytes = setup_.table.total_bytes();
  status.budget_limit_bytes = setup_.limit_bytes;
  status.modules = StatusModules(setup_.table, MemoryUse());
  status.round = link_->rounds_merged();
  status.state = link_->state();
  status.bytes_received = static_cast<std::int64_t>(traffic_->Total());
  status.messages_rejected = rejected_ + static_cast<std::int64_t>(AuthRejected(*bus_)) +
                             static_cast<std::int64_t>(server_->stats().rejected_batches +
                                                       server_->stats().rejected_pose_updates +
                                                       server_->stats().rejected_chunks);
  status.last_rejection = last_rejection_;
  link_->AppendRobotStatus(&status);
  for (const MergePairOutcome& p : link_->last_result().pairs) {
    status.pairs.push_back({p.alpha, p.beta, StageSolverText("B", p.stage_b) + "; " + StageSolverText("C", p.stage_c)});
  }
  if (platform::EncodeServerStatus(status, &buffer_).ok()) (void)bus_->Publish(platform::kServerStatusChannel, buffer_);
  if (!o_.quiet) {
    std::fprintf(stderr, "%s: %s; %lld bytes received, %lld messages rejected\n", kTag, status.state.c_str(),
                 static_cast<long long>(traffic_->Total()), static_cast<long long>(status.messages_rejected));
  }
}

int ServerProcess::InWorld() const {
  int in_world = 0;
  for (std::uint8_t w : link_->last_result().in_world) in_world += w;
  return in_world;
}

bool ServerProcess::PlacedRobotsConfirmed() const {
  const MergeResultMessage& r = link_->last_result();
  for (std::size_t i = 0; i < r.robot_ids.size(); ++i) {
    const int id = r.robot_ids[i];
    if (!r.in_world[i] || id < 0 || id >= robots_) continue;
    if (confirmed_session_[static_cast<std::size_t>(id)] != link_->robot_session(id)) return false;
  }
  return true;
}

int ServerProcess::Run() {
  std::error_code ec;
  std::filesystem::create_directories(o_.out_dir, ec);
  if (ec) {
    std::fprintf(stderr, "%s: cannot create --out %s: %s\n", kTag, o_.out_dir.c_str(), ec.message().c_str());
    return kExitFailure;
  }
  auto server = MergeServer::Create(robots_, static_cast<std::size_t>(setup_.config.max_keyframes_per_robot),
                                    server_params_);
  if (!server.ok()) {
    std::fprintf(stderr, "%s: %s\n", kTag, server.status().message().c_str());
    return kExitUsage;
  }
  server_ = std::move(*server);
  link_ = std::make_unique<ServerLink>(session_, link_params_, server_.get());
  confirmed_session_.assign(static_cast<std::size_t>(robots_), 0);
  MissionTrafficParams traffic_params;
  traffic_params.max_robots = static_cast<std::size_t>(robots_);
  traffic_ = std::make_unique<MissionTraffic>(traffic_params);
  start_us_ = platform::MonotonicUs();
  if (Status st = platform::StartExchangeRounds(o_.out_dir + "/exchange_rounds.tsv", robots_); !st.ok()) {
    std::fprintf(stderr, "%s: %s\n", kTag, st.message().c_str());
    return kExitFailure;
  }
  auto bus = o_.replay ? platform::OpenLcmBus(bus_params_, {platform::kKeyframesChannel, platform::kPosesChannel,
                                                            platform::kScansChannel, platform::kMergeResultChannel,
                                                            platform::kPolicyChannel, platform::kRoundChannel})
                       : platform::OpenLcmBus(bus_params_, {platform::kKeyframesChannel, platform::kPosesChannel,
                                                            platform::kScansChannel, platform::kRobotStatusChannel});
  if (!bus.ok()) {
    std::fprintf(stderr, "%s: %s\n", kTag, bus.status().message().c_str());
    return kExitFailure;
  }
  bus_ = std::move(*bus);
  InstallStopSignalHandlers();
  if (!o_.quiet) {
    std::fprintf(stderr, "%s: session %lld, robots 0..%d, mode %s, %s, writing to %s%s\n", kTag,
                 static_cast<long long>(session_), robots_ - 1, ExchangeModeName(mode_),
                 CascadeSettingsText(server_params_).c_str(), o_.out_dir.c_str(),
                 o_.replay ? " (replay: rounds run at the recorded round steps)" : "");
  }
  if (!o_.quiet || !bus_params_.authenticate) {
    std::fprintf(stderr, "%s: %s\n", kTag, AuthDescription(o_.auth, bus_params_).c_str());
  }
  last_recorded_us_ = platform::MonotonicUs();
  const std::int64_t start_us = platform::MonotonicUs();
  std::int64_t next_status_us = start_us;
  // After --exit-when-merged is met the server lingers: it keeps answering and re-sends the result every second
  // until every placed robot's status said "merged" (its current session), at most --linger-s.
  std::int64_t lingering_since_us = -1, next_result_us = 0;
  std::vector<ServerOutgoing> out;
  platform::BusMessage message;
  while (StopSignalCount() == 0) {
    if (Status st = bus_->Poll(10); !st.ok()) {
      std::fprintf(stderr, "%s: %s\n", kTag, st.message().c_str());
      return kExitFailure;
    }
    const std::int64_t wall = platform::WallTimeUs();
    while (bus_->Take(&message)) {
      Received received;
      const Status st = HandleMessage(message, wall, &received);
      last_recorded_us_ = platform::MonotonicUs();
      if (!(st.ok() && received.queued)) Account(message, st, received);  // a queued one: when a step takes it
    }
    out.clear();
    if (Status st = link_->Poll(wall, &out); !st.ok()) {
      std::fprintf(stderr, "%s: merge round failed: %s\n", kTag, st.message().c_str());
    }
    SayIncomparablePairs();
    for (const ServerOutgoing& o_msg : out) Publish(o_msg);
    const std::int64_t now = platform::MonotonicUs();
    // Done when enough robots are placed and the round behind it saw every keyframe delivered (the robots went
    // quiet): an early round on part of the data does not end the mission.
    const bool done = o_.exit_when_merged > 0 && InWorld() >= o_.exit_when_merged && link_->Settled(wall) &&
                      (!o_.replay || static_cast<double>(now - last_recorded_us_) > o_.round_quiet_s * 1e6);
    const bool entering_linger = done && lingering_since_us < 0;
    if (entering_linger) lingering_since_us = now;
    if (lingering_since_us >= 0 && now >= next_result_us && link_->rounds_merged() > 0) {
      next_result_us = now + 1000000;
      if (platform::EncodeMergeResult(link_->last_result(), &buffer_).ok()) {
        (void)bus_->Publish(platform::kMergeResultChannel, buffer_);
      }
    }
    if (now >= next_status_us || entering_linger) {
      next_status_us = now + 1000000;
      PublishStatus(wall);
    }
    if (lingering_since_us >= 0 &&
        (PlacedRobotsConfirmed() || static_cast<double>(now - lingering_since_us) >= o_.linger_s * 1e6)) {
      break;
    }
    if (lingering_since_us < 0 && o_.max_runtime_s > 0.0 && static_cast<double>(now - start_us) > o_.max_runtime_s * 1e6) {
      return Finish(kExitFailure);
    }
  }
  return Finish(kExitOk);
}

// The exit summary: rounds, robots placed and confirmed, delivery digests per robot, authentication, memory.
int ServerProcess::Finish(int exit_code) {
  if (o_.replay) {
    // What no recorded step took still belongs to the robots' data (the digests below).
    const std::size_t unused = replay_queue_.size();
    ApplyQueued({}, true, platform::WallTimeUs());
    if (replay_mode_ == ReplayMode::kSteps) {
      std::printf("server: replay followed %lld round steps of recording server session %lld: %lld differed; %lld "
                  "recorded merge results compared, %lld differed (largest T_world_map difference %.6f); %zu robot "
                  "messages after the last step, %lld handed over early; %lld steps after a restart of the "
                  "recording server (approximate)\n",
                  static_cast<long long>(steps_followed_), static_cast<long long>(followed_session_),
                  static_cast<long long>(step_mismatches_), static_cast<long long>(results_compared_),
                  static_cast<long long>(result_mismatches_), largest_result_difference_, unused,
                  static_cast<long long>(replay_overflow_), static_cast<long long>(steps_after_restart_));
      if (step_mismatches_ + result_mismatches_ > 0) exit_code = kExitFailure;
    } else {
      std::printf("server: replay without round steps: rounds began at the recorded scan requests (may differ "
                  "from the recording)\n");
    }
  }
  int confirmed = 0;
  for (int r = 0; r < robots_; ++r) {
    confirmed += confirmed_session_[static_cast<std::size_t>(r)] != 0 &&
                 confirmed_session_[static_cast<std::size_t>(r)] == link_->robot_session(r);
  }
  std::printf("server: %d merge rounds, %d of %zu robots in the world frame, %d confirmed it; %lld bytes received; "
              "%lld messages rejected%s%s\n",
              link_->rounds_merged(), InWorld(), link_->last_result().robot_ids.size(), confirmed,
              static_cast<long long>(traffic_->Total()),
              static_cast<long long>(rejected_ + static_cast<std::int64_t>(AuthRejected(*bus_))),
              last_rejection_.empty() ? "" : "; last: ", last_rejection_.c_str());
  for (int r = 0; r < robots_; ++r) {
    if (link_->robot_session(r) == 0) continue;
    std::printf("server: robot %d session %lld: %s\n", r, static_cast<long long>(link_->robot_session(r)),
                ServerDeliveryDigest(server_->robot(r)).ToText().c_str());
  }
  WriteExchangeSummary();
  std::printf("server %s\n", AuthSummary(*bus_).c_str());
  std::printf("%s\n", PeakRssLine().c_str());
  std::fprintf(stderr, "%s", MemorySummary(setup_.table, MemoryUse(), platform::ReadRss().peak_bytes).c_str());
  if (o_.exit_when_merged > 0 && InWorld() < o_.exit_when_merged) exit_code = kExitFailure;
  return exit_code;
}

int RunServer(const ServerOptions& o) {
  ServerProcess process(o);
  if (int rc = process.Configure(); rc != kExitOk || process.checked()) return rc;
  return process.Run();
}

}  // namespace

Command AddServerCommand(CLI::App& root) {
  auto o = std::make_shared<ServerOptions>();
  CLI::App* cmd = root.add_subcommand("server", "the merge server process on LCM: collect descriptors, request the "
                                                "few scans the cascade selects, register, publish the merge");
  cmd->add_option("--out", o->out_dir, "output directory (transforms.txt, trajectories/, merged_map.pcd/.ply, a row of "
                                       "exchange_rounds.tsv and exchange_bytes.png after every round; "
                                       "exchange_summary.tsv at exit)")->capture_default_str();
  cmd->add_option("--mode", o->mode, "exchange mode: send-all, A, A+B, A+C, A+B+C")->capture_default_str();
  cmd->add_option("--lcm-url", o->lcm_url, "LCM provider URL (default: LCM_DEFAULT_URL)");
  cmd->add_option("--lidar", o->lidar, "the robots' --lidar preset (hdl-64e, vlp-16, os1-64, os1-128, os2-128, os0-128, avia, "
                  "aeva): a forward-looking sensor's field of view limits which keyframes see one scene "
                  "(--max-colocated-chance)")->capture_default_str();
  cmd->add_option("--descriptor", o->descriptor,
                  "the robots' --descriptor: ring and solid send 92-byte records of 40 values, scan-context 1226-byte "
                  "Scan Context records compared by the Scan Context distance; batches of the other kind are "
                  "refused and counted")
      ->check(CLI::IsMember({"ring", "solid", "scan-context"}))
      ->capture_default_str();
  cmd->add_option("--round-interval-s", o->round_interval_s, "merge rounds start at most this often [s]")
      ->capture_default_str();
  cmd->add_option("--round-quiet-s", o->round_quiet_s, "start a round when new keyframes arrived and the robots "
                                                       "were quiet this long [s]")->capture_default_str();
  cmd->add_option("--round-min-new-keyframes", o->round_min_new_keyframes,
                  "start a round when this many keyframes arrived since the last")->capture_default_str();
  cmd->add_option("--request-timeout-s", o->request_timeout_s, "merge with what arrived after this [s]")
      ->capture_default_str();
  AddMergeFlags(cmd, &o->server, &o->profile);
  cmd->add_flag("--every-round", o->every_round,
                "register every pair every round, also pairs earlier rounds verified (off: a verified pair costs no "
                "scans until its overlap's poses move, a new overlap can check it, it is rejected or a robot "
                "restarts)");
  cmd->add_option("--recheck-moved-m", o->exchange.moved_m,
                  "a verified pair is registered again when a keyframe of its overlap moved more than this [m]")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  cmd->add_option("--recheck-moved-deg", o->exchange.moved_deg,
                  "... or turned more than this [deg]")->check(CLI::Range(0.0, 180.0))->capture_default_str();
  cmd->add_option("--new-overlap-m", o->exchange.new_overlap_m,
                  "a selection this far from every place a pair was registered at is a new overlap [m] (registered "
                  "for a pair nothing else checks, or a pair not verified yet)")
      ->check(CLI::Range(0.0, 100000.0))
      ->capture_default_str();
  cmd->add_option("--max-tried-places", o->exchange.max_tried_regions,
                  "places a pair between placed robots is registered at, at most")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cmd->add_option("--exit-when-merged", o->exit_when_merged, "exit 0 once this many robots are in the world frame "
                  "and the last round saw every keyframe delivered (the robots went quiet for --round-quiet-s)");
  cmd->add_option("--max-runtime-s", o->max_runtime_s, "give up (exit 1) after this long [s] (0 = never)");
  cmd->add_option("--linger-s", o->linger_s, "after --exit-when-merged is met, keep answering and re-send the "
                                           "result every second until every placed robot reported \"merged\", at "
                                           "most this long [s]")->check(CLI::Range(0.0, 3600.0))->capture_default_str();
  cmd->add_flag("--replay", o->replay, "serve a mission recorded with `commerge record` and played back with "
                                       "lcm-logplayer: every recorded round step runs again on exactly the robots' "
                                       "messages the recording server had taken, and is checked against it (exit 1 "
                                       "on a difference)");
  cmd->add_flag("--quiet", o->quiet, "no progress lines on stderr");
  AddAuthFlags(cmd, &o->auth);
  AddFaultFlags(cmd, &o->delay_ms, &o->jitter_ms, &o->duplicate_pct);
  AddMemoryFlags(cmd, &o->memory);
  return {cmd, [o, cmd]() {
            if (Status st = ApplyMergeProfile(*cmd, o->profile, o->lidar, &o->server); !st.ok()) {
              std::fprintf(stderr, "commerge server: %s\n", st.message().c_str());
              return static_cast<int>(kExitUsage);
            }
            if (cmd->count("--descriptor") == 0) o->descriptor = ProfileDescriptor(o->profile, o->descriptor);
            ApplySensorTauInter(cmd->count("--tau-inter") > 0, o->lidar, &o->server);
            return RunServer(*o);
          }};
}

}  // namespace commerge::app
