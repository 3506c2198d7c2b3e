// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/robot_link.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace commerge {

namespace {
constexpr std::uint32_t kToScanEnd = 0xFFFFu;  // Work::end: up to the scan's chunk count
}  // namespace

Status ValidateRobotLinkParams(const RobotLinkParams& params) {
  if (!(params.resend_timeout_s > 0.0) || !std::isfinite(params.resend_timeout_s)) {
    return InvalidArgument("resend_timeout_s = " + std::to_string(params.resend_timeout_s) + " must be > 0");
  }
  if (!(params.batch_delay_s >= 0.0) || !std::isfinite(params.batch_delay_s)) {
    return InvalidArgument("batch_delay_s = " + std::to_string(params.batch_delay_s) + " must be finite and >= 0");
  }
  if (params.max_pose_updates_in_flight < 1 || params.max_pose_updates_in_flight > 4096) {
    return InvalidArgument("max_pose_updates_in_flight = " + std::to_string(params.max_pose_updates_in_flight) +
                           " is outside 1..4096");
  }
  return Status::Ok();
}

RobotLink::RobotLink(std::int64_t session, const RobotLinkParams& params, RobotAgent* agent)
    : session_(session), params_(params), params_status_(ValidateRobotLinkParams(params)), agent_(agent) {
  if (params_status_.ok() && session <= 0) {
    params_status_ = InvalidArgument("session id " + std::to_string(session) + " must be > 0");
  }
  agent_->set_session(session);
  request_.request_id = -1;
}

bool RobotLink::Due(std::int64_t last_us, std::int64_t now_us) const {
  return last_us < 0 || static_cast<double>(now_us - last_us) >= params_.resend_timeout_s * 1e6;
}

std::size_t RobotLink::queued_chunks() const noexcept {
  std::size_t n = 0;
  for (const Work& w : work_) n += w.end == kToScanEnd ? 1 : w.end - w.next;
  return n;
}

void RobotLink::SeeServerSession(std::int64_t server_session) {
  // A restarted server lost our keyframes, poses and its requests: announce everything again.
  if (server_session_ != 0) {
    ++stats_.server_restarts;
    agent_->RequeueAllSent();
    in_flight_.clear();
    DropRequest();
  }
  server_session_ = server_session;
}

void RobotLink::DropRequest() {
  work_.clear();
  std::fill(slot_queued_.begin(), slot_queued_.end(), 0);
  request_poses_pending_ = false;
  request_done_ = true;
}

Status RobotLink::OnScanRequest(const ScanRequest& request, std::int64_t now_us) {
  (void)now_us;
  if (!params_status_.ok()) return params_status_;
  if (request.robot_id != agent_->robot_id()) {
    return InvalidArgument("scan request " + std::to_string(request.request_id) + " for robot " +
                           std::to_string(request.robot_id) + " reached robot " + std::to_string(agent_->robot_id()));
  }
  if (request.server_session < server_session_) return Status::Ok();  // from a server that has since restarted
  if (request.server_session > server_session_) {
    SeeServerSession(request.server_session);
    request_.request_id = -1;  // request ids restart with the server
  }
  if (request.request_id <= request_.request_id) return Status::Ok();  // a repeat, or an older one
  request_ = request;
  const std::size_t n = request_.keyframes.size();
  slot_sent_us_.assign(n, -1);
  slot_queued_.assign(n, 1);
  work_.clear();
  for (std::size_t i = 0; i < n; ++i) work_.push_back(Work{i, 0, kToScanEnd, false});
  request_poses_pending_ = true;
  request_done_ = false;
  ++stats_.requests;
  return Status::Ok();
}

void RobotLink::TrackPoses(const PoseUpdate& update, std::int64_t now_us) {
  in_flight_.push_back(InFlight{update.sequence, now_us, update.keyframes});
}

void RobotLink::ApplyKeyframeAcks(const TransferStatus& status, std::int64_t now_us) {
  const bool ours = status.robot_session == session_;
  const std::size_t sent = agent_->keyframes_sent();
  const std::size_t seen = ours ? status.keyframes_seen : 0;
  std::size_t held = seen;
  auto requeue = [&](std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < std::min(end, sent); ++k) {
      if (!Due(agent_->last_sent_us(k), now_us)) continue;
      agent_->RequeueKeyframe(k);
      ++stats_.keyframes_requeued;
    }
  };
  if (ours) {
    for (const KeyframeGap& g : status.gaps) {
      held -= std::min<std::size_t>(held, g.end - g.begin);
      requeue(g.begin, g.end);
    }
  }
  requeue(seen, sent);
  stats_.keyframes_acked = static_cast<std::uint32_t>(held);
}

void RobotLink::ApplyPoseAcks(const TransferStatus& status, std::int64_t now_us) {
  const bool ours = status.robot_session == session_;
  for (auto it = in_flight_.begin(); it != in_flight_.end();) {
    const bool acked = ours && std::find(status.pose_sequences.begin(), status.pose_sequences.end(), it->sequence) !=
                                   status.pose_sequences.end();
    if (acked) {
      it = in_flight_.erase(it);
    } else if (Due(it->sent_us, now_us)) {
      agent_->RequeuePoses(Span<const std::uint32_t>(it->keyframes));
      ++stats_.pose_updates_requeued;
      it = in_flight_.erase(it);
    } else {
      ++it;
    }
  }
}

void RobotLink::ApplyChunkAcks(const TransferStatus& status, std::int64_t now_us) {
  if (request_.request_id < 0 || request_done_) return;
  if (status.request_id == -1) {
    // The server no longer wants anything (it merged, or gave up on the round) - unless the status is older than
    // the request: a status delayed or reordered past the next round's policy (same server clock) says nothing
    // about that request. Dropping on it left the request unanswered until the server's request timeout.
    if (status.utime_us >= request_.utime_us) DropRequest();
    return;
  }
  if (status.request_id != request_.request_id) return;  // a newer request is on its way; or an old status
  if (status.request_complete) {
    DropRequest();
    ++stats_.requests_completed;
    return;
  }
  Work* last = nullptr;
  for (const MissingChunkRange& m : status.missing) {
    auto pos = std::lower_bound(request_.keyframes.begin(), request_.keyframes.end(), m.keyframe);
    if (pos == request_.keyframes.end() || *pos != m.keyframe) continue;
    const std::size_t slot = static_cast<std::size_t>(pos - request_.keyframes.begin());
    const std::uint32_t end = m.count == 0 ? kToScanEnd : static_cast<std::uint32_t>(m.first_chunk) + m.count;
    if (last != nullptr && last->slot == slot) {  // several ranges of one scan: one work item spanning them
      last->end = std::max(last->end, end);
      continue;
    }
    if (slot_queued_[slot] || !Due(slot_sent_us_[slot], now_us)) continue;
    work_.push_back(Work{slot, m.count == 0 ? 0u : m.first_chunk, end, true});
    slot_queued_[slot] = 1;
    last = &work_.back();
  }
}

Status RobotLink::OnTransferStatus(const TransferStatus& status, std::int64_t now_us) {
  if (!params_status_.ok()) return params_status_;
  if (status.robot_id != agent_->robot_id()) {
    ++stats_.foreign_statuses;
    return InvalidArgument("transfer status for robot " + std::to_string(status.robot_id) + " reached robot " +
                           std::to_string(agent_->robot_id()));
  }
  if (status.server_session < server_session_) {
    ++stats_.stale_statuses;
    return Status::Ok();
  }
  if (status.robot_session > session_) {
    ++stats_.foreign_statuses;
    return InvalidArgument("the server holds robot " + std::to_string(agent_->robot_id()) + " session " +
                           std::to_string(status.robot_session) + ", newer than this process's " +
                           std::to_string(session_) + ": another process uses this robot id");
  }
  if (status.server_session > server_session_) SeeServerSession(status.server_session);
  ++stats_.statuses;
  if (status.robot_session == session_) last_status_us_ = now_us;
  ApplyKeyframeAcks(status, now_us);
  ApplyPoseAcks(status, now_us);
  ApplyChunkAcks(status, now_us);
  return Status::Ok();
}

Result<bool> RobotLink::Next(std::int64_t now_us, RobotOutgoing* out) {
  if (!params_status_.ok()) return params_status_;
  if (request_poses_pending_) {
    request_poses_pending_ = false;
    if (agent_->TakeRequestPoses(request_, now_us, &out->poses, /*remember_poses=*/true)) {
      out->kind = RobotOutgoing::Kind::kPoseUpdate;
      out->resend = false;
      TrackPoses(out->poses, now_us);
      return true;
    }
  }
  // No status for three resend timeouts while keyframes wait for acknowledgement: announce one again, so a server
  // that never heard of this robot (every message lost) learns of it and starts sending statuses.
  const std::size_t sent = agent_->keyframes_sent();
  const double silence_us = 3.0 * params_.resend_timeout_s * 1e6;
  if (sent > stats_.keyframes_acked && agent_->queued_resends() == 0 &&
      (last_status_us_ < 0 || static_cast<double>(now_us - last_status_us_) >= silence_us)) {
    const std::size_t k = std::min<std::size_t>(stats_.keyframes_acked, sent - 1);
    if (static_cast<double>(now_us - agent_->last_sent_us(k)) >= silence_us) {
      agent_->RequeueKeyframe(k);
      ++stats_.keyframes_requeued;
    }
  }
  const bool resends = agent_->queued_resends() > 0;
  const std::size_t unsent = agent_->unsent_keyframes();
  if (unsent == 0) {
    unsent_since_us_ = -1;
  } else if (unsent_since_us_ < 0) {
    unsent_since_us_ = now_us;
  }
  const bool batch_due = resends || flush_ || unsent >= agent_->params().max_records_per_batch ||
                         (unsent > 0 && static_cast<double>(now_us - unsent_since_us_) >= params_.batch_delay_s * 1e6);
  if (batch_due) {
    auto batch = agent_->TakeKeyframeBatch(now_us, &out->batch);
    if (!batch.ok()) return batch.status();
    // What is left waits for its own batch (a full one goes at once).
    unsent_since_us_ = agent_->unsent_keyframes() == 0 ? -1 : now_us;
    if (*batch) {
      out->kind = RobotOutgoing::Kind::kKeyframeBatch;
      out->resend = resends;
      return true;
    }
  }
  if (in_flight_.size() < params_.max_pose_updates_in_flight && agent_->TakePoseUpdate(now_us, &out->poses)) {
    out->kind = RobotOutgoing::Kind::kPoseUpdate;
    out->resend = false;
    TrackPoses(out->poses, now_us);
    return true;
  }
  while (!work_.empty()) {
    Work& w = work_.front();
    const std::uint32_t k = request_.keyframes[w.slot];
    std::uint16_t num_chunks = 0;
    Status st = agent_->MakeScanChunk(k, static_cast<std::uint16_t>(std::min<std::uint32_t>(w.next, 0xFFFFu)),
                                      request_.request_id, now_us, &out->chunk, &num_chunks);
    if (st.ok()) {
      w.end = std::min<std::uint32_t>(w.end, num_chunks);
      out->kind = RobotOutgoing::Kind::kScanChunk;
      out->resend = w.resend;
      ++(w.resend ? stats_.chunks_resent : stats_.chunks_sent);
      slot_sent_us_[w.slot] = now_us;
      if (++w.next >= w.end) {
        slot_queued_[w.slot] = 0;
        work_.pop_front();
      }
      return true;
    }
    // The store no longer has the scan (evicted), or the range ends past the scan: nothing to send for it.
    if (st.code() == StatusCode::kNotFound && w.next == 0) ++stats_.scans_unavailable;
    slot_queued_[w.slot] = 0;
    work_.pop_front();
  }
  return false;
}

void TokenBucket::Refill(std::int64_t now_us) noexcept {
  if (last_us_ >= 0 && now_us > last_us_) {
    // Seconds as a division: exact for whole multiples of 1 s, so the refill after WaitUs() reaches 0 exactly
    // (with "* 1e-6" the aarch64 build, which contracts to fused multiply-adds, stopped 2e-13 short of it).
    tokens_ = std::min(burst_, tokens_ + rate_ * (static_cast<double>(now_us - last_us_) / 1e6));
  }
  if (now_us > last_us_) last_us_ = now_us;
}

bool TokenBucket::CanSend(std::int64_t now_us) noexcept {
  if (!(rate_ > 0.0)) return true;
  Refill(now_us);
  return tokens_ >= 0.0;
}

std::int64_t TokenBucket::WaitUs(std::int64_t now_us) noexcept {
  if (CanSend(now_us)) return 0;
  return static_cast<std::int64_t>(std::ceil(-tokens_ / rate_ * 1e6));
}

}  // namespace commerge
