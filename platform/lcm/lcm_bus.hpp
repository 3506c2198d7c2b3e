// SPDX-License-Identifier: BSD-3-Clause
// A thin LCM transport for the daemons: raw-buffer subscriptions (commerge decodes with its own bounded
// decoders, never with the generated decode), publishing of encoded bytes, and a wait with timeout. Incoming
// messages are queued up to a fixed count and byte total; beyond that they are dropped and counted, so a flood
// cannot grow memory. A test-only fault stage holds outgoing messages for `delay_ms` plus a random jitter of up
// to `jitter_ms` (which reorders them) and publishes `duplicate_pct` percent of them twice: the delay,
// duplication and reordering fault tests (sch_netem is unavailable on the CI kernel). It is bounded like the
// receive queue. With `authenticate`, every published message is signed (platform/lcm/message_auth: a 40-byte
// trailer with sender, session, sequence number and MAC) before the fault stage, and every received one is
// verified before it is queued: unsigned, forged, tampered, replayed and unknown-sender messages are dropped and
// counted (auth_stats()); the process's own looped-back messages are dropped silently.
//
// With `receive_thread` (the daemons), a thread of the bus's own hands every message from LCM to the bounded
// queue as it arrives, so a caller that computes for seconds between two Poll calls (the server registering a
// round, a robot closing a loop on a slow board) does not let LCM's 30-message queue per subscription fill:
// LCM drops beyond it silently, before anything can count. Poll then only waits for the queue to fill.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <initializer_list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "core/common/status.hpp"
#include "platform/lcm/message_auth.hpp"

namespace lcm {
class LCM;
}  // namespace lcm
struct _lcm_recv_buf_t;

namespace commerge::platform {

struct LcmBusParams {
  std::string url;                     ///< "" = LCM_DEFAULT_URL or LCM's default
  std::size_t max_queued_messages = 4096;
  std::size_t max_queued_bytes = 16u << 20;
  double delay_ms = 0.0;               ///< hold every outgoing message this long (fault tests)
  double jitter_ms = 0.0;              ///< plus a uniform random extra hold in [0, jitter_ms] (reorders)
  double duplicate_pct = 0.0;          ///< publish this percentage of messages twice (independent jitter)
  std::uint32_t fault_seed = 1;        ///< seed of the jitter and duplication draws
  /// Messages LCM's own receive thread may hold per subscription until they are handled (0 = LCM's default,
  /// 30): until the next Poll, or with receive_thread until that thread takes them. Beyond that LCM drops them
  /// silently, before this bus can count them. LCM bounds them by count only: keep the default on channels of
  /// large messages (live scans).
  int lcm_queue_capacity = 0;
  /// Hand messages from LCM to the queue in a thread of the bus's own, started by the first Poll (subscribe
  /// before). Without it, messages move only inside Poll (deterministic, for in-process tests).
  bool receive_thread = false;
  bool authenticate = false;           ///< sign and verify every message with `auth`
  MessageAuthParams auth;
};

struct BusMessage {
  std::string channel;
  std::vector<std::uint8_t> bytes;  ///< the LCM-encoded message (without the MAC trailer)
  int sender = -1;                  ///< authenticated sender (robot id, or kAuthServerSender); -1: not authenticated
  std::int64_t recv_utime_us = 0;   ///< when LCM received it [us since the Unix epoch]
};

struct LcmBusStats {
  std::uint64_t received = 0, received_bytes = 0, dropped_queue_full = 0;
  std::uint64_t published = 0, published_bytes = 0, publish_errors = 0;
};

class LcmBus {
 public:
  /// Connects; an error names the URL (e.g. a missing multicast route: `ip route add 224.0.0.0/4 dev lo`).
  static Result<std::unique_ptr<LcmBus>> Create(const LcmBusParams& params);
  ~LcmBus();
  LcmBus(const LcmBus&) = delete;
  LcmBus& operator=(const LcmBus&) = delete;

  /// Receive raw messages on channels matching `regex` (LCM channel regex, e.g. "COMMERGE_.*").
  Status Subscribe(const std::string& regex);
  /// Waits up to timeout_ms for traffic, moves what arrived into the queue, and publishes delayed messages
  /// that are due. With receive_thread: starts the thread at the first call, then waits until the queue holds a
  /// message; an error of the thread's LCM handling is returned here.
  Status Poll(int timeout_ms);
  /// Takes the oldest queued message; false when none.
  bool Take(BusMessage* out);
  /// Publishes (or holds in the fault stage) one encoded message, signed when authenticating.
  Status Publish(const std::string& channel, const std::vector<std::uint8_t>& bytes);
  /// Publishes `bytes` exactly as given: no signature, no fault stage (tests and tools that inject traffic).
  Status PublishRaw(const std::string& channel, const std::vector<std::uint8_t>& bytes);
  /// Verification counters (a copy: the receive thread updates them); empty when not authenticating.
  std::optional<AuthStats> auth_stats() const;
  LcmBusStats stats() const;
  /// Messages held by the fault stage.
  std::size_t delayed() const noexcept { return delayed_.size(); }

 private:
  explicit LcmBus(const LcmBusParams& params);
  // Subscribed through LCM's C API: the C++ member-handler template of LCM 1.3.1 fails UBSan's vptr check inside
  // LCM's own header (reproduced with a ten-line program), which aborts the sanitizer build.
  static void OnMessageC(const _lcm_recv_buf_t* rbuf, const char* channel, void* user);
  void OnMessage(const std::uint8_t* data, std::size_t size, const char* channel, std::int64_t recv_utime_us);
  Status StartReceiveThread();
  void ReceiveLoop();
  Status PublishNow(const std::string& channel, const std::vector<std::uint8_t>& bytes);
  void FlushDelayed();

  bool fault_stage() const noexcept {
    return params_.delay_ms > 0.0 || params_.jitter_ms > 0.0 || params_.duplicate_pct > 0.0;
  }
  Status Hold(const std::string& channel, const std::vector<std::uint8_t>& bytes);

  LcmBusParams params_;
  std::unique_ptr<lcm::LCM> lcm_;
  // mutex_ guards what the receive thread and the caller share: the authenticator (Verify there, Sign here),
  // the queue, its byte total, the counters and the thread's error.
  mutable std::mutex mutex_;
  std::condition_variable arrived_;
  std::unique_ptr<MessageAuthenticator> auth_;
  std::deque<BusMessage> queue_;
  std::size_t queued_bytes_ = 0;
  LcmBusStats stats_;
  Status receive_error_;
  // The caller's alone.
  std::vector<std::uint8_t> sign_buffer_;
  std::multimap<std::int64_t, BusMessage> delayed_;  ///< by due time [us, monotonic]
  std::mt19937 fault_rng_;
  std::thread receiver_;
  std::atomic<bool> stop_receiving_{false};
};

/// Create() plus Subscribe() of each channel: the daemons' start-up. Errors name the URL or the channel.
Result<std::unique_ptr<LcmBus>> OpenLcmBus(const LcmBusParams& params, std::initializer_list<const char*> channels);

/// Microseconds since the Unix epoch (message utime, session ids).
std::int64_t WallTimeUs();
/// Microseconds of a monotonic clock (timeouts, pacing).
std::int64_t MonotonicUs();

}  // namespace commerge::platform
