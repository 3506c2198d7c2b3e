// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target "server_inbox": a fuzzed stream of robot -> server messages (format in
// tests/fuzz/server_inbox.hpp: each record's first byte selects the channel) decoded and fed into a fresh
// transport-free server (MergeServer + ServerLink) on a fixed clock. The consumer must never crash, stay inside
// -malloc_limit_mb / -rss_limit_mb, count every refusal and publish only messages that encode and decode.
#include <cstddef>
#include <cstdint>

#include "core/common/span.hpp"
#include "tests/fuzz/server_inbox.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  commerge::fuzz::InboxServer server;
  commerge::Span<const std::uint8_t> stream(data, size);
  commerge::fuzz::InboxRecord record;
  while (commerge::fuzz::TakeInboxRecord(&stream, &record)) server.Feed(record);
  return 0;
}
