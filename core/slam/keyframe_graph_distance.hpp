// SPDX-License-Identifier: BSD-3-Clause
// commerge: path length between two keyframes through the robot's accepted loops. Keyframes form a chain
// (keyframe k and k + 1 are one step apart); every accepted loop links its two keyframes at no length. The
// shortest path from a to b is how far odometry has to carry the estimate between them once the loops are
// closed: the loop check's drift bound grows with it (robot_mapper.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/common/status.hpp"

namespace commerge {

class KeyframeGraphDistance {
 public:
  /// Capacity: keyframes and links (one accepted loop per keyframe at most). Reserves everything up front.
  explicit KeyframeGraphDistance(std::size_t max_keyframes);

  /// Records an accepted loop between keyframes a and b (a != b). ResourceExhausted when full.
  Status AddLink(std::uint32_t a, std::uint32_t b);

  /// Fewest chain steps on a path from a to b among keyframes [0, num_keyframes), links free. Precondition:
  /// a, b < num_keyframes <= max_keyframes and every link endpoint < num_keyframes. Steps in O(num_keyframes
  /// + links) without allocation (level-by-level breadth-first search with zero-length links closed first).
  std::uint32_t Steps(std::uint32_t a, std::uint32_t b, std::size_t num_keyframes);

  std::size_t num_links() const noexcept { return links_.size(); }
  /// Bytes held (capacities).
  std::size_t workspace_bytes() const;

 private:
  void BuildAdjacency(std::size_t num_keyframes);

  std::size_t max_keyframes_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> links_;
  std::size_t built_links_ = 0, built_keyframes_ = 0;
  std::vector<std::uint32_t> head_, adjacent_;       // CSR of the links
  std::vector<std::uint32_t> steps_;                 // per keyframe, kUnreached when not reached yet
  std::vector<std::uint32_t> level_, next_, stack_;  // search frontiers
};

}  // namespace commerge
