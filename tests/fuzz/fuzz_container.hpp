// SPDX-License-Identifier: BSD-3-Clause
// The checks shared by the libFuzzer targets of the recording readers (fuzz_ros1_bag.cpp, fuzz_mcap.cpp): a
// whole file read from memory record by record until kEnd or the first error, under an AllocationWatch.
//   * an error is DataLoss or InvalidArgument and names the source and a byte offset; Next() repeats it;
//   * kEnd repeats, and then position() == size() (the whole input was consumed);
//   * every message the reader reports is on a channel (connection) it reported, its index in step with the
//     reader's message count, its bytes readable;
//   * no single allocation exceeds the target's bound.
// What a channel (connection) item holds is checked by the target itself.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "platform/ros/byte_source.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace commerge::fuzz {

/// Names of one target, in its failure messages and its input.
struct ContainerTarget {
  const char* tag;          ///< "mcap", "ros1_bag": the start of every failure message
  const char* source_name;  ///< the input's ByteSource name, which every error must name
  const char* channel;      ///< what a message is on: "channel", "connection"
};

/// Far above the records a fuzz input can hold (8 bytes each at least in a bag, 9 in MCAP).
constexpr int kContainerMaxSteps = 1 << 20;
/// The targets' cap on a chunk (and on an MCAP record read whole) [bytes].
constexpr std::size_t kContainerMaxChunkBytes = std::size_t{1} << 20;
/// The largest single allocation allowed: the chunk cap, or what the decompression libraries allocate for their own
/// state, whichever is larger (one LZ4 frame block: at most 4 MiB, + 128 KiB for linked blocks; below it a bzip2
/// block table, at most 3.6 MB, and a zstd decompression context, ~160 KiB), + 4 KiB of slack.
constexpr std::size_t kContainerAllocationBound =
    std::max(kContainerMaxChunkBytes, (std::size_t{4} << 20) + (std::size_t{192} << 10)) + 4096;

/// Fails unless `status` is DataLoss or InvalidArgument and names the source and an offset.
inline void CheckContainerError(const ContainerTarget& target, const Status& status, const char* where) {
  const std::string& m = status.message();
  const bool code_ok = status.code() == StatusCode::kDataLoss || status.code() == StatusCode::kInvalidArgument;
  if (!code_ok || m.find(target.source_name) == std::string::npos || m.find("offset") == std::string::npos) {
    Fail("%s: %s refused the input with '%s' (expected DataLoss or InvalidArgument naming %s and an offset)",
         target.tag, where, status.ToString().c_str(), target.source_name);
  }
}

/// Checks one message item: `channel_known` (its channel id was reported), `index` (0-based) against the
/// reader's count of messages. Returns a value that depends on every byte of `data`.
inline std::uint64_t CheckContainerMessage(const ContainerTarget& target, bool channel_known, std::uint32_t channel_id,
                                           std::uint64_t index, std::uint64_t messages, Span<const std::uint8_t> data) {
  if (!channel_known) {
    Fail("%s: message %llu on %s %u, which was never reported", target.tag, static_cast<unsigned long long>(index),
         target.channel, channel_id);
  }
  if (index + 1 != messages) Fail("%s: message index out of step with the stats", target.tag);
  std::uint64_t sum = 0;
  for (const std::uint8_t b : data) sum += b;  // ASan checks that the view is inside a live buffer
  return sum;
}

/// Walks `reader` to kEnd or its first error; `check_item(item)` checks each other item and returns a value that
/// depends on what it holds.
template <typename Reader, typename CheckItem>
void WalkContainer(const ContainerTarget& target, Reader* reader, CheckItem&& check_item) {
  using Item = typename Reader::Item;
  std::uint64_t sink = 0;
  for (int step = 0; step < kContainerMaxSteps; ++step) {
    Result<Item> item = reader->Next();
    if (!item.ok()) {
      CheckContainerError(target, item.status(), "Next()");
      Result<Item> again = reader->Next();
      if (again.ok() || again.status().message() != item.status().message()) {
        Fail("%s: Next() after the error '%s' did not return it again", target.tag, item.status().message().c_str());
      }
      return;
    }
    if (*item == Item::kEnd) {
      Result<Item> again = reader->Next();
      if (!again.ok() || *again != Item::kEnd) Fail("%s: kEnd did not repeat", target.tag);
      if (reader->position() != reader->size()) Fail("%s: kEnd with position() below size()", target.tag);
      return;
    }
    sink += check_item(*item);
  }
  Fail("%s: more than %d items from one input (sink %llu)", target.tag, kContainerMaxSteps,
       static_cast<unsigned long long>(sink));
}

template <typename Reader>
Reader* ReaderOf(Reader& reader) noexcept {
  return &reader;
}
template <typename Reader>
Reader* ReaderOf(std::unique_ptr<Reader>& reader) noexcept {
  return reader.get();
}

/// One fuzz input: `open(source)` opens the reader on the input (a Result of the reader or of a unique_ptr to it;
/// a refused input is checked by CheckContainerError), WalkContainer walks it with `check_item(reader, item)`;
/// then no single allocation made meanwhile may exceed kContainerAllocationBound.
template <typename Open, typename CheckItem>
void FuzzContainerInput(const ContainerTarget& target, const std::uint8_t* data, std::size_t size, Open&& open,
                        CheckItem&& check_item) {
  constexpr std::size_t bound = kContainerAllocationBound;
  platform::MemoryByteSource source(Span<const std::uint8_t>(data, size), target.source_name);
  const bool watched = AllocationWatch::Available();
  AllocationWatch watch;
  {
    auto reader = open(static_cast<platform::ByteSource*>(&source));
    if (!reader.ok()) {
      CheckContainerError(target, reader.status(), "Open()");
    } else {
      auto* const r = ReaderOf(reader.value());
      WalkContainer(target, r, [&](auto item) { return check_item(*r, item); });
    }
  }
  if (watched && watch.largest_bytes() > bound) {
    Fail("%s: reading %zu bytes allocated one block of %zu bytes, above the bound of %zu", target.tag, size,
         watch.largest_bytes(), bound);
  }
}

}  // namespace commerge::fuzz
