// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the ROS 1 bag reader (platform/ros/ros1_bag.hpp): the input is a whole bag file, read
// from memory record by record until kEnd or the first error. Every input must be read or refused, never crash
// (ASan, UBSan). Also checked, for every input:
//   * an error is DataLoss or InvalidArgument and names the source and a byte offset; Next() repeats it;
//   * kEnd repeats, and then the whole input was consumed;
//   * every connection and message the reader reports is well formed (known connection, bytes readable);
//   * no single allocation exceeds the reader's limits (FuzzLimits(): 1 MiB chunks) or what liblz4 and libbz2
//     allocate for their own state, whichever is larger: one LZ4 frame block (at most 4 MiB, + 128 KiB for linked
//     blocks) or one bzip2 block table (at most 3.6 MB). The reader checks every length from the file before it
//     allocates for it.
#include <cstddef>
#include <cstdint>

#include "platform/ros/byte_source.hpp"
#include "platform/ros/ros1_bag.hpp"
#include "tests/fuzz/fuzz_container.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace commerge::fuzz {
namespace {

constexpr ContainerTarget kTarget{"ros1_bag", "fuzz.bag", "connection"};

platform::Ros1BagLimits FuzzLimits() {
  platform::Ros1BagLimits limits;
  limits.max_header_bytes = 1u << 16;
  limits.max_chunk_bytes = kContainerMaxChunkBytes;
  limits.max_connections = 256;
  return limits;
}

/// Checks what one kConnection or kMessage item holds; returns a value that depends on every message byte.
std::uint64_t CheckItem(const platform::Ros1BagReader& reader, platform::Ros1BagReader::Item item) {
  if (item == platform::Ros1BagReader::Item::kConnection) {
    const platform::Ros1Connection& c = reader.connection();
    if (reader.FindConnection(c.id) != &c) Fail("ros1_bag: connection %u is not found by its id", c.id);
    return c.topic.size() + c.type.size();
  }
  const platform::Ros1Message& m = reader.message();
  return CheckContainerMessage(kTarget, reader.FindConnection(m.connection_id) != nullptr, m.connection_id,
                               m.record_index, reader.stats().messages, m.data);
}

}  // namespace
}  // namespace commerge::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace commerge;        // NOLINT(google-build-using-namespace): a fuzz entry point
  using namespace commerge::fuzz;  // NOLINT(google-build-using-namespace)
  FuzzContainerInput(
      kTarget, data, size,
      [](platform::ByteSource* source) { return platform::Ros1BagReader::Open(source, FuzzLimits()); }, CheckItem);
  return 0;
}
