// SPDX-License-Identifier: BSD-3-Clause
// Scan fixtures shared by the cloud, store, spill-file and agent tests: a cloud encoded as the robot stores it
// (core/cloud/scan_codec), cut into the scan_chunk_t messages the robot sends (the same ScanChunkRange the robot
// and the server use), and a deterministic cloud.
#pragma once

#include <doctest/doctest.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/agent/messages.hpp"
#include "core/cloud/scan_codec.hpp"

namespace commerge::test {

/// `points` encoded by EncodeScan into a buffer of exactly the bytes written (REQUIREs success); the encoder's
/// report in *info_out when given.
inline std::vector<std::uint8_t> EncodeForTest(const std::vector<PointXYZI>& points,
                                               ScanEncodeInfo* info_out = nullptr) {
  std::vector<std::uint8_t> out(EncodedScanBytes(points.size()));
  const Result<ScanEncodeInfo> info = EncodeScan(Span<const PointXYZI>(points), Span<std::uint8_t>(out));
  REQUIRE_MESSAGE(info.ok(), info.status().ToString());
  out.resize(info->bytes_written);
  if (info_out != nullptr) *info_out = *info;
  return out;
}

/// The chunks of one encoded scan, each payload at most `max_payload` bytes.
inline std::vector<ScanChunk> ChunksOf(int robot, std::uint32_t keyframe, const std::vector<std::uint8_t>& bytes,
                                       std::size_t max_payload = kMaxScanChunkPayloadBytes) {
  std::vector<ScanChunk> out;
  const std::uint64_t n = ScanChunkCount(bytes.size(), max_payload);
  for (std::uint64_t i = 0; i < n; ++i) {
    const ChunkRange r = ScanChunkRange(bytes.size(), n, i);
    ScanChunk c;
    c.robot_id = robot;
    c.keyframe = keyframe;
    c.total_bytes = static_cast<std::uint32_t>(bytes.size());
    c.chunk_index = static_cast<std::uint16_t>(i);
    c.num_chunks = static_cast<std::uint16_t>(n);
    c.payload.assign(bytes.begin() + static_cast<std::ptrdiff_t>(r.offset),
                     bytes.begin() + static_cast<std::ptrdiff_t>(r.offset + r.size));
    out.push_back(c);
  }
  return out;
}

/// n points on a small repeating lattice (encodes to a known size: 6 bytes a point plus the header).
inline std::vector<PointXYZI> LatticePoints(std::size_t n) {
  std::vector<PointXYZI> p;
  for (std::size_t i = 0; i < n; ++i) {
    p.push_back({static_cast<float>(i % 37) * 0.5f, static_cast<float>(i % 11), static_cast<float>(i % 5), 0.0f});
  }
  return p;
}

}  // namespace commerge::test
