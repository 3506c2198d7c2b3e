// SPDX-License-Identifier: BSD-3-Clause
// A MergeServer for a test: MergeServer::Create, which must succeed.
#pragma once

#include <doctest/doctest.h>

#include <cstddef>
#include <memory>
#include <utility>

#include "core/agent/merge_server.hpp"

namespace commerge::test {

inline std::unique_ptr<MergeServer> MakeTestServer(int max_robots, std::size_t max_keyframes_per_robot,
                                                   const MergeServerParams& params) {
  auto server = MergeServer::Create(max_robots, max_keyframes_per_robot, params);
  REQUIRE_MESSAGE(server.ok(), server.status().message());
  return std::move(*server);
}

}  // namespace commerge::test
