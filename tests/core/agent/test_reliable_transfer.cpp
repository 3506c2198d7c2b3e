// SPDX-License-Identifier: BSD-3-Clause
// Reliable delivery between RobotLink and ServerLink over a simulated link that drops, duplicates, delays and
// reorders messages (seeded; the mission in reliable_transfer_support.hpp). The reference is the robots' own
// state: after the mission every keyframe's record at the server decodes to exactly what the robot's record
// encoder produces from its final descriptor, every requested scan at the server is byte-identical to the robot's
// stored encoded scan, and poses agree within the agent's pose-update thresholds. Also: no retransmission on a
// perfect link, batching delay, a robot heard late, a restarted server, stale statuses and foreign messages, and
// the token bucket's long-run rate. The server's own side (sessions, rounds, requests, replay): test_server_link.cpp.
#include <doctest/doctest.h>

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/agent/merge_server.hpp"
#include "core/agent/robot_link.hpp"
#include "core/agent/server_link.hpp"
#include "tests/core/agent/reliable_transfer_support.hpp"

using namespace commerge;
using commerge::test::Batching;
using commerge::test::LinkModel;
using commerge::test::Mission;
using commerge::test::SendAllParams;

TEST_CASE("Reliable transfer: a perfect link delivers everything once, with no re-announcement or retransmission") {
  Mission m(2, 12, LinkModel{}, 1, SendAllParams());
  m.RunUntil(30000000);
  m.CheckAllKeyframesDelivered();
  m.CheckAllScansDelivered();
  CHECK(m.merge_results_ >= 1);
  CHECK(m.bytes_resent_ == 0);
  for (auto& r : m.robots_) {
    CHECK(r->link->stats().keyframes_requeued == 0);
    CHECK(r->link->stats().chunks_resent == 0);
    CHECK(r->link->stats().pose_updates_requeued == 0);
    CHECK(r->link->stats().requests_completed >= 1);
  }
  CHECK(m.merge_->stats().duplicate_chunks == 0);
  CHECK(m.refused_ == 0);
}

TEST_CASE("Reliable transfer: 10 and 50 percent loss with duplicates and reordering still deliver every keyframe and scan") {
  for (double loss : {0.1, 0.5}) {
    CAPTURE(loss);
    LinkModel link;
    link.loss = loss;
    link.duplicate = 0.1;
    link.jitter_us = 300000;  // up to 0.3 s extra: messages overtake each other
    Mission m(2, 12, link, 7, SendAllParams());
    m.RunUntil(120000000);
    m.CheckAllKeyframesDelivered();
    m.CheckAllScansDelivered();
    CHECK(m.merge_results_ >= 1);
    CHECK(m.bytes_resent_ > 0);
    std::uint64_t requeued = 0;
    for (auto& r : m.robots_) requeued += r->link->stats().keyframes_requeued + r->link->stats().chunks_resent;
    CHECK(requeued > 0);
  }
}

TEST_CASE("Reliable transfer: new keyframes wait up to batch_delay_s to share a batch, and all arrive under loss") {
  // A keyframe every 0.1 s, 16 records a batch: with 2 s of delay 12 keyframes go in one batch when the delay
  // since the first has passed; with none, one batch each.
  for (double loss : {0.0, 0.3}) {
    for (double delay : {0.0, 2.0}) {
      CAPTURE(loss);
      CAPTURE(delay);
      LinkModel link;
      link.loss = loss;
      Mission m(2, 12, link, 9, SendAllParams(), Batching{delay, 16});
      m.RunUntil(90000000);
      m.CheckAllKeyframesDelivered();
      CHECK(m.merge_results_ >= 1);
      if (loss > 0.0) continue;
      for (int robot = 0; robot < 2; ++robot) {
        CAPTURE(robot);
        std::vector<std::pair<std::int64_t, std::size_t>> batches;  // (delivered at, records)
        for (const auto& [t, up] : m.recorded_) {
          if (up.kind == RobotOutgoing::Kind::kKeyframeBatch && up.batch.robot_id == robot) {
            batches.emplace_back(t, up.batch.num_records());
          }
        }
        if (delay == 0.0) {
          CHECK(batches.size() == 12);
          continue;
        }
        REQUIRE(batches.size() == 1);
        CHECK(batches[0].second == 12);
        // The first keyframe is made at 0.1 s (the first scan at 0 makes keyframe 0 too); its batch leaves 2 s
        // later and arrives 20 ms after that.
        CHECK(batches[0].first >= 2000000);
        CHECK(batches[0].first <= 2200000);
      }
    }
  }
}

TEST_CASE("Reliable transfer: a robot whose first messages were all lost is heard once its link recovers") {
  // The server never heard of robot 1 during its first 10 s, so it sends it no status; robot 1 announces one
  // keyframe again after three resend timeouts of silence, the server learns of it, and the rest follows.
  LinkModel link;
  link.mute_robot = 1;
  link.mute_until_us = 10000000;
  Mission m(2, 12, link, 3, SendAllParams(), Batching{2.0, 16});
  m.RunUntil(9000000);
  CHECK(m.merge_->robot(1).size() == 0);
  CHECK(m.robots_[1]->link->stats().statuses == 0);
  m.RunUntil(60000000);
  m.CheckAllKeyframesDelivered();
  CHECK(m.robots_[1]->link->stats().keyframes_requeued >= 1);
  CHECK(m.robots_[0]->link->stats().keyframes_requeued == 0);  // robot 0 heard statuses all along
}

TEST_CASE("Reliable transfer: a 2 s one-way delay still delivers everything and merges every robot") {
  LinkModel link;
  link.delay_us = 2000000;
  ServerLinkParams params = SendAllParams();
  params.mode = ExchangeMode::kStageABC;
  params.round_min_new_keyframes = 6;  // rounds start while the robots are still mapping
  Mission m(2, 12, link, 9, params);
  m.RunUntil(120000000);
  m.CheckAllKeyframesDelivered();
  const MergeResultMessage& r = m.server_->last_result();
  REQUIRE(r.in_world.size() == 2);
  CHECK(r.in_world[0] == 1);
  CHECK(r.in_world[1] == 1);
  // The last round saw every keyframe (what `commerge robot` waits for before it ends), and the server is
  // settled (what `commerge server --exit-when-merged` waits for).
  REQUIRE(r.keyframes.size() == 2);
  CHECK(r.keyframes[0] == m.robots_[0]->agent->mapper().num_keyframes());
  CHECK(r.keyframes[1] == m.robots_[1]->agent->mapper().num_keyframes());
  CHECK(m.server_->Settled(m.now_us_));
  CHECK(m.server_->rounds_merged() >= 2);  // rounds started while the robots were mapping
}

TEST_CASE("Reliable transfer: a restarted server gets every keyframe again and finishes the merge") {
  Mission m(2, 12, LinkModel{}, 3, SendAllParams());
  m.RunUntil(800000);  // part of the mission streamed
  m.StartServer(900);  // the server restarts: it lost everything
  m.RunUntil(40000000);
  m.CheckAllKeyframesDelivered();
  m.CheckAllScansDelivered();
  CHECK(m.merge_results_ >= 1);
  for (auto& r : m.robots_) {
    CHECK(r->link->stats().server_restarts == 1);
    CHECK(r->link->server_session() == 900);
  }
}

TEST_CASE("Reliable transfer: a status older than the robot's request does not withdraw it") {
  // Seen in the dup-reorder fault test: a status from before a round (no request) arrived after that round's
  // policy and made the robot drop the request, which then stayed unanswered until the server's timeout.
  Mission m(2, 4, LinkModel{}, 5, SendAllParams());
  m.RunUntil(600000);
  RobotLink& link = *m.robots_[0]->link;
  REQUIRE(m.robots_[0]->agent->mapper().num_keyframes() > 0);
  ScanRequest request;
  request.utime_us = m.now_us_;
  request.robot_id = 0;
  request.server_session = m.server_->session();
  request.request_id = 99;
  request.keyframes = {0};
  REQUIRE(link.OnScanRequest(request, m.now_us_).ok());
  REQUIRE(link.queued_chunks() > 0);
  TransferStatus stale = m.server_->MakeStatus(0, m.now_us_ - 200000);
  stale.request_id = -1;
  stale.request_complete = false;
  stale.missing.clear();
  REQUIRE(stale.utime_us < request.utime_us);
  CHECK(link.OnTransferStatus(stale, m.now_us_).ok());
  CHECK(link.active_request() == 99);
  CHECK(link.queued_chunks() > 0);
  TransferStatus later = stale;  // the server withdrew the request after issuing it: drop it
  later.utime_us = request.utime_us + 1000000;
  CHECK(link.OnTransferStatus(later, m.now_us_ + 1000000).ok());
  CHECK(link.queued_chunks() == 0);
}

TEST_CASE("Reliable transfer: chunks outside the active request and statuses for other robots are refused") {
  Mission m(2, 4, LinkModel{}, 5, SendAllParams());
  m.RunUntil(300000);
  ScanChunk chunk;
  chunk.robot_id = 0;
  chunk.request_id = 77;
  chunk.keyframe = 0;
  chunk.total_bytes = 30;
  chunk.num_chunks = 1;
  chunk.payload.assign(30, 1);
  const std::size_t held = m.merge_->scans_received();
  CHECK_FALSE(m.server_->OnScanChunk(chunk, m.now_us_).ok());
  CHECK(m.merge_->scans_received() == held);
  TransferStatus foreign = m.server_->MakeStatus(1, m.now_us_);
  CHECK_FALSE(m.robots_[0]->link->OnTransferStatus(foreign, m.now_us_).ok());
  CHECK(m.robots_[0]->link->stats().foreign_statuses == 1);
  ScanRequest other;
  other.robot_id = 1;
  CHECK_FALSE(m.robots_[0]->link->OnScanRequest(other, m.now_us_).ok());
  KeyframeBatch no_session;
  no_session.robot_id = 0;
  CHECK_FALSE(m.server_->OnKeyframeBatch(no_session, m.now_us_).ok());
}

TEST_CASE("Token bucket: the bytes let through never exceed rate x time + burst, and it does not starve") {
  TokenBucket bucket(1000.0, 500.0);
  std::int64_t sent = 0;
  const std::int64_t end_us = 10000000;
  for (std::int64_t t = 0; t <= end_us; t += 1000) {
    while (bucket.CanSend(t)) {
      bucket.Take(120);
      sent += 120;
    }
    if (t > 0) REQUIRE(sent <= static_cast<std::int64_t>(1000.0 * static_cast<double>(t) * 1e-6 + 500.0 + 120.0));
  }
  CHECK(sent >= 10000 - 120);  // 10 s at 1000 B/s
  TokenBucket empty(1000.0, 0.0);
  CHECK(empty.CanSend(0));
  empty.Take(2000);
  CHECK_FALSE(empty.CanSend(0));
  CHECK(empty.WaitUs(0) == 2000000);
  CHECK(empty.CanSend(2000000));
  TokenBucket unlimited(0.0, 0.0);
  unlimited.Take(1 << 20);
  CHECK(unlimited.CanSend(0));
}
