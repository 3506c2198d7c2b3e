// SPDX-License-Identifier: BSD-3-Clause
// A thin LCM transport for the daemons: raw-buffer subscriptions (commerge decodes with its own bounded
// decoders, never with the generated decode), publishing of encoded bytes, and a wait with timeout. Incoming
// messages are queued up to a fixed count and byte total; beyond that they are dropped and counted, so a flood
// cannot grow memory. A test-only delay stage (`delay_ms`) holds outgoing messages for a fixed time before
// publishing them (the 2 s delay fault test; sch_netem is unavailable on the CI kernel).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "core/common/status.hpp"

namespace lcm {
class LCM;
class ReceiveBuffer;
}  // namespace lcm

namespace commerge::platform {

struct LcmBusParams {
  std::string url;                     ///< "" = LCM_DEFAULT_URL or LCM's default
  std::size_t max_queued_messages = 4096;
  std::size_t max_queued_bytes = 16u << 20;
  double delay_ms = 0.0;               ///< hold every outgoing message this long (fault tests)
};

struct BusMessage {
  std::string channel;
  std::vector<std::uint8_t> bytes;
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
  /// that are due.
  Status Poll(int timeout_ms);
  /// Takes the oldest queued message; false when none.
  bool Take(BusMessage* out);
  /// Publishes (or holds, with delay_ms) one encoded message.
  Status Publish(const std::string& channel, const std::vector<std::uint8_t>& bytes);
  const LcmBusStats& stats() const noexcept { return stats_; }
  /// Messages held by the delay stage.
  std::size_t delayed() const noexcept { return delayed_.size(); }

 private:
  explicit LcmBus(const LcmBusParams& params);
  void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  Status PublishNow(const std::string& channel, const std::vector<std::uint8_t>& bytes);
  void FlushDelayed();

  struct Delayed {
    std::int64_t due_us = 0;
    BusMessage message;
  };
  LcmBusParams params_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::deque<BusMessage> queue_;
  std::size_t queued_bytes_ = 0;
  std::deque<Delayed> delayed_;
  LcmBusStats stats_;
};

/// Create() plus Subscribe() of each channel: the daemons' start-up. Errors name the URL or the channel.
Result<std::unique_ptr<LcmBus>> OpenLcmBus(const LcmBusParams& params, std::initializer_list<const char*> channels);

/// Microseconds since the Unix epoch (message utime, session ids).
std::int64_t WallTimeUs();
/// Microseconds of a monotonic clock (timeouts, pacing).
std::int64_t MonotonicUs();

}  // namespace commerge::platform
