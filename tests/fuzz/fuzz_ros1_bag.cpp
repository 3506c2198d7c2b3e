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
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "platform/ros/byte_source.hpp"
#include "platform/ros/ros1_bag.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace commerge::fuzz {
namespace {

constexpr const char* kSourceName = "fuzz.bag";
constexpr std::size_t kMaxChunkBytes = std::size_t{1} << 20;
constexpr std::size_t kLibraryStateBytes = (std::size_t{4} << 20) + (std::size_t{192} << 10);
constexpr std::size_t kSlackBytes = 4096;
constexpr int kMaxSteps = 1 << 20;  // far above the records a fuzz input can hold (8 bytes each at least)

platform::Ros1BagLimits FuzzLimits() {
  platform::Ros1BagLimits limits;
  limits.max_header_bytes = 1u << 16;
  limits.max_chunk_bytes = kMaxChunkBytes;
  limits.max_connections = 256;
  return limits;
}

void CheckError(const Status& status, const char* where) {
  const std::string& m = status.message();
  const bool code_ok = status.code() == StatusCode::kDataLoss || status.code() == StatusCode::kInvalidArgument;
  if (!code_ok || m.find(kSourceName) == std::string::npos || m.find("offset") == std::string::npos) {
    Fail("ros1_bag: %s refused the input with '%s' (expected DataLoss or InvalidArgument naming %s and an offset)",
         where, status.ToString().c_str(), kSourceName);
  }
}

/// Checks what one kConnection or kMessage item holds; returns a value that depends on every message byte.
std::uint64_t CheckItem(const platform::Ros1BagReader& reader, platform::Ros1BagReader::Item item) {
  if (item == platform::Ros1BagReader::Item::kConnection) {
    const platform::Ros1Connection& c = reader.connection();
    if (reader.FindConnection(c.id) != &c) Fail("ros1_bag: connection %u is not found by its id", c.id);
    return c.topic.size() + c.type.size();
  }
  const platform::Ros1Message& m = reader.message();
  if (reader.FindConnection(m.connection_id) == nullptr) {
    Fail("ros1_bag: message %llu on connection %u, which was never reported",
         static_cast<unsigned long long>(m.record_index), m.connection_id);
  }
  if (m.record_index + 1 != reader.stats().messages) Fail("ros1_bag: message index out of step with the stats");
  std::uint64_t sum = 0;
  for (const std::uint8_t b : m.data) sum += b;  // ASan checks that the view is inside a live buffer
  return sum;
}

/// Walks the bag to kEnd or its first error.
void Walk(platform::Ros1BagReader* reader) {
  std::uint64_t sink = 0;
  for (int step = 0; step < kMaxSteps; ++step) {
    Result<platform::Ros1BagReader::Item> item = reader->Next();
    if (!item.ok()) {
      CheckError(item.status(), "Next()");
      Result<platform::Ros1BagReader::Item> again = reader->Next();
      if (again.ok() || again.status().message() != item.status().message()) {
        Fail("ros1_bag: Next() after the error '%s' did not return it again", item.status().message().c_str());
      }
      return;
    }
    if (*item == platform::Ros1BagReader::Item::kEnd) {
      Result<platform::Ros1BagReader::Item> again = reader->Next();
      if (!again.ok() || *again != platform::Ros1BagReader::Item::kEnd) Fail("ros1_bag: kEnd did not repeat");
      if (reader->position() != reader->size()) Fail("ros1_bag: kEnd before the end of the input");
      return;
    }
    sink += CheckItem(*reader, *item);
  }
  Fail("ros1_bag: more than %d items from one input (sink %llu)", kMaxSteps, static_cast<unsigned long long>(sink));
}

}  // namespace
}  // namespace commerge::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace commerge;        // NOLINT(google-build-using-namespace): a fuzz entry point
  using namespace commerge::fuzz;  // NOLINT(google-build-using-namespace)
  platform::MemoryByteSource source(Span<const std::uint8_t>(data, size), kSourceName);
  const bool watched = AllocationWatch::Available();
  AllocationWatch watch;
  {
    Result<platform::Ros1BagReader> reader = platform::Ros1BagReader::Open(&source, FuzzLimits());
    if (!reader.ok()) {
      CheckError(reader.status(), "Open()");
    } else {
      Walk(&reader.value());
    }
  }
  const std::size_t bound = std::max(kMaxChunkBytes, kLibraryStateBytes) + kSlackBytes;
  if (watched && watch.largest_bytes() > bound) {
    Fail("ros1_bag: reading %zu bytes allocated one block of %zu bytes, above the bound of %zu", size,
         watch.largest_bytes(), bound);
  }
  return 0;
}
