// SPDX-License-Identifier: BSD-3-Clause
// Message authentication for every commerge LCM message: a 40-byte trailer after the LCM-encoded bytes carries
// the sender, its session, a sequence number and a MAC (HMAC-SHA-256 truncated to 128 bits, libsodium) keyed with
// the team's key. Receivers drop and count messages without a valid MAC, from senders outside the team's robot
// ids, replayed ones (a 1024-message window per sender), and those of a sender's older session.
//
// Trailer (big-endian), appended to the LCM message (fingerprint first, so lcm-spy still decodes it):
//   0  'C' 'A'      magic
//   2  u8  1        version
//   3  u8           key id (which key of the team's key file signed it)
//   4  u16          sender: robot id 0..63, or kAuthServerSender
//   6  u16  0       reserved
//   8  i64          sender's session (its start time [us]; a newer session resets the sender's window)
//   16 u64          sequence number within the session, from 1
//   24 16 bytes     MAC over: channel name, a 0 byte, the LCM bytes, trailer bytes 0..23
//
// Team key file: text, owner-only permissions (no group/other bits), at most kAuthMaxKeys lines
//   key <id 0..255> <64 hex digits>
// plus '#' comments and blank lines. The first key signs; every key listed is accepted (key rotation).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/common/status.hpp"

namespace commerge::platform {

inline constexpr std::size_t kAuthKeyBytes = 32;
inline constexpr std::size_t kAuthMacBytes = 16;
inline constexpr std::size_t kAuthTrailerBytes = 40;
inline constexpr std::size_t kAuthMaxKeys = 4;
inline constexpr std::size_t kAuthMaxKeyFileBytes = 4096;
inline constexpr std::uint16_t kAuthServerSender = 0xFFFF;
inline constexpr std::uint16_t kAuthMaxRobots = 64;  ///< robot ids 0..63 (robot_status_t MAX_ROBOT_ID)
inline constexpr std::uint64_t kReplayWindowMessages = 1024;

struct TeamKey {
  std::uint8_t id = 0;
  std::array<std::uint8_t, kAuthKeyBytes> bytes{};
};

/// keys[0] signs; every key verifies. 1..kAuthMaxKeys keys with distinct ids.
struct TeamKeyring {
  std::vector<TeamKey> keys;
};

/// Parses key-file text; errors name `source` and the line.
Result<TeamKeyring> ParseTeamKeyring(const std::string& text, const std::string& source);
/// Reads and parses a key file. Refused: not a regular file, group- or world-accessible (mode & 077), larger
/// than kAuthMaxKeyFileBytes. The key itself is never printed.
Result<TeamKeyring> LoadTeamKeyring(const std::string& path);
/// A fresh random key (libsodium's randombytes).
Result<TeamKey> GenerateTeamKey(std::uint8_t id);
/// "key <id> <hex>\n".
std::string FormatTeamKey(const TeamKey& key);
/// Creates `path` with mode 0600 (refuses an existing file) and writes `text`.
Status WriteNewKeyFile(const std::string& path, const std::string& text);

enum class AuthVerdict : std::uint8_t {
  kOk = 0,
  kOwnEcho,        ///< this process's own message looped back: dropped, not a rejection
  kNoTrailer,      ///< too short or no commerge trailer (unsigned or foreign traffic)
  kUnknownKey,     ///< key id not in the key file (another team, or a rotated-out key)
  kBadMac,         ///< forged or tampered
  kUnknownSender,  ///< valid MAC but a sender outside the team's robot ids
  kOldSession,     ///< a sender's session older than one already seen (replayed from an earlier run)
  kReplayed,       ///< a sequence number already accepted in the current window
  kTooOld,         ///< a sequence number below the window
};
inline constexpr std::size_t kAuthVerdictCount = 9;
/// "ok", "own echo", "no MAC trailer", "unknown key id", "bad MAC", "unknown sender", "old session", "replayed",
/// "older than the replay window".
const char* AuthVerdictName(AuthVerdict verdict) noexcept;

/// Sliding replay window of one sender: the highest sequence number accepted and which of the
/// kReplayWindowMessages below it were seen. Pure.
class ReplayWindow {
 public:
  /// What Accept would do with (session, sequence): kOk, kOldSession, kReplayed or kTooOld. session must be > 0.
  AuthVerdict Check(std::int64_t session, std::uint64_t sequence) const noexcept;
  /// Records an accepted message (call only after Check returned kOk). A newer session resets the window.
  void Accept(std::int64_t session, std::uint64_t sequence) noexcept;
  std::int64_t session() const noexcept { return session_; }

 private:
  static constexpr std::size_t kWords = kReplayWindowMessages / 64;
  std::int64_t session_ = 0;
  std::uint64_t top_ = 0;                   ///< highest sequence accepted in session_ (0: none)
  std::array<std::uint64_t, kWords> seen_{};  ///< bit i: top_ - i accepted
};

struct MessageAuthParams {
  TeamKeyring keyring;
  std::uint16_t sender = kAuthServerSender;  ///< this process: a robot id or kAuthServerSender
  std::int64_t session = 0;                  ///< this process's session (> 0), e.g. its start time [us]
  std::uint16_t max_robots = kAuthMaxRobots; ///< robot senders 0 .. max_robots - 1 are accepted (1..64)
};

/// The unauthenticated fields of a message's trailer (bytes 0..23), read without the key.
struct AuthTrailerFields {
  std::uint8_t key_id = 0;
  std::uint16_t sender = 0;
  std::int64_t session = 0;
  std::uint64_t sequence = 0;
};
/// Reads the trailer at the end of `data` (size bytes); false when the message is too short or ends in no
/// commerge trailer (unsigned or foreign traffic). Says nothing about the MAC.
bool ReadAuthTrailer(const std::uint8_t* data, std::size_t size, AuthTrailerFields* out) noexcept;

struct AuthStats {
  std::uint64_t signed_messages = 0;
  std::uint64_t trailer_bytes = 0;  ///< kAuthTrailerBytes per signed message: the overhead on the wire
  std::uint64_t accepted = 0;
  std::array<std::uint64_t, kAuthVerdictCount> verdicts{};  ///< every Verify, by verdict
  /// Rejections: every verdict but kOk and kOwnEcho.
  std::uint64_t rejected() const noexcept;
};

class MessageAuthenticator {
 public:
  /// Checks the parameters (keyring 1..kAuthMaxKeys distinct ids, session > 0, max_robots 1..64) and initialises
  /// libsodium.
  static Result<std::unique_ptr<MessageAuthenticator>> Create(const MessageAuthParams& params);

  /// Appends the trailer to `bytes` (the LCM-encoded message to be published on `channel`).
  void Sign(const std::string& channel, std::vector<std::uint8_t>* bytes);
  /// Checks one received message. On kOk, *payload_bytes is its length without the trailer and *sender the
  /// signer. Only kOk updates the sender's replay window; nothing is allocated.
  AuthVerdict Verify(const char* channel, const std::uint8_t* data, std::size_t size, std::size_t* payload_bytes,
                     std::uint16_t* sender);

  const AuthStats& stats() const noexcept { return stats_; }
  std::uint16_t sender() const noexcept { return params_.sender; }

 private:
  explicit MessageAuthenticator(const MessageAuthParams& params) : params_(params) {}
  ReplayWindow* WindowOf(std::uint16_t sender) noexcept;

  MessageAuthParams params_;
  std::uint64_t next_sequence_ = 1;
  std::array<ReplayWindow, kAuthMaxRobots + 1> windows_{};  ///< robots 0..63, then the server
  AuthStats stats_;
};

}  // namespace commerge::platform
