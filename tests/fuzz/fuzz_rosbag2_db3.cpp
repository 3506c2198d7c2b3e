// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the rosbag2 sqlite3 reader (platform/ros/rosbag2_db3.hpp): the input is a whole .db3 file.
// The reader opens a path (through libsqlite3), so each input is written to a per-process temporary file
// (TempInputFile: /dev/shm, else $TMPDIR, else /tmp, with the pid in its name; rewritten per input, removed at
// exit), then walked item by item until kEnd or the first error. Every input must be read or refused, never crash
// (ASan, UBSan). Also checked, for every input:
//   * an error (at Open or from Next()) is DataLoss, InvalidArgument or IoError and names the file; Next()
//     repeats it;
//   * kEnd repeats, and then position() == size(); position() never decreases and never passes size();
//   * every channel is found by its id; every message is on an announced channel, its index in step with the
//     messages seen, its bytes readable;
//   * no single allocation exceeds Db3AllocationBound(size): a message's data is read into the reader's buffer
//     only after its length is checked against the file's size, and SQLite's own blocks are capped at
//     kSqliteLargestBlockBytes (4 MiB, platform/ros/rosbag2_db3.hpp); SQLite asking for more is refused and
//     reported as an error. 4 MiB + the input size.
// Seeds: tests/fuzz/ros_seeds.py (SEEDS/rosbag2_db3/: a small .db3 in rosbag2's schema, one Odometry topic).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "core/common/status.hpp"
#include "platform/ros/message_source.hpp"
#include "platform/ros/rosbag2_db3.hpp"
#include "tests/fuzz/fuzz_container.hpp"
#include "tests/fuzz/fuzz_support.hpp"
#include "tests/fuzz/fuzz_temp_file.hpp"

namespace commerge::fuzz {
namespace {

constexpr ContainerTarget kTarget{"rosbag2_db3", "the .db3 input file", "channel"};

/// Far above the items a fuzz input can hold.
constexpr int kMaxSteps = 1 << 20;

/// The largest single allocation allowed for an input of `size` bytes (see the comment at the top).
std::size_t Db3AllocationBound(std::size_t size) { return (std::size_t{4} << 20) + size; }

platform::Rosbag2Db3Limits FuzzLimits() {
  platform::Rosbag2Db3Limits limits;
  limits.max_topics = 256;
  return limits;
}

/// A static object: destroyed (the file removed) when libFuzzer exits normally.
const TempInputFile& InputFile() {
  static const TempInputFile file(".db3");
  return file;
}

/// Fails unless `status` is DataLoss, InvalidArgument or IoError and names `path`.
void CheckError(const std::string& path, const Status& status, const char* where) {
  const bool code_ok = status.code() == StatusCode::kDataLoss || status.code() == StatusCode::kInvalidArgument ||
                       status.code() == StatusCode::kIoError;
  if (!code_ok || status.message().find(path) == std::string::npos) {
    Fail("rosbag2_db3: %s refused the input with '%s' (expected DataLoss, InvalidArgument or IoError naming %s)",
         where, status.ToString().c_str(), path.c_str());
  }
}

/// Walks `reader` to kEnd or its first error.
void Walk(const std::string& path, platform::Rosbag2Db3Reader* reader) {
  using Item = platform::RosMessageSource::Item;
  std::uint64_t messages = 0;
  std::uint64_t sink = 0;
  std::uint64_t position = 0;
  for (int step = 0; step < kMaxSteps; ++step) {
    Result<Item> item = reader->Next();
    if (reader->position() < position || reader->position() > reader->size()) {
      Fail("rosbag2_db3: position() went from %llu to %llu (size() %llu)", static_cast<unsigned long long>(position),
           static_cast<unsigned long long>(reader->position()), static_cast<unsigned long long>(reader->size()));
    }
    position = reader->position();
    if (!item.ok()) {
      CheckError(path, item.status(), "Next()");
      Result<Item> again = reader->Next();
      if (again.ok() || again.status().message() != item.status().message()) {
        Fail("rosbag2_db3: Next() after the error '%s' did not return it again", item.status().message().c_str());
      }
      return;
    }
    if (*item == Item::kEnd) {
      Result<Item> again = reader->Next();
      if (!again.ok() || *again != Item::kEnd) Fail("rosbag2_db3: kEnd did not repeat");
      if (reader->position() != reader->size()) Fail("rosbag2_db3: kEnd with position() below size()");
      return;
    }
    if (*item == Item::kChannel) {
      const platform::RosChannel& c = reader->channel();
      if (reader->FindChannel(c.id) != &c) Fail("rosbag2_db3: channel %u is not found by its id", c.id);
      sink += c.topic.size() + c.type.size();
      continue;
    }
    const platform::RosRecord& m = reader->message();
    ++messages;
    sink += CheckContainerMessage(kTarget, reader->FindChannel(m.channel_id) != nullptr, m.channel_id, m.index,
                                  messages, m.data);
  }
  Fail("rosbag2_db3: more than %d items from one input (sink %llu)", kMaxSteps,
       static_cast<unsigned long long>(sink));
}

}  // namespace
}  // namespace commerge::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace commerge;        // NOLINT(google-build-using-namespace): a fuzz entry point
  using namespace commerge::fuzz;  // NOLINT(google-build-using-namespace)
  const TempInputFile& file = InputFile();
  file.Write(data, size);
  const std::size_t bound = Db3AllocationBound(size);
  const bool watched = AllocationWatch::Available();
  AllocationWatch watch;
  {
    auto reader = platform::Rosbag2Db3Reader::Open(file.path(), FuzzLimits());
    if (!reader.ok()) {
      CheckError(file.path(), reader.status(), "Open()");
    } else {
      Walk(file.path(), reader->get());
    }
  }
  if (watched && watch.largest_bytes() > bound) {
    Fail("rosbag2_db3: reading %zu bytes allocated one block of %zu bytes, above the bound of %zu", size,
         watch.largest_bytes(), bound);
  }
  return 0;
}
