// SPDX-License-Identifier: BSD-3-Clause
#include "core/slam/keyframe_graph_distance.hpp"

#include <limits>
#include <string>

namespace commerge {
namespace {
constexpr std::uint32_t kUnreached = std::numeric_limits<std::uint32_t>::max();
}  // namespace

KeyframeGraphDistance::KeyframeGraphDistance(std::size_t max_keyframes) : max_keyframes_(max_keyframes) {
  links_.reserve(max_keyframes);
  head_.reserve(max_keyframes + 1);
  adjacent_.reserve(2 * max_keyframes);
  steps_.reserve(max_keyframes);
  level_.reserve(max_keyframes);
  next_.reserve(max_keyframes);
  stack_.reserve(max_keyframes);
}

Status KeyframeGraphDistance::AddLink(std::uint32_t a, std::uint32_t b) {
  if (a == b || a >= max_keyframes_ || b >= max_keyframes_) {
    return InvalidArgument("keyframe graph distance: link " + std::to_string(a) + "-" + std::to_string(b) +
                           " is not between two distinct keyframes below " + std::to_string(max_keyframes_));
  }
  if (links_.size() >= max_keyframes_) {
    return ResourceExhausted("keyframe graph distance: " + std::to_string(max_keyframes_) + " links held");
  }
  links_.emplace_back(a, b);
  return Status::Ok();
}

std::size_t KeyframeGraphDistance::workspace_bytes() const {
  return links_.capacity() * sizeof(links_[0]) +
         (head_.capacity() + adjacent_.capacity() + steps_.capacity() + level_.capacity() + next_.capacity() +
          stack_.capacity()) *
             sizeof(std::uint32_t);
}

void KeyframeGraphDistance::BuildAdjacency(std::size_t num_keyframes) {
  if (built_links_ == links_.size() && built_keyframes_ == num_keyframes) return;
  head_.assign(num_keyframes + 1, 0);
  for (const auto& [a, b] : links_) {
    ++head_[a + 1];
    ++head_[b + 1];
  }
  for (std::size_t k = 0; k < num_keyframes; ++k) head_[k + 1] += head_[k];
  adjacent_.resize(2 * links_.size());
  // steps_ serves as the fill cursor per keyframe (Steps() resets it).
  steps_.assign(head_.begin(), head_.end() - 1);
  for (const auto& [a, b] : links_) {
    adjacent_[steps_[a]++] = b;
    adjacent_[steps_[b]++] = a;
  }
  built_links_ = links_.size();
  built_keyframes_ = num_keyframes;
}

std::uint32_t KeyframeGraphDistance::Steps(std::uint32_t a, std::uint32_t b, std::size_t num_keyframes) {
  if (a == b) return 0;
  BuildAdjacency(num_keyframes);
  steps_.assign(num_keyframes, kUnreached);
  level_.clear();
  steps_[a] = 0;
  level_.push_back(a);
  for (std::uint32_t d = 0;; ++d) {
    // Close the level under the free links: everything reachable from it at no length is at d as well.
    stack_.assign(level_.begin(), level_.end());
    while (!stack_.empty()) {
      const std::uint32_t k = stack_.back();
      stack_.pop_back();
      for (std::uint32_t i = head_[k]; i < head_[k + 1]; ++i) {
        const std::uint32_t j = adjacent_[i];
        if (steps_[j] != kUnreached) continue;
        steps_[j] = d;
        level_.push_back(j);
        stack_.push_back(j);
      }
    }
    if (steps_[b] != kUnreached) return steps_[b];
    // One chain step further.
    next_.clear();
    for (const std::uint32_t k : level_) {
      if (k > 0 && steps_[k - 1] == kUnreached) {
        steps_[k - 1] = d + 1;
        next_.push_back(k - 1);
      }
      if (k + 1 < num_keyframes && steps_[k + 1] == kUnreached) {
        steps_[k + 1] = d + 1;
        next_.push_back(k + 1);
      }
    }
    if (next_.empty()) return kUnreached;  // unreachable only if a or b is out of range (precondition)
    level_.swap(next_);
  }
}

}  // namespace commerge
