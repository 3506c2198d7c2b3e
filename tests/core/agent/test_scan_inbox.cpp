// SPDX-License-Identifier: BSD-3-Clause
// The merge server's scan inbox (core/agent/scan_inbox.hpp): scan chunks are reassembled whatever their order,
// de-duplicated (a duplicate is counted, not refused) and CRC-checked, bounded in bytes and in scans held;
// ResetRobot drops one robot's complete and partial scans; ScanInbox::Create names the field out of range.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/agent/merge_server.hpp"
#include "core/agent/scan_inbox.hpp"
#include "tests/core/agent/scan_chunk_fixtures.hpp"
#include "tests/core/agent/server_fixture.hpp"

using namespace commerge;
using commerge::test::ChunksOf;
using commerge::test::EncodeForTest;
using commerge::test::LatticePoints;

TEST_CASE("Merge server reassembles scan chunks in any order, ignores duplicates and refuses corrupt scans") {
  MergeServerParams params;
  params.max_scan_bytes = 1 << 16;
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, params);
  MergeServer& server = *server_owner;
  const std::vector<std::uint8_t> scan = EncodeForTest(LatticePoints(1000));  // 6012 bytes
  std::vector<ScanChunk> chunks = ChunksOf(1, 4, scan, 700);
  REQUIRE(chunks.size() == 9);
  std::reverse(chunks.begin(), chunks.end());
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    REQUIRE(server.OnScanChunk(chunks[i]).ok());
    if (i == 3) REQUIRE(server.OnScanChunk(chunks[i]).ok());  // a retransmission
    CHECK(server.has_scan(1, 4) == (i + 1 == chunks.size()));
  }
  CHECK(server.stats().duplicate_chunks == 1);
  CHECK(server.OnScanChunk(chunks[0]).ok());  // after completion: a duplicate too
  CHECK(server.stats().duplicate_chunks == 2);
  CHECK(server.scans_received() == 1);
  CHECK(server.scan_bytes_held() == scan.size());

  // A flipped payload byte: the CRC refuses the scan, which is not kept.
  std::vector<ScanChunk> bad = ChunksOf(0, 2, scan, 700);
  bad[3].payload[5] ^= 0x01;
  Status last;
  for (const ScanChunk& c : bad) last = server.OnScanChunk(c);
  CHECK(last.code() == StatusCode::kDataLoss);
  CHECK_FALSE(server.has_scan(0, 2));
  CHECK(server.stats().corrupt_scans == 1);
  CHECK(server.scan_bytes_held() == scan.size());

  // A payload of the wrong size for its index, and an index beyond the count: refused, nothing held for them.
  std::vector<ScanChunk> odd = ChunksOf(0, 3, scan, 700);
  odd[1].payload.pop_back();
  CHECK(server.OnScanChunk(odd[1]).code() == StatusCode::kInvalidArgument);
  CHECK(server.scan_bytes_held() == scan.size());
  odd[2].chunk_index = odd[2].num_chunks;
  CHECK_FALSE(server.OnScanChunk(odd[2]).ok());

  // The byte budget: scans beyond max_scan_bytes are refused and counted.
  std::size_t refused = 0;
  for (std::uint32_t k = 10; k < 30; ++k) {
    for (const ScanChunk& c : ChunksOf(1, k, scan, 1200)) refused += !server.OnScanChunk(c).ok();
  }
  CHECK(refused > 0);
  CHECK(server.stats().chunks_over_budget > 0);
  CHECK(server.scan_bytes_held() <= params.max_scan_bytes);
  server.ClearScans();
  CHECK(server.scans_received() == 0);
  CHECK(server.scan_bytes_held() == 0);
}

TEST_CASE("Merge server bounds the number of scans it holds, whatever their size") {
  MergeServerParams params;
  params.max_scans_held = 3;
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, params);
  MergeServer& server = *server_owner;
  const std::vector<std::uint8_t> tiny = EncodeForTest(LatticePoints(2));
  std::size_t accepted = 0;
  for (std::uint32_t k = 0; k < 6; ++k) {
    for (const ScanChunk& c : ChunksOf(0, k, tiny, 1200)) accepted += server.OnScanChunk(c).ok();
  }
  CHECK(accepted == 3);
  CHECK(server.scans_received() == 3);
  CHECK(server.stats().chunks_over_budget == 3);
}

TEST_CASE("Scan inbox: Create refuses max_robots outside 2..64, max_scans_held 0 and max_scan_points 0, naming them") {
  CHECK(ScanInbox::Create(2, ScanInboxLimits{}).ok());
  CHECK(ScanInbox::Create(64, ScanInboxLimits{}).ok());
  for (int robots : {1, 65}) {
    CAPTURE(robots);
    const auto inbox = ScanInbox::Create(robots, ScanInboxLimits{});
    REQUIRE_FALSE(inbox.ok());
    CHECK(inbox.status().code() == StatusCode::kInvalidArgument);
    CHECK(inbox.status().message().find("max_robots = " + std::to_string(robots)) != std::string::npos);
  }
  ScanInboxLimits no_scans;
  no_scans.max_scans_held = 0;
  const auto held = ScanInbox::Create(2, no_scans);
  REQUIRE_FALSE(held.ok());
  CHECK(held.status().code() == StatusCode::kInvalidArgument);
  CHECK(held.status().message().find("max_scans_held") != std::string::npos);
  ScanInboxLimits no_points;
  no_points.max_scan_points = 0;
  const auto points = ScanInbox::Create(2, no_points);
  REQUIRE_FALSE(points.ok());
  CHECK(points.status().code() == StatusCode::kInvalidArgument);
  CHECK(points.status().message().find("max_scan_points = 0") != std::string::npos);
}

TEST_CASE("Scan inbox: a duplicate chunk is counted, not refused, and ResetRobot drops only that robot's scans") {
  auto created = ScanInbox::Create(3, ScanInboxLimits{});
  REQUIRE(created.ok());
  ScanInbox& inbox = *created;
  MergeServerStats stats;
  int allocated = 0;  // new partial scans (note_memory)
  const auto note = [&allocated] { ++allocated; };
  // Encoded scans are 12 + 6 n bytes: 100 points 612, 50 points 312, 200 points 1212.
  const std::vector<std::uint8_t> scan100 = EncodeForTest(LatticePoints(100));
  const std::vector<std::uint8_t> scan50 = EncodeForTest(LatticePoints(50));
  const std::vector<std::uint8_t> scan200 = EncodeForTest(LatticePoints(200));
  REQUIRE(scan100.size() == 612);
  REQUIRE(scan50.size() == 312);
  REQUIRE(scan200.size() == 1212);

  // Robot 0 keyframe 1 in 3 chunks of 204 bytes (612 / 300 rounded up).
  const std::vector<ScanChunk> three = ChunksOf(0, 1, scan100, 300);
  REQUIRE(three.size() == 3);
  REQUIRE(inbox.OnScanChunk(three[0], &stats, note).ok());
  CHECK(inbox.OnScanChunk(three[0], &stats, note).ok());  // a retransmission before the scan is complete
  std::uint16_t num_chunks = 0;
  const std::vector<std::uint8_t>* have = nullptr;
  REQUIRE(inbox.PartialScan(0, 1, &num_chunks, &have));
  CHECK(num_chunks == 3);
  CHECK(*have == std::vector<std::uint8_t>{1, 0, 0});
  CHECK(stats.duplicate_chunks == 1);
  CHECK(stats.chunks == 1);
  CHECK(allocated == 1);
  CHECK(inbox.scan_bytes_held() == 612);  // a partial scan holds its whole size
  REQUIRE(inbox.OnScanChunk(three[2], &stats, note).ok());
  REQUIRE(inbox.OnScanChunk(three[1], &stats, note).ok());
  CHECK(inbox.has_scan(0, 1));
  CHECK_FALSE(inbox.PartialScan(0, 1, &num_chunks, &have));
  CHECK(inbox.OnScanChunk(three[1], &stats, note).ok());  // and after it
  CHECK(stats.duplicate_chunks == 2);
  CHECK(stats.chunks == 3);
  CHECK(stats.scans_completed == 1);
  CHECK(stats.rejected_chunks == 0);
  CHECK(allocated == 1);

  // Robot 1: keyframes 1 and 2 complete (one chunk each) and half of keyframe 3; robot 0 half of keyframe 5;
  // robot 2 keyframe 1.
  for (std::uint32_t k : {1u, 2u}) REQUIRE(inbox.OnScanChunk(ChunksOf(1, k, scan50)[0], &stats, note).ok());
  const std::vector<ScanChunk> halves = ChunksOf(1, 3, scan200, 700);
  REQUIRE(halves.size() == 2);
  REQUIRE(inbox.OnScanChunk(halves[0], &stats, note).ok());
  REQUIRE(inbox.OnScanChunk(ChunksOf(0, 5, scan200, 700)[0], &stats, note).ok());
  REQUIRE(inbox.OnScanChunk(ChunksOf(2, 1, scan50)[0], &stats, note).ok());
  CHECK(allocated == 6);
  CHECK(inbox.scans_received() == 4);
  CHECK(inbox.scan_bytes_held() == 612 + 2 * 312 + 1212 + 1212 + 312);

  inbox.ResetRobot(1);
  CHECK(inbox.scans_received() == 2);
  CHECK(inbox.scan_bytes_held() == 612 + 1212 + 312);
  CHECK_FALSE(inbox.has_scan(1, 1));
  CHECK_FALSE(inbox.has_scan(1, 2));
  CHECK(inbox.scan_bytes(1, 1) == nullptr);
  CHECK_FALSE(inbox.PartialScan(1, 3, &num_chunks, &have));
  CHECK(inbox.has_scan(0, 1));
  REQUIRE(inbox.scan_bytes(0, 1) != nullptr);
  CHECK(*inbox.scan_bytes(0, 1) == scan100);
  CHECK(inbox.has_scan(2, 1));
  REQUIRE(inbox.PartialScan(0, 5, &num_chunks, &have));
  CHECK(num_chunks == 2);
  CHECK(*have == std::vector<std::uint8_t>{1, 0});
  CHECK(stats.duplicate_chunks == 2);

  // The robot's scans are taken again as new ones; robots outside 0..2 are ignored.
  REQUIRE(inbox.OnScanChunk(ChunksOf(1, 1, scan50)[0], &stats, note).ok());
  CHECK(inbox.has_scan(1, 1));
  CHECK(stats.duplicate_chunks == 2);
  inbox.ResetRobot(-1);
  inbox.ResetRobot(3);
  CHECK(inbox.scans_received() == 3);
  CHECK(inbox.scan_bytes_held() == 612 + 1212 + 312 + 312);
}
