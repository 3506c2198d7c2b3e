// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the MCAP reader (platform/ros/mcap_reader.hpp): the input is a whole MCAP file, read from
// memory record by record until kEnd or the first error. Every input must be read or refused, never crash (ASan,
// UBSan). Also checked, for every input:
//   * an error is DataLoss or InvalidArgument and names the source and a byte offset; Next() repeats it;
//   * kEnd repeats, and then position() == size();
//   * every channel and message the reader reports is well formed (known channel, bytes readable);
//   * no single allocation exceeds the reader's limits (FuzzLimits(): 1 MiB chunks and records) or what liblz4
//     and libzstd allocate for their own state, whichever is larger: one LZ4 frame block (at most 4 MiB, + 128 KiB
//     for linked blocks) or a zstd decompression context (~160 KiB; one-shot decompression into the chunk buffer
//     needs no window buffer). The reader checks every length from the file before it allocates for it.
// Seeds: small MCAP files (tests/fuzz/ros_seeds.py: unchunked, an uncompressed chunk, an lz4 chunk).
#include <cstddef>
#include <cstdint>

#include "platform/ros/byte_source.hpp"
#include "platform/ros/mcap_reader.hpp"
#include "tests/fuzz/fuzz_container.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace commerge::fuzz {
namespace {

constexpr ContainerTarget kTarget{"mcap", "fuzz.mcap", "channel"};

platform::McapLimits FuzzLimits() {
  platform::McapLimits limits;
  limits.max_record_bytes = kContainerMaxChunkBytes;
  limits.max_chunk_bytes = kContainerMaxChunkBytes;
  return limits;
}

/// Checks what one kChannel or kMessage item holds; returns a value that depends on every message byte.
std::uint64_t CheckItem(const platform::McapReader& reader, platform::RosMessageSource::Item item) {
  if (item == platform::RosMessageSource::Item::kChannel) {
    const platform::RosChannel& c = reader.channel();
    if (reader.FindChannel(c.id) != &c) Fail("mcap: channel %u is not found by its id", c.id);
    return c.topic.size() + c.type.size();
  }
  const platform::RosRecord& m = reader.message();
  return CheckContainerMessage(kTarget, reader.FindChannel(m.channel_id) != nullptr, m.channel_id, m.index,
                               reader.stats().messages, m.data);
}

}  // namespace
}  // namespace commerge::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace commerge;        // NOLINT(google-build-using-namespace): a fuzz entry point
  using namespace commerge::fuzz;  // NOLINT(google-build-using-namespace)
  FuzzContainerInput(
      kTarget, data, size,
      [](platform::ByteSource* source) { return platform::McapReader::Open(source, FuzzLimits()); }, CheckItem);
  return 0;
}
