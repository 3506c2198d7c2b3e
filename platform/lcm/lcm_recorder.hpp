// SPDX-License-Identifier: BSD-3-Clause
// `commerge record`: writes the mission's LCM traffic to an LCM event log (the format of lcm-logger, played back
// by lcm-logplayer into `commerge server --replay`), without losing messages to LCM's own queue.
//
// Why not lcm-logger: LCM 1.3.1 keeps at most 30 received messages per subscription until the process handles
// them and drops the rest silently, and lcm-logger does not raise that. On a loaded board its log can then miss
// scan chunks (while the kernel drops none), and a replay registers fewer scans than the recording server did.
// The recorder raises LCM's queue to lcm_queue_capacity, drains it into a bounded LcmBus queue (drops there are
// counted), and counts what is missing from the log by the senders' own sequence numbers (SequenceGapCounter),
// so an incomplete recording says so.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/common/status.hpp"
#include "platform/lcm/lcm_bus.hpp"
#include "platform/lcm/message_auth.hpp"

struct _lcm_eventlog_t;

namespace commerge::platform {

/// What one sender's messages in a recording look like by their trailers' sequence numbers.
struct SenderSequences {
  std::uint16_t sender = 0;        ///< robot id, or kAuthServerSender
  std::int64_t session = 0;        ///< the newest session seen
  std::uint64_t received = 0;      ///< distinct sequence numbers recorded in that session
  std::uint64_t missing = 0;       ///< numbers between its lowest and highest that were not recorded
  std::uint64_t duplicates = 0;    ///< recorded more than once (network duplicates)
  std::uint64_t older_sessions_missing = 0;  ///< missing in the sender's earlier sessions (restarts)
};

/// Counts, per sender, the sequence numbers of commerge message trailers (platform/lcm/message_auth) that a
/// recording lacks. The trailers are read without checking their MAC (a recorder holds no key): a forged
/// trailer can distort the counts, never crash or grow memory (robots 0..63 and the server are tracked; other
/// sender ids only counted). A message more than kReplayWindowMessages behind its sender's newest is taken as
/// new. Sequence numbers count every message a sender signs, so record every channel the senders publish on.
/// Pure.
class SequenceGapCounter {
 public:
  /// Counts one received message (LCM bytes plus trailer).
  void Count(const std::uint8_t* data, std::size_t size) noexcept;
  /// Messages without a commerge trailer (unsigned traffic).
  std::uint64_t unsigned_messages() const noexcept { return unsigned_; }
  /// Messages with a sender id that is neither a robot 0..63 nor the server.
  std::uint64_t unknown_senders() const noexcept { return unknown_senders_; }
  /// Messages of a session older than one already seen for that sender.
  std::uint64_t stale_messages() const noexcept { return stale_; }
  /// Missing messages over every sender and session.
  std::uint64_t missing() const noexcept;
  /// The senders seen, robots ascending, the server last.
  std::vector<SenderSequences> senders() const;

 private:
  struct Track {
    ReplayWindow window;
    std::uint64_t lowest = 0, highest = 0;  ///< 0: nothing in this session yet
    SenderSequences summary;
    bool seen = false;
  };
  /// Numbers between the track's lowest and highest not recorded (0 when nothing was).
  static std::uint64_t Missing(const Track& track) noexcept;
  std::array<Track, kAuthMaxRobots + 1> tracks_{};  ///< robots 0..63, then the server
  std::uint64_t unsigned_ = 0, unknown_senders_ = 0, stale_ = 0;
};

struct LcmRecorderParams {
  std::string url;  ///< "" = LCM_DEFAULT_URL or LCM's default
  /// LCM channel regex. The default is the mission's channels between robots and server; the live input
  /// (lidar_scan_t, odometry_t) stays on each board and is not recorded.
  std::string channels =
      "COMMERGE_(KEYFRAMES|POSES|POLICY|SCANS|TRANSFER_STATUS|MERGE_RESULT|ROUND|ROBOT_STATUS|SERVER_STATUS)";
  std::string out_path;
  bool overwrite = false;  ///< replace an existing file (otherwise refused)
  /// Messages LCM may hold between two polls (LCM counts messages, not bytes: see LcmBusParams).
  int lcm_queue_capacity = 4096;
  /// Drain LCM in a thread of the bus's own (LcmBusParams::receive_thread): a slow disk (an SD card) does not
  /// stall the receiving.
  bool receive_thread = true;
  std::size_t max_queued_messages = 4096;
  std::size_t max_queued_bytes = 64u << 20;
};

struct LcmRecorderStats {
  std::uint64_t messages = 0;  ///< events written
  std::uint64_t bytes = 0;     ///< their payload bytes
  std::uint64_t dropped = 0;   ///< dropped by the bounded queue (LcmBus) before they could be written
};

class LcmRecorder {
 public:
  /// Creates `out_path` (refused when it exists, unless overwrite) and subscribes. Errors name the file or URL.
  static Result<std::unique_ptr<LcmRecorder>> Open(const LcmRecorderParams& params);
  ~LcmRecorder();
  LcmRecorder(const LcmRecorder&) = delete;
  LcmRecorder& operator=(const LcmRecorder&) = delete;

  /// Waits up to timeout_ms for traffic and writes every message that arrived, in arrival order, with LCM's
  /// receive time. An error names the file (disk full, ...); the log stays readable up to the last whole event.
  Status Poll(int timeout_ms);
  /// Polls until quiet_ms pass without a new message, or max_ms in all: on a stop request, what the network
  /// still holds for this process (the mission's last round step and result, sent just before everybody exited)
  /// reaches the log before Close. Returns the messages it wrote; errors as Poll.
  Result<std::uint64_t> Drain(int quiet_ms, int max_ms);
  /// Flushes the log to the file (Poll flushes once a second by itself).
  Status Flush();
  /// Writes what is still queued, flushes and closes; later Polls fail. Called by the destructor too.
  Status Close();

  const LcmRecorderStats& stats() const noexcept { return stats_; }
  const SequenceGapCounter& sequences() const noexcept { return sequences_; }
  const std::string& path() const noexcept { return params_.out_path; }
  /// Testing: the recorder's own bus. On memq:// (in-process) only messages published through it reach the
  /// recorder.
  LcmBus* bus_for_testing() noexcept { return bus_.get(); }

 private:
  explicit LcmRecorder(const LcmRecorderParams& params) : params_(params) {}
  Status WriteQueued();

  LcmRecorderParams params_;
  std::unique_ptr<LcmBus> bus_;
  _lcm_eventlog_t* log_ = nullptr;
  std::int64_t last_flush_us_ = 0;
  LcmRecorderStats stats_;
  SequenceGapCounter sequences_;
};

}  // namespace commerge::platform
