// SPDX-License-Identifier: BSD-3-Clause
// The "server inbox" of the fuzz targets: what reaches `commerge server` on the robot -> server channels, replayed
// into the transport-free server (MergeServer + ServerLink) through the same bounded decoders, with a fixed
// session and a clock that only the input advances, so a run is deterministic. cm_fuzz_server_inbox feeds it
// fuzzed streams; cm_fuzz_seeds records a two-robot mission through it (the robots answer what it publishes).
//
// Stream format: records [channel selector: 1 byte][payload length: 2 bytes, big-endian][payload]. The selector
// modulo kInboxChannels picks COMMERGE_KEYFRAMES, COMMERGE_POSES, COMMERGE_SCANS or a clock tick; a length beyond
// the end takes what is left, so every byte string is a stream and a single message needs no exact length.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/agent/merge_server.hpp"
#include "core/agent/messages.hpp"
#include "core/agent/server_link.hpp"
#include "core/common/span.hpp"

namespace commerge::fuzz {

enum class InboxChannel : std::uint8_t { kKeyframes = 0, kPoses = 1, kScans = 2, kTick = 3 };
inline constexpr int kInboxChannels = 4;
inline constexpr std::size_t kInboxMaxPayloadBytes = 65535;
/// A tick advances the clock by kInboxTickUs x (1 + its first payload byte; 0 when empty) before the poll.
inline constexpr std::int64_t kInboxTickUs = 10000;
/// Fixed start time and server session [us] (2023-11-14): every run sees the same clock.
inline constexpr std::int64_t kInboxStartUs = 1700000000000000;
inline constexpr std::int64_t kInboxServerSession = kInboxStartUs;

struct InboxRecord {
  InboxChannel channel = InboxChannel::kTick;
  Span<const std::uint8_t> payload;
};

/// Takes the next record off the front of `*stream`; false when the stream is empty.
bool TakeInboxRecord(Span<const std::uint8_t>* stream, InboxRecord* record);
/// Appends one record (at most kInboxMaxPayloadBytes of payload; longer payloads are a bug of the caller).
void AppendInboxRecord(InboxChannel channel, Span<const std::uint8_t> payload, std::vector<std::uint8_t>* stream);

/// The fuzzed server's sizes and parameters (see the .cpp for why each differs from the daemon's defaults).
inline constexpr int kInboxMaxRobots = 3;
inline constexpr std::size_t kInboxMaxKeyframes = 1024;
MergeServerParams InboxMergeServerParams();
ServerLinkParams InboxServerLinkParams();

/// The server side of `commerge server` (apps/cmd_server.cpp) without LCM. Feed() checks, for every record,
/// and calls Fail() when one does not hold:
///   * a message the decoder refuses is refused with DataLoss (the daemon counts it);
///   * a decoded message the server refuses is counted in MergeServer or ServerLink stats;
///   * everything the server publishes (transfer status, exchange policy, merge result, and the server status
///     the daemon sends once per second) is accepted by its encoder, and the encoded bytes by its decoder (the
///     robots and lcm-spy must be able to read it);
///   * a refused message that applied no keyframe record leaves every robot's session and keyframe database as it
///     was (ServerLink's "refused messages ... never change the state"); CM_FUZZ_STRICT_REFUSALS=0 turns this
///     check off.
class InboxServer {
 public:
  InboxServer();
  InboxServer(const InboxServer&) = delete;
  InboxServer& operator=(const InboxServer&) = delete;

  void Feed(const InboxRecord& record);

  std::int64_t now_us() const noexcept { return now_us_; }
  /// What the last Feed() published (its poll), and the same messages encoded.
  const std::vector<ServerOutgoing>& published() const noexcept { return out_; }
  const std::vector<std::vector<std::uint8_t>>& published_bytes() const noexcept { return out_bytes_; }
  /// The daemon's server_status_t content now (its memory modules left empty, as the daemon does).
  ServerStatus MakeServerStatus() const;

  const MergeServer& server() const noexcept { return *server_; }
  const ServerLink& link() const noexcept { return link_; }
  std::uint64_t rejected() const noexcept { return rejected_; }
  std::uint64_t accepted() const noexcept { return accepted_; }
  std::uint64_t failed_polls() const noexcept { return failed_polls_; }

 private:
  std::uint64_t CountedRefusals() const;
  std::uint64_t StateDigest() const;
  template <typename Message, typename Handler>
  void Deliver(const char* channel, const Result<Message>& decoded, Handler handler);
  void Publish();

  std::unique_ptr<MergeServer> server_;  ///< MergeServer::Create, which must succeed
  ServerLink link_;
  std::int64_t now_us_ = kInboxStartUs;
  std::int64_t next_status_us_ = kInboxStartUs;
  std::uint64_t rejected_ = 0, accepted_ = 0, failed_polls_ = 0;
  std::int64_t bytes_received_ = 0;
  std::string last_rejection_;
  bool strict_refusals_ = false;
  std::vector<ServerOutgoing> out_;
  std::vector<std::vector<std::uint8_t>> out_bytes_;
};

}  // namespace commerge::fuzz
