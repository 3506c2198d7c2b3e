// SPDX-License-Identifier: BSD-3-Clause
// commerge: how the server's modules name a robot and count a refused message (MergeServerStats).
#pragma once

#include <cstdint>
#include <string>

#include "core/agent/merge_server_params.hpp"
#include "core/common/status.hpp"

namespace commerge {

/// "robot 3".
inline std::string ServerRobotText(int robot) { return "robot " + std::to_string(robot); }

/// Counts a refusal in *counter, keeps its words as the latest rejection, and returns it.
inline Status CountRejection(MergeServerStats* stats, std::uint64_t* counter, Status status) {
  ++*counter;
  stats->last_rejection = status.message();
  return status;
}

}  // namespace commerge
