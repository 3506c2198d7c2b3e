// SPDX-License-Identifier: BSD-3-Clause
// commerge: the robot's side of reliable delivery over a lossy link (LCM udpm drops whole messages). It sits on a
// RobotAgent and turns the server's periodic TransferStatus into re-announcements and retransmissions:
//   * keyframes: every keyframe the status does not list as held (a gap, or above keyframes_seen) and that was
//     last sent more than resend_timeout_s ago is announced again (record with its current pose, or its pose when
//     it has no valid descriptor), so every keyframe's descriptor eventually reaches the server;
//   * poses: pose updates stay "in flight" until the status acknowledges their sequence; an unacknowledged one
//     older than resend_timeout_s re-queues its keyframes' current poses;
//   * scans: the active scan request (the newest from the server) is answered chunk by chunk; the status's
//     missing-chunk ranges are sent again once the chunks are older than resend_timeout_s;
//   * a new server session (the server restarted) re-announces everything; a new request replaces the old one;
//   * new keyframes wait up to batch_delay_s to share a batch (records are 92 bytes, a batch's header 47).
// Nothing is resent without a status, so a silent link is not flooded; only when no status came for three
// resend timeouts while keyframes wait for acknowledgement is one keyframe announced again per three timeouts (a
// server that lost every message of a robot never heard of it, and sends it no status). Queues are bounded: the keyframe and
// pose queues are flags per keyframe, the chunk work list holds at most one entry per requested scan plus
// kMaxStatusMissingRanges, and at most max_pose_updates_in_flight updates are tracked (then poses wait).
// The caller encodes, paces (TokenBucket) and publishes what Next() returns; the link never blocks.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <vector>

#include "core/agent/messages.hpp"
#include "core/agent/robot_agent.hpp"
#include "core/common/status.hpp"

namespace commerge {

struct RobotLinkParams {
  /// Data the server has not acknowledged this long after it was sent is sent again [s].
  double resend_timeout_s = 2.0;
  /// Pose updates awaiting acknowledgement (1..4096); when full, further poses wait.
  std::size_t max_pose_updates_in_flight = 64;
  /// New keyframes wait up to this long for more to share their batch [s] (a full batch goes at once, and so does
  /// everything after set_flush): a batch's header costs half a record, so a robot that sent each keyframe alone
  /// paid 50 % more for its descriptors. 0: every keyframe as soon as it is made.
  double batch_delay_s = 2.0;
};

Status ValidateRobotLinkParams(const RobotLinkParams& params);

/// One message to publish.
struct RobotOutgoing {
  enum class Kind : std::uint8_t { kKeyframeBatch, kPoseUpdate, kScanChunk };
  Kind kind = Kind::kKeyframeBatch;
  bool resend = false;  ///< a re-announcement or retransmission (counted apart in the byte ledger)
  KeyframeBatch batch;
  PoseUpdate poses;
  ScanChunk chunk;
};

struct RobotLinkStats {
  std::uint64_t statuses = 0, stale_statuses = 0, foreign_statuses = 0;
  std::uint64_t server_restarts = 0;         ///< new server sessions seen after the first
  std::uint64_t keyframes_requeued = 0;      ///< re-announcements queued
  std::uint64_t pose_updates_requeued = 0;   ///< unacknowledged pose updates whose poses were queued again
  std::uint64_t chunks_sent = 0, chunks_resent = 0;
  std::uint64_t requests = 0, requests_completed = 0, scans_unavailable = 0;
  std::uint32_t keyframes_acked = 0;         ///< keyframes the last status says the server holds
};

class RobotLink {
 public:
  /// `agent` is not owned; its session is set to `session` (> 0, e.g. the process start time in us).
  RobotLink(std::int64_t session, const RobotLinkParams& params, RobotAgent* agent);

  /// A scan request (exchange policy). Requests for another robot are an error; repeats of the active request
  /// and requests older than it are ignored; a newer one replaces it.
  Status OnScanRequest(const ScanRequest& request, std::int64_t now_us);
  /// The server's transfer status for this robot (others are an error and counted).
  Status OnTransferStatus(const TransferStatus& status, std::int64_t now_us);

  /// The next message to publish, by priority: the pose update of a new request, keyframe batches
  /// (re-announcements first), pose updates, scan chunks. False when there is nothing to send.
  Result<bool> Next(std::int64_t now_us, RobotOutgoing* out);

  /// The mission's input ended: queued keyframes go without waiting for batch_delay_s.
  void set_flush(bool flush) noexcept { flush_ = flush; }

  /// Chunks queued for the active request (not yet sent, or to be resent), at most.
  std::size_t queued_chunks() const noexcept;
  std::int32_t active_request() const noexcept { return request_.request_id; }
  bool request_done() const noexcept { return request_done_; }
  std::int64_t server_session() const noexcept { return server_session_; }
  std::size_t pose_updates_in_flight() const noexcept { return in_flight_.size(); }
  const RobotLinkStats& stats() const noexcept { return stats_; }

 private:
  struct Work {  // chunks [next, end) of request keyframe `slot`; end = 0xFFFF: up to the scan's chunk count
    std::size_t slot = 0;
    std::uint32_t next = 0, end = 0;
    bool resend = false;
  };
  struct InFlight {
    std::int32_t sequence = 0;
    std::int64_t sent_us = 0;
    std::vector<std::uint32_t> keyframes;
  };
  bool Due(std::int64_t last_us, std::int64_t now_us) const;
  void TrackPoses(const PoseUpdate& update, std::int64_t now_us);
  void ApplyKeyframeAcks(const TransferStatus& status, std::int64_t now_us);
  void ApplyPoseAcks(const TransferStatus& status, std::int64_t now_us);
  void ApplyChunkAcks(const TransferStatus& status, std::int64_t now_us);
  void DropRequest();
  void SeeServerSession(std::int64_t server_session);

  std::int64_t session_;
  RobotLinkParams params_;
  Status params_status_;
  RobotAgent* agent_;
  std::int64_t server_session_ = 0;
  ScanRequest request_;                     ///< active request (request_id -1: none)
  bool request_done_ = false;
  bool request_poses_pending_ = false;
  std::vector<std::int64_t> slot_sent_us_;  ///< per request keyframe: when its last chunk went out (-1: never)
  std::vector<std::uint8_t> slot_queued_;   ///< per request keyframe: a work item is queued
  std::deque<Work> work_;
  std::deque<InFlight> in_flight_;
  bool flush_ = false;
  std::int64_t unsent_since_us_ = -1;  ///< when the oldest keyframe not yet batched was first seen (-1: none)
  std::int64_t last_status_us_ = -1;   ///< when the last status for this session arrived (-1: none yet)
  RobotLinkStats stats_;
};

/// A token bucket for the per-robot bandwidth cap: `rate_bytes_per_s` refills up to `burst_bytes`. A message may
/// go when the bucket is not in debt; its size is then taken (the bucket may go negative by one message), so the
/// long-run rate never exceeds the cap. rate 0 = no cap.
class TokenBucket {
 public:
  TokenBucket(double rate_bytes_per_s, double burst_bytes) noexcept
      : rate_(rate_bytes_per_s), burst_(burst_bytes), tokens_(burst_bytes) {}
  bool CanSend(std::int64_t now_us) noexcept;
  void Take(std::size_t bytes) noexcept { tokens_ -= static_cast<double>(bytes); }
  /// Microseconds until CanSend() turns true (0 when it is).
  std::int64_t WaitUs(std::int64_t now_us) noexcept;

 private:
  void Refill(std::int64_t now_us) noexcept;
  double rate_, burst_, tokens_;
  std::int64_t last_us_ = -1;
};

}  // namespace commerge
