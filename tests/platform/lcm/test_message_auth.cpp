// SPDX-License-Identifier: BSD-3-Clause
// Message authentication (platform/lcm/message_auth): the trailer layout against the documented bytes and a
// one-shot HMAC-SHA-256 of them; forged, tampered (every byte), replayed, reordered, foreign-team, unknown-sender
// and old-session messages refused; the replay window against a brute-force set model; key files (parse errors,
// permissions, rotation); and LcmBus on memq:// signing, verifying, stripping the trailer and counting refusals.
#include <doctest/doctest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <fstream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <sodium.h>

#include "platform/lcm/lcm_bus.hpp"
#include "platform/lcm/message_auth.hpp"

namespace commerge::platform {
namespace {

using Bytes = std::vector<std::uint8_t>;

TeamKey KeyOf(std::uint8_t id, std::uint8_t fill) {
  TeamKey k;
  k.id = id;
  for (std::size_t i = 0; i < k.bytes.size(); ++i) k.bytes[i] = static_cast<std::uint8_t>(fill + 7 * i);
  return k;
}

MessageAuthParams Params(std::vector<TeamKey> keys, std::uint16_t sender, std::int64_t session,
                         std::uint16_t max_robots = 4) {
  MessageAuthParams p;
  p.keyring.keys = std::move(keys);
  p.sender = sender;
  p.session = session;
  p.max_robots = max_robots;
  return p;
}

std::unique_ptr<MessageAuthenticator> Make(const MessageAuthParams& p) {
  auto a = MessageAuthenticator::Create(p);
  REQUIRE_MESSAGE(a.ok(), a.status().message());
  return std::move(*a);
}

Bytes Payload(std::size_t n, std::uint8_t seed) {
  Bytes b(n);
  for (std::size_t i = 0; i < n; ++i) b[i] = static_cast<std::uint8_t>(seed * 31 + i * 13);
  return b;
}

Bytes Signed(MessageAuthenticator* a, const std::string& channel, Bytes payload) {
  a->Sign(channel, &payload);
  return payload;
}

AuthVerdict Check(MessageAuthenticator* a, const std::string& channel, const Bytes& m, std::size_t* payload = nullptr,
                  std::uint16_t* sender = nullptr) {
  std::size_t p = 0;
  std::uint16_t s = 0;
  const AuthVerdict v = a->Verify(channel.c_str(), m.data(), m.size(), &p, &s);
  if (payload) *payload = p;
  if (sender) *sender = s;
  return v;
}

std::uint64_t Be(const Bytes& b, std::size_t off, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | b[off + static_cast<std::size_t>(i)];
  return v;
}

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("cm_auth_" + std::to_string(::getpid()) + "_" + name)).string();
}

void WriteFile(const std::string& path, const std::string& text, mode_t mode) {
  std::filesystem::remove(path);
  { std::ofstream(path) << text; }
  REQUIRE(::chmod(path.c_str(), mode) == 0);
}

}  // namespace

TEST_CASE("message auth: the trailer holds the documented fields and a truncated HMAC-SHA-256 of them") {
  const TeamKey key = KeyOf(7, 3);
  auto robot = Make(Params({key}, 2, 1700000000123456));
  const Bytes payload = Payload(100, 1);
  const Bytes m1 = Signed(robot.get(), "COMMERGE_KEYFRAMES", payload);
  const Bytes m2 = Signed(robot.get(), "COMMERGE_KEYFRAMES", payload);
  REQUIRE(m1.size() == payload.size() + kAuthTrailerBytes);
  CHECK(Bytes(m1.begin(), m1.begin() + 100) == payload);
  const std::size_t t = payload.size();
  CHECK(m1[t] == 'C');
  CHECK(m1[t + 1] == 'A');
  CHECK(m1[t + 2] == 1);
  CHECK(m1[t + 3] == 7);
  CHECK(Be(m1, t + 4, 2) == 2);
  CHECK(Be(m1, t + 6, 2) == 0);
  CHECK(Be(m1, t + 8, 8) == 1700000000123456u);
  CHECK(Be(m1, t + 16, 8) == 1);
  CHECK(Be(m2, t + 16, 8) == 2);  // sequence numbers count up
  // Independent MAC: one-shot HMAC-SHA-256 over channel, 0, payload, trailer bytes 0..23.
  std::string channel = "COMMERGE_KEYFRAMES";
  Bytes input(channel.begin(), channel.end());
  input.push_back(0);
  input.insert(input.end(), m1.begin(), m1.begin() + static_cast<std::ptrdiff_t>(t + 24));
  unsigned char mac[crypto_auth_hmacsha256_BYTES];
  crypto_auth_hmacsha256(mac, input.data(), input.size(), key.bytes.data());
  CHECK(Bytes(mac, mac + kAuthMacBytes) == Bytes(m1.begin() + static_cast<std::ptrdiff_t>(t + 24), m1.end()));
  CHECK(robot->stats().signed_messages == 2);
  CHECK(robot->stats().trailer_bytes == 2 * kAuthTrailerBytes);
}

TEST_CASE("message auth: a signed message verifies once, with its sender and its payload length") {
  const TeamKey key = KeyOf(1, 9);
  auto robot = Make(Params({key}, 3, 1000));
  auto server = Make(Params({key}, kAuthServerSender, 2000));
  const Bytes m = Signed(robot.get(), "C", Payload(57, 2));
  std::size_t payload = 0;
  std::uint16_t sender = 0;
  CHECK(Check(server.get(), "C", m, &payload, &sender) == AuthVerdict::kOk);
  CHECK(payload == 57);
  CHECK(sender == 3);
  CHECK(Check(server.get(), "C", m) == AuthVerdict::kReplayed);
  CHECK(server->stats().accepted == 1);
  CHECK(server->stats().rejected() == 1);
  // An empty payload is legal too.
  CHECK(Check(server.get(), "C", Signed(robot.get(), "C", {})) == AuthVerdict::kOk);
}

TEST_CASE("message auth: changing any single byte of a signed message is refused") {
  const TeamKey key = KeyOf(1, 5);
  auto robot = Make(Params({key}, 0, 1000));
  const Bytes m = Signed(robot.get(), "COMMERGE_SCANS", Payload(64, 3));
  for (std::size_t i = 0; i < m.size(); ++i) {
    for (std::uint8_t flip : {std::uint8_t{0x01}, std::uint8_t{0x80}}) {
      auto server = Make(Params({key}, kAuthServerSender, 2000));
      Bytes tampered = m;
      tampered[i] ^= flip;
      const AuthVerdict v = Check(server.get(), "COMMERGE_SCANS", tampered);
      CAPTURE(i);
      CHECK(v != AuthVerdict::kOk);
      CHECK(v != AuthVerdict::kOwnEcho);
    }
  }
  // Truncated (trailer cut) and extended (bytes appended) messages are refused as well.
  auto server = Make(Params({key}, kAuthServerSender, 2000));
  for (std::size_t cut = 1; cut <= m.size(); cut += 7) {
    CHECK(Check(server.get(), "COMMERGE_SCANS", Bytes(m.begin(), m.end() - static_cast<std::ptrdiff_t>(cut))) !=
          AuthVerdict::kOk);
  }
  Bytes longer = m;
  longer.push_back(0);
  CHECK(Check(server.get(), "COMMERGE_SCANS", longer) != AuthVerdict::kOk);
  // The channel is signed: the same bytes on another channel are refused.
  CHECK(Check(server.get(), "COMMERGE_POSES", m) == AuthVerdict::kBadMac);
  CHECK(Check(server.get(), "COMMERGE_SCANS", m) == AuthVerdict::kOk);
}

TEST_CASE("message auth: another team's key, unsigned traffic and a forged MAC are refused") {
  const TeamKey ours = KeyOf(1, 5), theirs_same_id = KeyOf(1, 200), theirs_other_id = KeyOf(9, 5);
  auto server = Make(Params({ours}, kAuthServerSender, 2000));
  auto foreign = Make(Params({theirs_same_id}, 0, 1000));
  auto foreign2 = Make(Params({theirs_other_id}, 0, 1000));
  CHECK(Check(server.get(), "C", Signed(foreign.get(), "C", Payload(30, 1))) == AuthVerdict::kBadMac);
  CHECK(Check(server.get(), "C", Signed(foreign2.get(), "C", Payload(30, 1))) == AuthVerdict::kUnknownKey);
  CHECK(Check(server.get(), "C", Payload(30, 1)) == AuthVerdict::kNoTrailer);
  CHECK(Check(server.get(), "C", Bytes{}) == AuthVerdict::kNoTrailer);
  // A forger who copies a real trailer and only changes the payload.
  auto robot = Make(Params({ours}, 0, 1000));
  Bytes real = Signed(robot.get(), "C", Payload(30, 1));
  Bytes forged = Payload(30, 2);
  forged.insert(forged.end(), real.end() - static_cast<std::ptrdiff_t>(kAuthTrailerBytes), real.end());
  CHECK(Check(server.get(), "C", forged) == AuthVerdict::kBadMac);
  CHECK(server->stats().verdicts[static_cast<std::size_t>(AuthVerdict::kBadMac)] == 2);
  CHECK(server->stats().accepted == 0);
}

TEST_CASE("message auth: a team member outside the robot ids is refused, and own looped-back messages are dropped") {
  const TeamKey key = KeyOf(1, 5);
  auto server = Make(Params({key}, kAuthServerSender, 2000, /*max_robots=*/2));
  auto robot5 = Make(Params({key}, 5, 1000, /*max_robots=*/8));
  CHECK(Check(server.get(), "C", Signed(robot5.get(), "C", Payload(8, 1))) == AuthVerdict::kUnknownSender);
  auto robot1 = Make(Params({key}, 1, 1000, 2));
  CHECK(Check(server.get(), "C", Signed(robot1.get(), "C", Payload(8, 1))) == AuthVerdict::kOk);
  CHECK(Check(server.get(), "C", Signed(server.get(), "C", Payload(8, 1))) == AuthVerdict::kOwnEcho);
  CHECK(server->stats().rejected() == 1);  // the echo is not a rejection
  // A robot id the team does not have cannot even sign.
  CHECK_FALSE(MessageAuthenticator::Create(Params({key}, 2, 1000, 2)).ok());
}

TEST_CASE("message auth: replayed, reordered and old-session messages") {
  const TeamKey key = KeyOf(1, 5);
  auto server = Make(Params({key}, kAuthServerSender, 5000));
  auto robot = Make(Params({key}, 0, 1000));
  std::vector<Bytes> sent;
  for (int i = 0; i < 10; ++i) sent.push_back(Signed(robot.get(), "C", Payload(20, static_cast<std::uint8_t>(i))));
  // Reordered delivery: every message once, in any order, is accepted; any repeat is refused.
  for (int i : {3, 0, 9, 1, 2, 8, 4, 7, 6, 5}) CHECK(Check(server.get(), "C", sent[static_cast<std::size_t>(i)]) == AuthVerdict::kOk);
  for (const Bytes& m : sent) CHECK(Check(server.get(), "C", m) == AuthVerdict::kReplayed);
  // A message older than the window.
  const Bytes old = Signed(robot.get(), "C", Payload(20, 50));
  for (std::uint64_t i = 0; i < kReplayWindowMessages; ++i) {
    REQUIRE(Check(server.get(), "C", Signed(robot.get(), "C", Payload(4, 1))) == AuthVerdict::kOk);
  }
  CHECK(Check(server.get(), "C", old) == AuthVerdict::kTooOld);
  // The robot restarts (newer session): accepted, and the old session's messages are now refused.
  auto restarted = Make(Params({key}, 0, 1001));
  CHECK(Check(server.get(), "C", Signed(restarted.get(), "C", Payload(4, 1))) == AuthVerdict::kOk);
  CHECK(Check(server.get(), "C", Signed(robot.get(), "C", Payload(4, 2))) == AuthVerdict::kOldSession);
}

TEST_CASE("message auth: the replay window agrees with a brute-force set of every sequence seen") {
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    ReplayWindow w;
    std::set<std::uint64_t> seen;
    std::uint64_t top = 0;
    for (int op = 0; op < 4000; ++op) {
      // Mostly a little ahead of the top or somewhere behind it (late, repeated or past the window); now and then
      // a jump ahead of more than the window.
      std::uint64_t seq;
      const int r = static_cast<int>(rng() % 100);
      if (r < 50 || top == 0) seq = top + 1 + rng() % 70;
      else if (r < 95) seq = top - std::min<std::uint64_t>(top - 1, rng() % 1100);
      else seq = top + 1 + rng() % 3000;
      const bool expect_too_old = top >= kReplayWindowMessages && seq <= top - kReplayWindowMessages;
      const bool expect_replayed = !expect_too_old && seen.count(seq) > 0;
      const AuthVerdict v = w.Check(42, seq);
      CAPTURE(seq);
      CAPTURE(top);
      if (expect_too_old) {
        CHECK(v == AuthVerdict::kTooOld);
      } else if (expect_replayed) {
        CHECK(v == AuthVerdict::kReplayed);
      } else {
        REQUIRE(v == AuthVerdict::kOk);
        w.Accept(42, seq);
        seen.insert(seq);
        top = std::max(top, seq);
      }
    }
    CHECK(w.Check(41, top + 1) == AuthVerdict::kOldSession);
    CHECK(w.Check(43, 1) == AuthVerdict::kOk);
  }
}

TEST_CASE("message auth: key files are parsed strictly and round-trip through the formatter") {
  const TeamKey a = KeyOf(1, 5), b = KeyOf(2, 99);
  auto ring = ParseTeamKeyring("# team alpha\n\n" + FormatTeamKey(a) + "  " + FormatTeamKey(b), "k");
  REQUIRE(ring.ok());
  REQUIRE(ring->keys.size() == 2);
  CHECK(ring->keys[0].id == 1);
  CHECK(ring->keys[0].bytes == a.bytes);
  CHECK(ring->keys[1].bytes == b.bytes);
  const std::string hex(64, 'a');
  struct Bad {
    std::string text, needle;
  };
  for (const Bad& bad : {Bad{"", "no key"}, Bad{"# only a comment\n", "no key"}, Bad{"kee 1 " + hex, "expected 'key"},
                         Bad{"key 256 " + hex, "0..255"}, Bad{"key x " + hex, "0..255"},
                         Bad{"key 1 " + hex.substr(2), "64 hex digits, found 62"},
                         Bad{"key 1 " + hex.substr(1) + "g", "not a hex digit"}, Bad{"key 1 " + hex + " junk", "after the key"},
                         Bad{"key 1 " + hex + "\nkey 1 " + hex, "listed twice"},
                         Bad{"key 1 " + hex + "\nkey 2 " + hex + "\nkey 3 " + hex + "\nkey 4 " + hex + "\nkey 5 " + hex,
                             "more than 4"}}) {
    auto r = ParseTeamKeyring(bad.text, "team.key");
    CAPTURE(bad.text);
    REQUIRE_FALSE(r.ok());
    CHECK(r.status().message().find(bad.needle) != std::string::npos);
    CHECK(r.status().message().find("team.key") != std::string::npos);
  }
}

TEST_CASE("message auth: key files must be owner-only regular files, and keygen never overwrites") {
  const std::string path = TempPath("team.key");
  auto key = GenerateTeamKey(3);
  REQUIRE(key.ok());
  std::filesystem::remove(path);
  REQUIRE(WriteNewKeyFile(path, FormatTeamKey(*key)).ok());
  struct stat st {};
  REQUIRE(::stat(path.c_str(), &st) == 0);
  CHECK((st.st_mode & 0777) == 0600);
  auto loaded = LoadTeamKeyring(path);
  REQUIRE(loaded.ok());
  CHECK(loaded->keys[0].bytes == key->bytes);
  CHECK(loaded->keys[0].id == 3);
  auto again = WriteNewKeyFile(path, "key 1 " + std::string(64, '0') + "\n");
  CHECK_FALSE(again.ok());
  CHECK(again.message().find("refusing to overwrite") != std::string::npos);
  CHECK(LoadTeamKeyring(path)->keys[0].bytes == key->bytes);
  // Two fresh keys differ (random, not a constant).
  CHECK(GenerateTeamKey(3)->bytes != key->bytes);

  for (mode_t mode : {mode_t{0640}, mode_t{0604}, mode_t{0644}}) {
    WriteFile(path, FormatTeamKey(*key), mode);
    auto r = LoadTeamKeyring(path);
    REQUIRE_FALSE(r.ok());
    CHECK(r.status().message().find("chmod 600 " + path) != std::string::npos);
  }
  WriteFile(path, FormatTeamKey(*key), 0400);
  CHECK(LoadTeamKeyring(path).ok());
  WriteFile(path, std::string(kAuthMaxKeyFileBytes + 1, '#'), 0600);
  CHECK(LoadTeamKeyring(path).status().message().find("more than a key file's") != std::string::npos);
  const std::string dir = TempPath("dir.key");
  std::filesystem::create_directory(dir);
  ::chmod(dir.c_str(), 0700);
  CHECK(LoadTeamKeyring(dir).status().message().find("not a regular file") != std::string::npos);
  const std::string link = TempPath("link.key");
  WriteFile(path, FormatTeamKey(*key), 0600);
  std::filesystem::remove(link);
  std::filesystem::create_symlink(path, link);
  CHECK(LoadTeamKeyring(link).status().message().find("symbolic link") != std::string::npos);
  CHECK(LoadTeamKeyring(TempPath("missing.key")).status().message().find("cannot open") != std::string::npos);
  std::filesystem::remove(link);
  std::filesystem::remove(dir);
  std::filesystem::remove(path);
}

TEST_CASE("message auth: key rotation, old and new keys accepted while both are listed") {
  const TeamKey old_key = KeyOf(1, 5), new_key = KeyOf(2, 77);
  auto server_both = Make(Params({old_key, new_key}, kAuthServerSender, 2000));
  auto server_new = Make(Params({new_key}, kAuthServerSender, 2000));
  auto robot_old = Make(Params({old_key}, 0, 1000));            // not yet updated
  auto robot_new = Make(Params({new_key, old_key}, 1, 1000));   // signs with the new key
  CHECK(Check(server_both.get(), "C", Signed(robot_old.get(), "C", Payload(9, 1))) == AuthVerdict::kOk);
  CHECK(Check(server_both.get(), "C", Signed(robot_new.get(), "C", Payload(9, 1))) == AuthVerdict::kOk);
  CHECK(Check(server_new.get(), "C", Signed(robot_new.get(), "C", Payload(9, 1))) == AuthVerdict::kOk);
  CHECK(Check(server_new.get(), "C", Signed(robot_old.get(), "C", Payload(9, 1))) == AuthVerdict::kUnknownKey);
}

TEST_CASE("message auth: LcmBus signs what it publishes, strips verified trailers and counts what it refuses") {
  const TeamKey key = KeyOf(1, 5);
  LcmBusParams p;
  p.url = "memq://";
  p.authenticate = true;
  p.auth = Params({key}, kAuthServerSender, 2000, 2);
  auto opened = OpenLcmBus(p, {"CM_TEST_.*"});
  REQUIRE(opened.ok());
  LcmBus& bus = **opened;
  auto robot = Make(Params({key}, 1, 1000, 2));
  auto stranger = Make(Params({KeyOf(1, 6)}, 1, 1000, 2));
  const Bytes good = Signed(robot.get(), "CM_TEST_A", Payload(25, 4));
  REQUIRE(bus.PublishRaw("CM_TEST_A", good).ok());
  REQUIRE(bus.PublishRaw("CM_TEST_A", good).ok());                                                // replayed
  REQUIRE(bus.PublishRaw("CM_TEST_A", Payload(25, 4)).ok());                                      // unsigned
  REQUIRE(bus.PublishRaw("CM_TEST_A", Signed(stranger.get(), "CM_TEST_A", Payload(25, 4))).ok());  // other team
  REQUIRE(bus.PublishRaw("CM_TEST_B", good).ok());                                                // re-routed
  REQUIRE(bus.Publish("CM_TEST_A", Payload(10, 1)).ok());  // our own, looped back by memq
  std::vector<BusMessage> got;
  for (int i = 0; i < 20 && got.size() < 1; ++i) {
    REQUIRE(bus.Poll(5).ok());
    BusMessage m;
    while (bus.Take(&m)) got.push_back(m);
  }
  for (int i = 0; i < 5; ++i) REQUIRE(bus.Poll(1).ok());
  BusMessage m;
  while (bus.Take(&m)) got.push_back(m);
  REQUIRE(got.size() == 1);
  CHECK(got[0].bytes == Payload(25, 4));
  CHECK(got[0].sender == 1);
  const std::optional<AuthStats> s = bus.auth_stats();
  REQUIRE(s.has_value());
  CHECK(s->verdicts[static_cast<std::size_t>(AuthVerdict::kReplayed)] == 1);
  CHECK(s->verdicts[static_cast<std::size_t>(AuthVerdict::kNoTrailer)] == 1);
  CHECK(s->verdicts[static_cast<std::size_t>(AuthVerdict::kBadMac)] == 2);
  CHECK(s->verdicts[static_cast<std::size_t>(AuthVerdict::kOwnEcho)] == 1);  // signed correctly, then dropped
  CHECK(s->rejected() == 4);
  CHECK(s->signed_messages == 1);
  CHECK(bus.stats().published_bytes == 4 * (25 + kAuthTrailerBytes) + 25 + 10 + kAuthTrailerBytes);
}

}  // namespace commerge::platform
