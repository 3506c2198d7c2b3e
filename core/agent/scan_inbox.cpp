// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/scan_inbox.hpp"

#include <algorithm>
#include <string>
#include <utility>

#include "core/agent/server_rejection.hpp"
#include "core/cloud/scan_codec.hpp"

namespace commerge {

Result<ScanInbox> ScanInbox::Create(int max_robots, const ScanInboxLimits& limits) {
  if (max_robots < 2 || max_robots > kMaxRobotId + 1) {
    return InvalidArgument("max_robots = " + std::to_string(max_robots) + " is outside 2.." +
                           std::to_string(kMaxRobotId + 1));
  }
  if (limits.max_scans_held < 1) return InvalidArgument("max_scans_held must be >= 1");
  if (limits.max_scan_points < 1 || limits.max_scan_points > kMaxEncodedScanPoints) {
    return InvalidArgument("max_scan_points = " + std::to_string(limits.max_scan_points) + " is outside 1.." +
                           std::to_string(kMaxEncodedScanPoints));
  }
  ScanInbox inbox;
  inbox.max_robots_ = max_robots;
  inbox.limits_ = limits;
  return inbox;
}

bool ScanInbox::has_scan(int robot, std::uint32_t keyframe) const {
  return scans_.count(Key(robot, keyframe)) != 0;
}

const std::vector<std::uint8_t>* ScanInbox::scan_bytes(int robot, std::uint32_t keyframe) const {
  auto it = scans_.find(Key(robot, keyframe));
  return it == scans_.end() ? nullptr : &it->second;
}

Status ScanInbox::OnScanChunk(const ScanChunk& chunk, MergeServerStats* stats,
                              const std::function<void()>& note_memory) {
  const std::string what = "scan chunk " + std::to_string(chunk.chunk_index) + "/" + std::to_string(chunk.num_chunks) +
                           " of " + ServerRobotText(chunk.robot_id) + " keyframe " + std::to_string(chunk.keyframe);
  if (chunk.robot_id < 0 || chunk.robot_id >= max_robots_) {
    return CountRejection(stats, &stats->rejected_chunks, InvalidArgument(what + ": robot_id is outside 0.." +
                                                           std::to_string(max_robots_ - 1)));
  }
  const std::uint64_t total = chunk.total_bytes;
  const std::uint64_t per_chunk = kMaxScanChunkPayloadBytes;
  if (chunk.num_chunks == 0 || chunk.num_chunks > kMaxChunksPerScan || chunk.chunk_index >= chunk.num_chunks ||
      total < kEncodedScanHeaderBytes || total > static_cast<std::uint64_t>(chunk.num_chunks) * per_chunk ||
      chunk.payload.empty() || chunk.payload.size() > per_chunk) {
    return CountRejection(stats, &stats->rejected_chunks,
                  InvalidArgument(what + ": inconsistent sizes (total " + std::to_string(total) + " bytes, payload " +
                                  std::to_string(chunk.payload.size()) + ")"));
  }
  if (total > EncodedScanBytes(limits_.max_scan_points)) {
    return CountRejection(stats, &stats->rejected_chunks,
                  InvalidArgument(what + ": a scan of " + std::to_string(total) + " bytes holds more than the " +
                                  std::to_string(limits_.max_scan_points) + " points a stored scan may (" +
                                  std::to_string(EncodedScanBytes(limits_.max_scan_points)) + " bytes)"));
  }
  const std::uint64_t key = Key(chunk.robot_id, chunk.keyframe);
  if (scans_.count(key)) {
    ++stats->duplicate_chunks;  // the scan is complete already: a retransmission
    return Status::Ok();
  }
  // Chunk i covers [i x size, min(total, (i + 1) x size)) with size = ceil(total / num_chunks) (ScanChunkRange).
  const ChunkRange range = ScanChunkRange(total, chunk.num_chunks, chunk.chunk_index);
  if (chunk.payload.size() != range.size) {
    return CountRejection(stats, &stats->rejected_chunks, InvalidArgument(what + ": payload of " + std::to_string(chunk.payload.size()) +
                                                           " bytes where the protocol expects " +
                                                           std::to_string(range.size)));
  }
  auto it = partial_.find(key);
  if (it == partial_.end()) {
    if (held_bytes_ + total > limits_.max_scan_bytes || partial_.size() + scans_.size() >= limits_.max_scans_held) {
      ++stats->chunks_over_budget;
      return CountRejection(stats, &stats->rejected_chunks,
                    ResourceExhausted(what + ": the server already holds " + std::to_string(partial_.size() + scans_.size()) +
                                      " scans, " + std::to_string(held_bytes_) + " bytes (max_scans_held = " +
                                      std::to_string(limits_.max_scans_held) + ", max_scan_bytes = " +
                                      std::to_string(limits_.max_scan_bytes) + ")"));
    }
    Partial fresh;
    fresh.total_bytes = chunk.total_bytes;
    fresh.num_chunks = chunk.num_chunks;
    fresh.have.assign(chunk.num_chunks, 0);
    fresh.bytes.assign(chunk.total_bytes, 0);
    held_bytes_ += total;
    partial_flag_bytes_ += fresh.have.capacity();
    it = partial_.emplace(key, std::move(fresh)).first;
    note_memory();
  }
  Partial& p = it->second;
  if (p.total_bytes != chunk.total_bytes || p.num_chunks != chunk.num_chunks) {
    return CountRejection(stats, &stats->rejected_chunks, InvalidArgument(what + ": sizes differ from the scan's earlier chunks"));
  }
  const std::uint64_t offset = range.offset;
  if (p.have[chunk.chunk_index]) {
    ++stats->duplicate_chunks;
    return Status::Ok();
  }
  std::copy(chunk.payload.begin(), chunk.payload.end(), p.bytes.begin() + static_cast<std::ptrdiff_t>(offset));
  p.have[chunk.chunk_index] = 1;
  ++p.received;
  ++stats->chunks;
  if (p.received < p.num_chunks) return Status::Ok();
  // Complete: verify the scan before it is used.
  std::vector<std::uint8_t> bytes = std::move(p.bytes);
  partial_flag_bytes_ -= p.have.capacity();
  partial_.erase(it);
  if (auto header = VerifyEncodedScan(Span<const std::uint8_t>(bytes)); !header.ok() ||
      EncodedScanBytes(header->num_points) != bytes.size()) {
    held_bytes_ -= total;
    ++stats->corrupt_scans;
    return CountRejection(stats, &stats->rejected_chunks,
                  DataLoss(ServerRobotText(chunk.robot_id) + " keyframe " + std::to_string(chunk.keyframe) +
                           ": reassembled scan is corrupt (" +
                           (header.ok() ? std::string("size does not match its point count") : header.status().message()) +
                           "); it must be sent again"));
  }
  scans_.emplace(key, std::move(bytes));
  ++stats->scans_completed;
  return Status::Ok();
}

void ScanInbox::Clear() {
  partial_.clear();
  scans_.clear();
  held_bytes_ = 0;
  partial_flag_bytes_ = 0;
}

void ScanInbox::ResetRobot(int robot) {
  if (robot < 0 || robot >= max_robots_) return;
  const std::uint64_t begin = Key(robot, 0), end = Key(robot + 1, 0);
  for (auto it = partial_.lower_bound(begin); it != partial_.end() && it->first < end;) {
    held_bytes_ -= it->second.total_bytes;
    partial_flag_bytes_ -= it->second.have.capacity();
    it = partial_.erase(it);
  }
  for (auto it = scans_.lower_bound(begin); it != scans_.end() && it->first < end;) {
    held_bytes_ -= it->second.size();
    it = scans_.erase(it);
  }
}

bool ScanInbox::PartialScan(int robot, std::uint32_t keyframe, std::uint16_t* num_chunks,
                              const std::vector<std::uint8_t>** have) const {
  auto it = partial_.find(Key(robot, keyframe));
  if (it == partial_.end()) return false;
  *num_chunks = it->second.num_chunks;
  *have = &it->second.have;
  return true;
}

std::size_t ScanInbox::MemoryBytes() const {
  // Scan bytes are allocated exactly (assign of total_bytes, moved when complete): held_bytes_ is their sum.
  return static_cast<std::size_t>(held_bytes_ + partial_flag_bytes_) +
         partial_.size() * sizeof(decltype(partial_)::value_type) + scans_.size() * sizeof(decltype(scans_)::value_type);
}

}  // namespace commerge
