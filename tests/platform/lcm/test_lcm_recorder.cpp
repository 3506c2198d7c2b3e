// SPDX-License-Identifier: BSD-3-Clause
// commerge record (platform/lcm/lcm_recorder): the sequence-gap count against a brute-force set model of what
// each sender signed and what reached the log (drops, duplicates, reordering, restarts, unsigned and foreign
// traffic, random bytes); and the recorder on memq:// writing an LCM event log that LCM's own reader returns
// event for event, with the channel filter, the refusal to overwrite and a full disk reported.
#include <doctest/doctest.h>

#include <lcm/lcm.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "platform/lcm/lcm_bus.hpp"
#include "platform/lcm/lcm_recorder.hpp"
#include "platform/lcm/message_auth.hpp"

namespace commerge::platform {
namespace {

using Bytes = std::vector<std::uint8_t>;

std::unique_ptr<MessageAuthenticator> Signer(std::uint16_t sender, std::int64_t session) {
  MessageAuthParams p;
  TeamKey key;
  key.id = 3;
  for (std::size_t i = 0; i < key.bytes.size(); ++i) key.bytes[i] = static_cast<std::uint8_t>(11 * i + 5);
  p.keyring.keys = {key};
  p.sender = sender;
  p.session = session;
  auto a = MessageAuthenticator::Create(p);
  REQUIRE_MESSAGE(a.ok(), a.status().message());
  return std::move(*a);
}

// A signed message whose payload names its sender's sequence number (independent of the trailer parsing).
Bytes SignedMessage(MessageAuthenticator* signer, const std::string& channel, std::size_t payload_bytes) {
  Bytes b(payload_bytes, 0x5A);
  signer->Sign(channel, &b);
  return b;
}

std::string Temp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("cm_test_recorder_" + name)).string();
}

struct Event {
  std::string channel;
  Bytes bytes;
  std::int64_t timestamp = 0;
};

std::vector<Event> ReadLog(const std::string& path) {
  std::vector<Event> events;
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "r");
  REQUIRE(log != nullptr);
  while (lcm_eventlog_event_t* e = lcm_eventlog_read_next_event(log)) {
    const auto* d = static_cast<const std::uint8_t*>(e->data);
    events.push_back(Event{std::string(e->channel, static_cast<std::size_t>(e->channellen)),
                           Bytes(d, d + e->datalen), e->timestamp});
    lcm_eventlog_free_event(e);
  }
  lcm_eventlog_destroy(log);
  return events;
}

TEST_CASE("record: the sequence gap count equals a brute-force count of what each sender signed and the log lacks") {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    SequenceGapCounter counter;
    // Senders: robots 0, 1, 5 and the server; robot 1 restarts once (a new session) in half the trials.
    const std::vector<std::uint16_t> ids = {0, 1, 5, kAuthServerSender};
    std::map<std::pair<std::uint16_t, std::int64_t>, std::unique_ptr<MessageAuthenticator>> signers;
    std::map<std::pair<std::uint16_t, std::int64_t>, std::set<std::uint64_t>> signed_seq, logged_seq;
    std::map<std::uint16_t, std::uint64_t> duplicates;
    std::vector<std::pair<std::pair<std::uint16_t, std::int64_t>, Bytes>> wire;  // what reaches the log, in order
    const double drop = std::uniform_real_distribution<double>(0.0, 0.3)(rng);
    const int restart_at = trial % 2 == 0 ? 150 : -1;
    std::uint64_t unsigned_sent = 0;
    for (int i = 0; i < 300; ++i) {
      const std::uint16_t id = ids[static_cast<std::size_t>(rng() % ids.size())];
      const std::int64_t session = (id == 1 && restart_at >= 0 && i >= restart_at) ? 2000 : 1000;
      auto key = std::make_pair(id, session);
      auto& signer = signers[key];
      if (!signer) signer = Signer(id, session);
      Bytes b = SignedMessage(signer.get(), "COMMERGE_SCANS", 20 + rng() % 100);
      signed_seq[key].insert(signed_seq[key].size() + 1);  // Sign numbers from 1
      if (std::uniform_real_distribution<double>(0.0, 1.0)(rng) < drop) continue;
      logged_seq[key].insert(signed_seq[key].size());
      wire.emplace_back(key, b);
      if (rng() % 20 == 0) {  // a network duplicate, logged twice
        wire.emplace_back(key, b);
        ++duplicates[id];
      }
      if (rng() % 25 == 0) {  // unsigned traffic in between
        wire.emplace_back(std::make_pair(std::uint16_t{0}, std::int64_t{-1}), Bytes(7 + rng() % 60, 1));
        ++unsigned_sent;
      }
    }
    // Reorder by short random swaps (LCM over UDP keeps order per sender, the network need not).
    // A swap never puts a restarted sender's new session before its old one (that message would be stale).
    for (std::size_t k = 1; k < wire.size(); ++k) {
      const bool across_restart =
          wire[k - 1].first.first == wire[k].first.first && wire[k - 1].first.second != wire[k].first.second;
      if (rng() % 10 == 0 && !across_restart) std::swap(wire[k - 1], wire[k]);
    }
    for (const auto& w : wire) counter.Count(w.second.data(), w.second.size());

    // Brute force: per sender session, the numbers between the lowest and highest logged that are not logged
    // (numbers the sender signed after the last logged one are invisible to any receiver).
    std::uint64_t want_missing = 0;
    std::map<std::uint16_t, std::pair<std::int64_t, std::uint64_t>> newest;  // id -> (session, missing)
    std::map<std::uint16_t, std::uint64_t> received;
    for (const auto& [key, logged] : logged_seq) {
      if (logged.empty()) continue;
      const std::uint64_t span = *logged.rbegin() - *logged.begin() + 1;
      want_missing += span - logged.size();
      if (key.second >= newest[key.first].first) {
        newest[key.first] = {key.second, span - logged.size()};
        received[key.first] = logged.size();
      }
    }
    CAPTURE(trial);
    CHECK(counter.missing() == want_missing);
    CHECK(counter.unsigned_messages() == unsigned_sent);
    CHECK(counter.stale_messages() == 0);
    const std::vector<SenderSequences> senders = counter.senders();
    CHECK(senders.size() == newest.size());
    for (const SenderSequences& s : senders) {
      CAPTURE(s.sender);
      REQUIRE(newest.count(s.sender) == 1);
      CHECK(s.session == newest[s.sender].first);
      CHECK(s.missing == newest[s.sender].second);
      CHECK(s.received == received[s.sender]);
      CHECK(s.duplicates == duplicates[s.sender]);
    }
  }
}

TEST_CASE("record: the gap count survives random bytes, foreign senders and old sessions") {
  SequenceGapCounter counter;
  auto server = Signer(kAuthServerSender, 50);
  auto robot2 = Signer(2, 50);
  auto old_session = Signer(kAuthServerSender, 40);
  Bytes a = SignedMessage(server.get(), "X", 10);
  Bytes stale = SignedMessage(old_session.get(), "X", 10);
  Bytes other = SignedMessage(robot2.get(), "X", 10);
  other[other.size() - kAuthTrailerBytes + 4] = 0;  // sender 200: neither a robot nor the server (MAC unchecked)
  other[other.size() - kAuthTrailerBytes + 5] = 200;
  counter.Count(a.data(), a.size());
  counter.Count(stale.data(), stale.size());
  counter.Count(other.data(), other.size());
  counter.Count(nullptr, 0);
  std::mt19937 rng(3);
  for (int i = 0; i < 2000; ++i) {
    Bytes junk(rng() % 200);
    for (auto& b : junk) b = static_cast<std::uint8_t>(rng());
    if (junk.size() >= kAuthTrailerBytes && i % 2 == 0) {  // a plausible trailer head with random fields
      junk[junk.size() - kAuthTrailerBytes] = 'C';
      junk[junk.size() - kAuthTrailerBytes + 1] = 'A';
      junk[junk.size() - kAuthTrailerBytes + 2] = 1;
      junk[junk.size() - kAuthTrailerBytes + 6] = 0;
      junk[junk.size() - kAuthTrailerBytes + 7] = 0;
    }
    counter.Count(junk.data(), junk.size());
  }
  CHECK(counter.stale_messages() >= 1);
  CHECK(counter.unknown_senders() >= 1);
  CHECK(counter.senders().size() <= kAuthMaxRobots + 1);

  // A duplicate that arrives beyond the window is taken as new: the count saturates at 0 missing.
  SequenceGapCounter late;
  auto robot = Signer(3, 9);
  std::vector<Bytes> all;
  for (std::uint64_t i = 0; i < kReplayWindowMessages + 200; ++i) all.push_back(SignedMessage(robot.get(), "X", 4));
  for (const Bytes& b : all) late.Count(b.data(), b.size());
  late.Count(all[0].data(), all[0].size());
  CHECK(late.missing() == 0);
  REQUIRE(late.senders().size() == 1);
  CHECK(late.senders()[0].received == all.size() + 1);
  CHECK(late.senders()[0].missing == 0);
  auto restarted = Signer(3, 10);  // a new session archives the old one's count, still 0
  Bytes next = SignedMessage(restarted.get(), "X", 4);
  late.Count(next.data(), next.size());
  CHECK(late.missing() == 0);
  CHECK(late.senders()[0].older_sessions_missing == 0);
}

LcmRecorderParams MemqParams(const std::string& path) {
  LcmRecorderParams p;
  p.url = "memq://";
  p.out_path = path;
  p.overwrite = true;
  return p;
}

TEST_CASE("record: the log holds every message of the recorded channels in order, as LCM's reader returns them") {
  const std::string path = Temp("order.lcmlog");
  auto rec = LcmRecorder::Open(MemqParams(path));
  REQUIRE_MESSAGE(rec.ok(), rec.status().message());
  LcmBus* bus = (*rec)->bus_for_testing();
  auto robot = Signer(1, 77);
  std::vector<std::pair<std::string, Bytes>> sent;
  const std::vector<std::string> channels = {"COMMERGE_KEYFRAMES", "COMMERGE_SCANS", "COMMERGE_MERGE_RESULT",
                                             "COMMERGE_LIDAR_SCAN", "OTHER_TEAM"};
  std::mt19937 rng(5);
  std::vector<std::uint64_t> logged_sequences;  // the robot signs 1, 2, ...
  for (int i = 0; i < 600; ++i) {
    const std::string& ch = channels[static_cast<std::size_t>(rng() % channels.size())];
    Bytes b = SignedMessage(robot.get(), ch, 1 + rng() % 1500);
    if (i % 97 == 50) continue;  // signed but never published
    REQUIRE(bus->PublishRaw(ch, b).ok());
    if (ch.rfind("COMMERGE_", 0) == 0 && ch != "COMMERGE_LIDAR_SCAN") {
      sent.emplace_back(ch, b);
      logged_sequences.push_back(static_cast<std::uint64_t>(i) + 1);
    }
    if (i % 50 == 0) REQUIRE((*rec)->Poll(0).ok());  // the first starts the bus's receive thread
  }
  // The receive thread queues the rest while nobody polls; Close writes what is queued.
  const std::int64_t end = MonotonicUs() + 5000000;
  while (bus->stats().received < sent.size() && MonotonicUs() < end) REQUIRE((*rec)->Poll(10).ok());
  REQUIRE((*rec)->Close().ok());
  CHECK((*rec)->stats().messages == sent.size());
  CHECK((*rec)->stats().dropped == 0);
  const std::vector<Event> events = ReadLog(path);
  REQUIRE(events.size() == sent.size());
  for (std::size_t i = 0; i < events.size(); ++i) {
    CAPTURE(i);
    CHECK(events[i].channel == sent[i].first);
    CHECK(events[i].bytes == sent[i].second);
    CHECK(events[i].timestamp > 0);
    if (i > 0) CHECK(events[i].timestamp >= events[i - 1].timestamp);
  }
  // Never published or on a channel the filter leaves out: both are missing from the log, and counted (which
  // is why the recorder's help asks for every channel the senders sign).
  REQUIRE(logged_sequences.size() >= 2);
  const std::uint64_t span = logged_sequences.back() - logged_sequences.front() + 1;
  CHECK((*rec)->sequences().missing() == span - logged_sequences.size());
  REQUIRE((*rec)->sequences().senders().size() == 1);
  CHECK((*rec)->sequences().senders()[0].sender == 1);
  CHECK((*rec)->sequences().senders()[0].received == logged_sequences.size());
  CHECK_FALSE((*rec)->Poll(0).ok());  // closed
  std::filesystem::remove(path);
}

TEST_CASE("record: Drain writes every message still arriving, returns their count, and returns 0 on a quiet bus") {
  const std::string path = Temp("drain.lcmlog");
  auto rec = LcmRecorder::Open(MemqParams(path));
  REQUIRE_MESSAGE(rec.ok(), rec.status().message());
  LcmBus* bus = (*rec)->bus_for_testing();
  auto robot = Signer(2, 9);
  REQUIRE((*rec)->Poll(0).ok());  // starts the bus's receive thread
  // Nobody polls while these are published: they wait in LCM and the bus's queue, as a mission's last messages
  // do when the stop request comes.
  const std::size_t sent = 300;
  for (std::size_t i = 0; i < sent; ++i) {
    REQUIRE(bus->PublishRaw("COMMERGE_ROUND", SignedMessage(robot.get(), "COMMERGE_ROUND", 200)).ok());
  }
  auto drained = (*rec)->Drain(200, 10000);
  REQUIRE_MESSAGE(drained.ok(), drained.status().message());
  CHECK(*drained == sent);
  CHECK((*rec)->stats().messages == sent);
  auto quiet = (*rec)->Drain(50, 10000);
  REQUIRE(quiet.ok());
  CHECK(*quiet == 0);
  REQUIRE((*rec)->Close().ok());
  CHECK(ReadLog(path).size() == sent);
  CHECK((*rec)->sequences().missing() == 0);
  CHECK_FALSE((*rec)->Drain(10, 10).ok());  // closed
  std::filesystem::remove(path);
}

TEST_CASE("record: an existing log is refused without overwrite, a missing directory and a full disk are named") {
  const std::string path = Temp("exists.lcmlog");
  {
    auto first = LcmRecorder::Open(MemqParams(path));
    REQUIRE(first.ok());
  }
  LcmRecorderParams p = MemqParams(path);
  p.overwrite = false;
  auto second = LcmRecorder::Open(p);
  REQUIRE_FALSE(second.ok());
  CHECK(second.status().message().find(path) != std::string::npos);
  CHECK(second.status().message().find("--force") != std::string::npos);
  std::filesystem::remove(path);

  auto nodir = LcmRecorder::Open(MemqParams("/nonexistent-dir-cm/x.lcmlog"));
  REQUIRE_FALSE(nodir.ok());
  CHECK(nodir.status().message().find("/nonexistent-dir-cm/x.lcmlog") != std::string::npos);

  p = MemqParams("");
  CHECK_FALSE(LcmRecorder::Open(p).ok());
  p = MemqParams(path);
  p.lcm_queue_capacity = 0;
  CHECK_FALSE(LcmRecorder::Open(p).ok());

  if (std::filesystem::exists("/dev/full")) {
    auto full = LcmRecorder::Open(MemqParams("/dev/full"));
    REQUIRE(full.ok());
    Bytes big(60000, 1);
    for (int i = 0; i < 4; ++i) REQUIRE((*full)->bus_for_testing()->PublishRaw("COMMERGE_SCANS", big).ok());
    Status st;
    const std::int64_t end = MonotonicUs() + 5000000;
    while (st.ok() && (*full)->bus_for_testing()->stats().received < 4 && MonotonicUs() < end) st = (*full)->Poll(10);
    if (st.ok()) st = (*full)->Poll(0);
    if (st.ok()) st = (*full)->Flush();
    REQUIRE_FALSE(st.ok());
    CHECK(st.message().find("/dev/full") != std::string::npos);
  }
}

}  // namespace
}  // namespace commerge::platform
