// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/server_link.hpp"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <utility>

namespace commerge {

namespace {

bool Elapsed(std::int64_t since_us, std::int64_t now_us, double seconds) {
  return since_us < 0 || static_cast<double>(now_us - since_us) >= seconds * 1e6;
}

}  // namespace

Status ValidateServerLinkParams(const ServerLinkParams& params) {
  const std::pair<const char*, double> positive[] = {{"status_interval_s", params.status_interval_s},
                                                     {"policy_repeat_s", params.policy_repeat_s},
                                                     {"request_timeout_s", params.request_timeout_s}};
  for (const auto& [name, value] : positive) {
    if (!(value > 0.0) || !std::isfinite(value)) {
      return InvalidArgument(std::string(name) + " = " + std::to_string(value) + " must be finite and > 0");
    }
  }
  const std::pair<const char*, double> non_negative[] = {{"round_interval_s", params.round_interval_s},
                                                         {"round_quiet_s", params.round_quiet_s}};
  for (const auto& [name, value] : non_negative) {
    if (!(value >= 0.0) || !std::isfinite(value)) {
      return InvalidArgument(std::string(name) + " = " + std::to_string(value) + " must be finite and >= 0");
    }
  }
  return ValidatePairExchangeParams(params.exchange);
}

ServerLink::ServerLink(std::int64_t session, const ServerLinkParams& params, MergeServer* server)
    : session_(session),
      params_(params),
      params_status_(ValidateServerLinkParams(params)),
      server_(server),
      merge_round_(server, MergeRoundParams{params.mode, /*run_cascades=*/true, params.exchange}) {
  if (params_status_.ok() && session <= 0) {
    params_status_ = InvalidArgument("session id " + std::to_string(session) + " must be > 0");
  }
  robots_.resize(static_cast<std::size_t>(std::max(0, server->max_robots())));
  for (RobotState& r : robots_) r.request.request_id = -1;
  taken_.resize(robots_.size());
  for (std::size_t r = 0; r < taken_.size(); ++r) taken_[r].robot_id = static_cast<int>(r);
  last_result_.server_session = session;
}

Status ServerLink::Refuse(Status status) {
  ++stats_.stale_messages;
  stats_.last_rejection = status.message();
  return status;
}

std::int64_t ServerLink::robot_session(int robot) const {
  return robot >= 0 && robot < static_cast<int>(robots_.size()) ? robots_[static_cast<std::size_t>(robot)].session : 0;
}

void ServerLink::OnRobotLeft(int robot_id, std::int64_t session) {
  if (robot_id < 0 || robot_id >= static_cast<int>(robots_.size())) return;
  RobotState& r = robots_[static_cast<std::size_t>(robot_id)];
  if (session <= 0 || session != r.session || r.left_session == session) return;
  r.left_session = session;
  if (r.request.request_id >= 0 && !r.request_complete) {  // withdrawn: the round stops waiting for it
    r.request = ScanRequest();
    r.request.request_id = -1;
  }
}

bool ServerLink::robot_left(int robot) const {
  if (robot < 0 || robot >= static_cast<int>(robots_.size())) return false;
  const RobotState& r = robots_[static_cast<std::size_t>(robot)];
  return r.left_session != 0 && r.left_session == r.session;
}


Status ServerLink::CheckSession(int robot_id, std::int64_t session, const char* what) {
  if (robot_id < 0 || robot_id >= static_cast<int>(robots_.size())) return Status::Ok();  // MergeServer refuses it
  if (session <= 0) {
    return Refuse(InvalidArgument(std::string(what) + " of robot " + std::to_string(robot_id) + ": session " +
                                  std::to_string(session) + " must be > 0"));
  }
  RobotState& r = robots_[static_cast<std::size_t>(robot_id)];
  if (session < r.session) {
    return Refuse(InvalidArgument(std::string(what) + " of robot " + std::to_string(robot_id) + ": session " +
                                  std::to_string(session) + " is older than the current " +
                                  std::to_string(r.session) + " (a message from before the robot restarted)"));
  }
  if (session > r.session) {
    if (r.session != 0) {
      ++stats_.robot_restarts;
      // Its keyframes count as new again, so a round starts once the new session's keyframes are in (they may
      // be no more than the old session delivered).
      const std::size_t dropped = DeliveredKeyframes(robot_id);
      delivered_at_last_round_ -= std::min(dropped, delivered_at_last_round_);
      server_->ResetRobot(robot_id);
      // The restarted robot maps in a new frame: its placement is void until a round merges it again. Robot 0's
      // map is the world frame, so its restart voids everybody else's placement.
      for (std::size_t i = 0; i < last_result_.robot_ids.size(); ++i) {
        const int id = last_result_.robot_ids[i];
        if (id == robot_id ? id != 0 : robot_id == 0) {
          last_result_.in_world[i] = 0;
          last_result_.T_world_map[i] = Eigen::Isometry3d::Identity();
        }
        if (id == robot_id && i < last_result_.keyframes.size()) last_result_.keyframes[i] = 0;
      }
    }
    r = RobotState();
    r.session = session;
    r.request.request_id = -1;
  }
  return Status::Ok();
}

void ServerLink::CountTaken(int robot_id, RobotMessageKind kind, std::initializer_list<std::int64_t> ids) {
  if (robot_id < 0 || robot_id >= static_cast<int>(taken_.size())) return;
  RoundRobotInput& t = taken_[static_cast<std::size_t>(robot_id)];
  const auto mix = [&t](std::uint64_t value) {  // FNV-1a, byte by byte
    for (int b = 0; b < 8; ++b, value >>= 8) {
      t.digest = (t.digest ^ static_cast<std::uint32_t>(value & 0xffu)) * 16777619u;
    }
  };
  mix(static_cast<std::uint64_t>(kind));
  for (std::int64_t id : ids) mix(static_cast<std::uint64_t>(id));
  switch (kind) {
    case RobotMessageKind::kKeyframeBatch: ++t.keyframe_batches; break;
    case RobotMessageKind::kPoseUpdate: ++t.pose_updates; break;
    case RobotMessageKind::kScanChunk: ++t.scan_chunks; break;
  }
}

std::vector<RoundRobotInput> ServerLink::TakenInputs() const {
  std::vector<RoundRobotInput> inputs = taken_;
  for (std::size_t r = 0; r < inputs.size(); ++r) {
    inputs[r].session = robots_[r].session;
    inputs[r].left = robot_left(static_cast<int>(r));
  }
  return inputs;
}

void ServerLink::FollowRecordedRequests() noexcept {
  params_.follow_recorded_steps = false;
  params_.accept_unrequested_scans = true;
}

Status ServerLink::OnKeyframeBatch(const KeyframeBatch& batch, std::int64_t now_us) {
  if (!params_status_.ok()) return params_status_;
  CountTaken(batch.robot_id, RobotMessageKind::kKeyframeBatch, {batch.session, batch.sequence});
  if (batch.robot_id >= 0 && batch.robot_id < static_cast<int>(robots_.size()) && batch.session > 0 &&
      batch.session > robot_session(batch.robot_id) && !server_->CheckKeyframeBatch(batch).ok()) {
    // Validate before a new session resets anything: a batch without one usable record must not wipe a robot's
    // keyframes (nor lock its real session out as stale).
    return server_->OnKeyframeBatch(batch);  // refused and counted there
  }
  if (Status st = CheckSession(batch.robot_id, batch.session, "keyframe batch"); !st.ok()) return st;
  last_message_us_ = now_us;
  return server_->OnKeyframeBatch(batch);
}

Status ServerLink::OnPoseUpdate(const PoseUpdate& update, std::int64_t now_us) {
  if (!params_status_.ok()) return params_status_;
  CountTaken(update.robot_id, RobotMessageKind::kPoseUpdate, {update.session, update.sequence});
  if (update.robot_id >= 0 && update.robot_id < static_cast<int>(robots_.size()) && update.session > 0 &&
      update.session > robot_session(update.robot_id) && !server_->CheckPoseUpdate(update).ok()) {
    return server_->OnPoseUpdate(update);  // refused and counted there, before a new session resets anything
  }
  if (Status st = CheckSession(update.robot_id, update.session, "pose update"); !st.ok()) return st;
  last_message_us_ = now_us;
  Status st = server_->OnPoseUpdate(update);
  if (st.ok()) {
    std::deque<std::int32_t>& acks = robots_[static_cast<std::size_t>(update.robot_id)].pose_acks;
    acks.push_back(update.sequence);
    while (acks.size() > kMaxStatusPoseAcks) acks.pop_front();
  }
  return st;
}

Status ServerLink::OnScanChunk(const ScanChunk& chunk, std::int64_t now_us) {
  if (!params_status_.ok()) return params_status_;
  CountTaken(chunk.robot_id, RobotMessageKind::kScanChunk, {chunk.request_id, chunk.keyframe, chunk.chunk_index});
  if (chunk.robot_id < 0 || chunk.robot_id >= static_cast<int>(robots_.size())) return server_->OnScanChunk(chunk);
  const RobotState& r = robots_[static_cast<std::size_t>(chunk.robot_id)];
  if (params_.accept_unrequested_scans && r.session != 0) {
    last_message_us_ = now_us;
    return server_->OnScanChunk(chunk);
  }
  if (r.request.request_id < 0 || chunk.request_id != r.request.request_id ||
      !std::binary_search(r.request.keyframes.begin(), r.request.keyframes.end(), chunk.keyframe)) {
    return Refuse(InvalidArgument("scan chunk of robot " + std::to_string(chunk.robot_id) + " keyframe " +
                                  std::to_string(chunk.keyframe) + " for request " +
                                  std::to_string(chunk.request_id) + ": not part of the active request " +
                                  std::to_string(r.request.request_id)));
  }
  last_message_us_ = now_us;
  return server_->OnScanChunk(chunk);
}

bool ServerLink::RequestComplete(int robot) const {
  const RobotState& r = robots_[static_cast<std::size_t>(robot)];
  for (std::uint32_t k : r.request.keyframes) {
    if (!server_->has_scan(robot, k)) return false;
  }
  return true;
}

void ServerLink::AppendRobotStatus(ServerStatus* status) const {
  for (int r = 0; r < static_cast<int>(robots_.size()); ++r) {
    if (robot_session(r) == 0) continue;
    const RobotKeyframeDb& db = server_->robot(r);
    std::uint32_t scans = 0;
    for (std::size_t k = 0; k < db.size(); ++k) scans += server_->has_scan(r, static_cast<std::uint32_t>(k)) ? 1 : 0;
    status->robot_ids.push_back(r);
    status->keyframes.push_back(static_cast<std::uint32_t>(db.size()));
    status->scans.push_back(scans);
    status->chunks_missing.push_back(static_cast<std::uint32_t>(chunks_missing(r)));
    status->descriptor_ids.push_back(db.descriptor_id);
  }
}

std::size_t ServerLink::chunks_missing(int robot) const {
  if (robot < 0 || robot >= static_cast<int>(robots_.size())) return 0;
  const RobotState& r = robots_[static_cast<std::size_t>(robot)];
  if (r.request.request_id < 0) return 0;
  std::size_t missing = 0;
  for (std::uint32_t k : r.request.keyframes) {
    if (server_->has_scan(robot, k)) continue;
    std::uint16_t n = 0;
    const std::vector<std::uint8_t>* have = nullptr;
    if (server_->PartialScan(robot, k, &n, &have)) {
      missing += static_cast<std::size_t>(std::count(have->begin(), have->end(), 0));
    } else {
      ++missing;  // its chunk count is unknown until one arrives: counted as one
    }
  }
  return missing;
}

TransferStatus ServerLink::MakeStatus(int robot, std::int64_t now_us) const {
  TransferStatus s;
  s.utime_us = now_us;
  s.robot_id = robot;
  s.server_session = session_;
  if (robot < 0 || robot >= static_cast<int>(robots_.size())) return s;
  const RobotState& r = robots_[static_cast<std::size_t>(robot)];
  s.robot_session = r.session;
  const RobotKeyframeDb& db = server_->robot(robot);
  const std::size_t n = db.size();
  s.keyframes_seen = static_cast<std::uint32_t>(n);
  std::size_t k = 0;
  while (k < n && db.delivered(k)) ++k;
  s.keyframes_contiguous = static_cast<std::uint32_t>(k);
  while (k < n) {
    const std::size_t begin = k;
    while (k < n && !db.delivered(k)) ++k;
    if (s.gaps.size() == kMaxStatusGaps) {
      s.gaps_truncated = true;
      break;
    }
    s.gaps.push_back(KeyframeGap{static_cast<std::uint32_t>(begin), static_cast<std::uint32_t>(k)});
    while (k < n && db.delivered(k)) ++k;
  }
  s.pose_sequences.assign(r.pose_acks.begin(), r.pose_acks.end());
  s.request_id = r.request.request_id;
  if (r.request.request_id < 0) return s;
  s.request_complete = true;
  for (std::uint32_t kf : r.request.keyframes) {
    if (server_->has_scan(robot, kf)) continue;
    s.request_complete = false;
    std::uint16_t num_chunks = 0;
    const std::vector<std::uint8_t>* have = nullptr;
    if (!server_->PartialScan(robot, kf, &num_chunks, &have)) {
      if (s.missing.size() == kMaxStatusMissingRanges) break;
      s.missing.push_back(MissingChunkRange{kf, 0, 0});
      continue;
    }
    for (std::size_t c = 0; c < num_chunks;) {
      if ((*have)[c]) {
        ++c;
        continue;
      }
      const std::size_t first = c;
      while (c < num_chunks && !(*have)[c]) ++c;
      if (s.missing.size() == kMaxStatusMissingRanges) break;
      s.missing.push_back(MissingChunkRange{kf, static_cast<std::uint16_t>(first), static_cast<std::uint16_t>(c - first)});
    }
    if (s.missing.size() == kMaxStatusMissingRanges) break;
  }
  return s;
}

std::size_t ServerLink::DeliveredKeyframes(int only_robot) const {
  std::size_t n = 0;
  for (int r = 0; r < server_->max_robots(); ++r) {
    if (only_robot >= 0 && r != only_robot) continue;
    const RobotKeyframeDb& db = server_->robot(r);
    for (std::size_t k = 0; k < db.size(); ++k) n += db.delivered(k) ? 1 : 0;
  }
  return n;
}

Status ServerLink::StartRound(std::int64_t now_us, std::vector<ServerOutgoing>* out) {
  const std::size_t first = out->size();
  ++stats_.rounds_started;
  round_requested_ = false;
  last_round_us_ = now_us;
  delivered_at_last_round_ = DeliveredKeyframes();
  round_keyframes_.assign(robots_.size(), 0);
  std::vector<std::int64_t> sessions(robots_.size(), 0);
  for (int r = 0; r < static_cast<int>(robots_.size()); ++r) {
    round_keyframes_[static_cast<std::size_t>(r)] = static_cast<std::uint32_t>(DeliveredKeyframes(r));
    sessions[static_cast<std::size_t>(r)] = robots_[static_cast<std::size_t>(r)].session;
  }
  if (Status st = merge_round_.Begin(Span<const std::int64_t>(sessions), &round_requests_); !st.ok()) return st;
  round_active_ = true;
  round_start_us_ = now_us;
  round_step_ = 0;
  // A round whose scans are all held (or whose robots all left) continues at the next Poll.
  SendRequests(round_requests_, now_us, out);
  EmitStep(round_ + 1, 0, false, first, now_us, out);
  return Status::Ok();
}

void ServerLink::EmitStep(int round, int step, bool finished, std::size_t first, std::int64_t now_us,
                          std::vector<ServerOutgoing>* out) const {
  ServerOutgoing o;
  o.kind = ServerOutgoing::Kind::kRoundStep;
  o.step.utime_us = now_us;
  o.step.server_session = session_;
  o.step.round = round;
  o.step.step = step;
  o.step.finished = finished;
  o.step.robots = TakenInputs();
  for (std::size_t i = first; i < out->size(); ++i) {
    if ((*out)[i].kind != ServerOutgoing::Kind::kScanRequest) continue;
    ScanRequest q = (*out)[i].request;
    q.utime_us = 0;
    o.step.requests.push_back(std::move(q));
  }
  out->insert(out->begin() + static_cast<std::ptrdiff_t>(first), std::move(o));
}

Status ServerLink::FollowStep(const RoundStep& recorded, std::int64_t now_us, std::vector<ServerOutgoing>* out) {
  if (!params_status_.ok()) return params_status_;
  for (const RoundRobotInput& r : recorded.robots) {
    if (r.left) OnRobotLeft(r.robot_id, robot_session(r.robot_id));
  }
  const std::size_t first = out->size();
  std::string before;
  if (recorded.step == 0) {
    if (round_active_) {
      before = "round " + std::to_string(recorded.round) + " began in the recording while round " +
               std::to_string(round_ + 1) + " here still waited for scans; ";
    }
    Status st = StartRound(now_us, out);
    if (!st.ok()) {
      round_active_ = false;
      return st;
    }
  } else {
    if (!round_active_) {
      return DataLoss("round " + std::to_string(recorded.round) + " step " + std::to_string(recorded.step) +
                      ": the recording continued a round, but no round waits here");
    }
    if (Status st = ContinueRound(now_us, out); !st.ok()) return st;
  }
  const RoundStep* mine = nullptr;
  for (std::size_t i = first; i < out->size() && mine == nullptr; ++i) {
    if ((*out)[i].kind == ServerOutgoing::Kind::kRoundStep) mine = &(*out)[i].step;
  }
  const std::string mismatch = mine != nullptr ? RoundStepMismatch(recorded, *mine) : "no step ran";
  if (before.empty() && mismatch.empty()) return Status::Ok();
  return DataLoss(before + mismatch);
}

std::size_t ServerLink::SendRequests(const std::vector<ScanRequest>& requests, std::int64_t now_us,
                                     std::vector<ServerOutgoing>* out) {
  std::size_t sent = 0;
  for (const ScanRequest& planned : requests) {
    if (robot_left(planned.robot_id)) continue;  // it sends nothing any more: the round uses the scans held
    RobotState& r = robots_[static_cast<std::size_t>(planned.robot_id)];
    r.request = planned;
    r.request.utime_us = now_us;
    r.request.server_session = session_;
    r.request_complete = false;
    r.last_policy_us = now_us;
    ServerOutgoing o;
    o.kind = ServerOutgoing::Kind::kScanRequest;
    o.request = r.request;
    out->push_back(std::move(o));
    ++stats_.policies;
    ++sent;
  }
  return sent;
}

void ServerLink::WithdrawIncompleteRequests() {
  for (RobotState& r : robots_) {
    // A complete request stays (the status keeps saying so); an incomplete one is withdrawn, so the robot stops
    // sending once its status shows no request.
    if (r.request.request_id >= 0 && !r.request_complete) {
      r.request = ScanRequest();
      r.request.request_id = -1;
    }
  }
}

Status ServerLink::ContinueRound(std::int64_t now_us, std::vector<ServerOutgoing>* out) {
  const std::size_t first = out->size();
  const int step = ++round_step_;
  round_active_ = false;
  WithdrawIncompleteRequests();
  while (true) {
    auto done = merge_round_.Continue(&round_requests_);
    stats_.widened_pairs = merge_round_.widened_selections();
    if (!done.ok()) return done.status();
    if (*done) break;
    if (SendRequests(round_requests_, now_us, out) > 0) {  // wait for the extra scans
      round_active_ = true;
      round_start_us_ = now_us;
      EmitStep(round_ + 1, step, false, first, now_us, out);
      return Status::Ok();
    }
  }
  const MergeRoundResult& round = merge_round_.result();
  if (!round.frames_ok) return InvalidArgument("frame solver: " + round.frames_error);
  ++round_;
  ++stats_.rounds_merged;
  std::vector<int> ids;
  std::vector<std::uint32_t> keyframes;
  for (int r = 0; r < server_->max_robots(); ++r) {
    if (robots_[static_cast<std::size_t>(r)].session == 0) continue;
    ids.push_back(r);
    keyframes.push_back(static_cast<std::size_t>(r) < round_keyframes_.size() ? round_keyframes_[static_cast<std::size_t>(r)] : 0);
  }
  last_result_ = MakeMergeResultMessage(round, *server_, Span<const int>(ids), Span<const std::uint32_t>(keyframes),
                                        session_, now_us);
  last_result_.round = round_;
  EmitStep(round_, step, true, first, now_us, out);
  ServerOutgoing o;
  o.kind = ServerOutgoing::Kind::kMergeResult;
  o.result = last_result_;
  out->push_back(std::move(o));
  return Status::Ok();
}

bool ServerLink::Settled(std::int64_t now_us) const {
  // Also with rounds on request (a replay): keyframes that arrived after the last round keep it unsettled until a
  // round has seen them, so a replay does not end at a recording's early round while the log still plays.
  return round_ > 0 && !round_active_ && !round_requested_ && Elapsed(last_message_us_, now_us, params_.round_quiet_s) &&
         DeliveredKeyframes() == delivered_at_last_round_;
}

// Continues an active round whose scans are complete (or timed out), or starts one when it is due; `worked`: it did.
Status ServerLink::AdvanceRound(std::int64_t now_us, std::vector<ServerOutgoing>* out, bool* worked) {
  *worked = false;
  if (round_active_) {
    bool complete = true;
    for (int r = 0; r < static_cast<int>(robots_.size()); ++r) {
      RobotState& state = robots_[static_cast<std::size_t>(r)];
      if (state.request.request_id < 0 || state.request_complete) continue;
      state.request_complete = RequestComplete(r);
      complete = complete && state.request_complete;
    }
    const bool timed_out = Elapsed(round_start_us_, now_us, params_.request_timeout_s);
    if (!params_.follow_recorded_steps && (complete || timed_out)) {
      if (!complete) ++stats_.rounds_timed_out;
      *worked = true;
      if (Status st = ContinueRound(now_us, out); !st.ok()) return st;
    }
  } else {
    // Counting the delivered keyframes walks every database: only when a round could start.
    bool start = false;
    const bool requested = round_requested_ && !params_.follow_recorded_steps;
    if (requested || (params_.automatic_rounds && Elapsed(last_round_us_, now_us, params_.round_interval_s) &&
                      Elapsed(last_round_check_us_, now_us, params_.status_interval_s))) {
      last_round_check_us_ = now_us;
      const std::size_t delivered = DeliveredKeyframes();
      const std::size_t fresh = delivered > delivered_at_last_round_ ? delivered - delivered_at_last_round_ : 0;
      start = (round_requested_ && delivered > 0) ||
              (params_.automatic_rounds && fresh > 0 &&
               (fresh >= params_.round_min_new_keyframes || Elapsed(last_message_us_, now_us, params_.round_quiet_s)));
    }
    if (start) {
      *worked = true;
      Status st = StartRound(now_us, out);
      if (!st.ok()) {
        round_active_ = false;
        return st;
      }
    }
  }
  return Status::Ok();
}

Status ServerLink::Poll(std::int64_t now_us, std::vector<ServerOutgoing>* out) {
  if (!params_status_.ok()) return params_status_;
  // Round bookkeeping first, so the statuses below already show a new or finished request; but after a Poll with
  // round work, due statuses go out first (rounds back to back would otherwise never let one out).
  bool status_due = false;
  for (const RobotState& state : robots_) {
    status_due = status_due || (state.session != 0 && Elapsed(state.last_status_us, now_us, params_.status_interval_s));
  }
  const bool statuses_first = statuses_owed_ && status_due;
  statuses_owed_ = false;
  bool round_work = false;
  if (!statuses_first) {
    if (Status st = AdvanceRound(now_us, out, &round_work); !st.ok()) return st;
  }
  for (int r = 0; r < static_cast<int>(robots_.size()); ++r) {
    RobotState& state = robots_[static_cast<std::size_t>(r)];
    if (state.session == 0) continue;
    if (state.request.request_id >= 0 && !state.request_complete &&
        Elapsed(state.last_policy_us, now_us, params_.policy_repeat_s)) {
      state.last_policy_us = now_us;
      ServerOutgoing o;
      o.kind = ServerOutgoing::Kind::kScanRequest;
      o.request = state.request;
      o.request.utime_us = now_us;
      out->push_back(std::move(o));
      ++stats_.policies;
    }
    // After round work (seconds of registration) the robots' messages of that time still wait in the caller's
    // queue: a status now would show their keyframes missing and make the robots send them again. The next Poll,
    // after the caller took them, sends it.
    if (!round_work && Elapsed(state.last_status_us, now_us, params_.status_interval_s)) {
      state.last_status_us = now_us;
      ServerOutgoing o;
      o.kind = ServerOutgoing::Kind::kTransferStatus;
      o.status = MakeStatus(r, now_us);
      out->push_back(std::move(o));
      ++stats_.statuses;
    }
  }
  statuses_owed_ = round_work;
  return Status::Ok();
}

std::string ServerLink::state() const {
  if (round_active_) {
    std::size_t missing = 0;
    for (int r = 0; r < static_cast<int>(robots_.size()); ++r) missing += chunks_missing(r);
    return "round " + std::to_string(round_ + 1) + ": waiting for scans (" + std::to_string(missing) + " chunks)";
  }
  if (round_ == 0) return "collecting keyframes";
  std::size_t in_world = 0;
  for (std::uint8_t w : last_result_.in_world) in_world += w;
  return "merged " + std::to_string(in_world) + "/" + std::to_string(last_result_.robot_ids.size()) +
         " robots (round " + std::to_string(round_) + ")";
}

}  // namespace commerge
