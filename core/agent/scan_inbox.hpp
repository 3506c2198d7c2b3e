// SPDX-License-Identifier: BSD-3-Clause
// commerge: the server's scan inbox (budget module "scan_reassembly"): reassembles the scan chunks the robots answer
// requests with, whatever their order, de-duplicated, bounded in scans and bytes, CRC-verified when complete.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <vector>

#include "core/agent/merge_server_params.hpp"
#include "core/agent/messages.hpp"
#include "core/common/status.hpp"

namespace commerge {

struct ScanInboxLimits {
  std::size_t max_scan_points = 8192;           ///< points of the largest scan (refused at its first chunk)
  std::uint64_t max_scan_bytes = 512ull << 20;  ///< bytes of complete and partial scans held at once
  std::size_t max_scans_held = 200000;          ///< complete and partial scans held at once
};

class ScanInbox {
 public:
  /// Empty: no robot (every chunk is refused as out of range).
  ScanInbox() = default;
  /// Robots 0..max_robots-1 (2..kMaxRobotId + 1); the limits of MergeServerParams (checked there).
  static Result<ScanInbox> Create(int max_robots, const ScanInboxLimits& limits);

  /// Takes one chunk; a refusal is counted in *stats (a duplicate is counted, not refused). `note_memory` is called
  /// when a new partial scan has been allocated.
  Status OnScanChunk(const ScanChunk& chunk, MergeServerStats* stats, const std::function<void()>& note_memory);

  /// Drops every complete and partial scan.
  void Clear();
  /// Drops one robot's complete and partial scans.
  void ResetRobot(int robot);

  bool has_scan(int robot, std::uint32_t keyframe) const;
  /// The complete, verified encoded scan of keyframe k (nullptr when not held).
  const std::vector<std::uint8_t>* scan_bytes(int robot, std::uint32_t keyframe) const;
  /// Chunks of keyframe k's scan received so far: false when no chunk arrived (or the scan is complete);
  /// otherwise `*num_chunks` and `*have` (one flag per chunk).
  bool PartialScan(int robot, std::uint32_t keyframe, std::uint16_t* num_chunks,
                   const std::vector<std::uint8_t>** have) const;
  std::size_t scans_received() const noexcept { return scans_.size(); }
  std::uint64_t scan_bytes_held() const noexcept { return held_bytes_; }
  /// Bytes held: scan bytes, chunk flags and one map entry per scan.
  std::size_t MemoryBytes() const;

 private:
  struct Partial {
    std::uint32_t total_bytes = 0;
    std::uint16_t num_chunks = 0;
    std::uint16_t received = 0;
    std::vector<std::uint8_t> have;
    std::vector<std::uint8_t> bytes;
  };
  static std::uint64_t Key(int robot, std::uint32_t keyframe) {
    return (static_cast<std::uint64_t>(robot) << 32) | keyframe;
  }

  int max_robots_ = 0;
  ScanInboxLimits limits_;
  std::map<std::uint64_t, Partial> partial_;
  std::map<std::uint64_t, std::vector<std::uint8_t>> scans_;
  std::uint64_t held_bytes_ = 0;
  std::uint64_t partial_flag_bytes_ = 0;  ///< chunk flags of the partial scans
};

}  // namespace commerge
