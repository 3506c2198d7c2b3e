// SPDX-License-Identifier: BSD-3-Clause
#include "platform/ros/message_source.hpp"

#include <cstring>
#include <utility>

#include "platform/ros/byte_source.hpp"
#include "platform/ros/mcap_reader.hpp"
#include "platform/ros/ros1_bag.hpp"
#include "platform/ros/rosbag2_db3.hpp"

namespace commerge::platform {

namespace {

// A ROS 1 bag as a RosMessageSource: connections are channels, every message is ROS 1 serialized.
class Ros1BagSource final : public RosMessageSource {
 public:
  Ros1BagSource(std::unique_ptr<ByteSource> bytes, Ros1BagReader reader)
      : bytes_(std::move(bytes)), reader_(std::move(reader)) {}

  Result<Item> Next() override {
    auto item = reader_.Next();
    if (!item.ok()) return item.status();
    switch (*item) {
      case Ros1BagReader::Item::kConnection: {
        const Ros1Connection& c = reader_.connection();
        channel_ = RosChannel{c.id, c.topic, c.type, RosEncoding::kRos1};
        return Item::kChannel;
      }
      case Ros1BagReader::Item::kMessage: {
        const Ros1Message& m = reader_.message();
        message_ = RosRecord{m.connection_id, m.time_ns, m.data, m.record_offset, m.record_index};
        return Item::kMessage;
      }
      case Ros1BagReader::Item::kEnd: break;
    }
    return Item::kEnd;
  }
  const RosChannel& channel() const noexcept override { return channel_; }
  const RosRecord& message() const noexcept override { return message_; }
  const RosChannel* FindChannel(std::uint32_t id) const noexcept override {
    const Ros1Connection* c = reader_.FindConnection(id);
    if (c == nullptr) return nullptr;
    lookup_ = RosChannel{c->id, c->topic, c->type, RosEncoding::kRos1};
    return &lookup_;
  }
  std::uint64_t position() const noexcept override { return reader_.position(); }
  std::uint64_t size() const noexcept override { return reader_.size(); }
  const char* format() const noexcept override { return "ROS 1 bag"; }

 private:
  std::unique_ptr<ByteSource> bytes_;  // the reader points into it: declared first, destroyed last
  Ros1BagReader reader_;
  RosChannel channel_;
  RosRecord message_;
  mutable RosChannel lookup_;
};

// A source that reads from a ByteSource it does not own (McapReader), with that ByteSource.
class OwningSource final : public RosMessageSource {
 public:
  OwningSource(std::unique_ptr<ByteSource> bytes, std::unique_ptr<RosMessageSource> source)
      : bytes_(std::move(bytes)), source_(std::move(source)) {}
  Result<Item> Next() override { return source_->Next(); }
  const RosChannel& channel() const noexcept override { return source_->channel(); }
  const RosRecord& message() const noexcept override { return source_->message(); }
  const RosChannel* FindChannel(std::uint32_t id) const noexcept override { return source_->FindChannel(id); }
  std::uint64_t position() const noexcept override { return source_->position(); }
  std::uint64_t size() const noexcept override { return source_->size(); }
  const char* format() const noexcept override { return source_->format(); }

 private:
  std::unique_ptr<ByteSource> bytes_;  // the source points into it: declared first, destroyed last
  std::unique_ptr<RosMessageSource> source_;
};

constexpr std::uint8_t kMcapMagic[8] = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};
constexpr char kSqliteMagic[] = "SQLite format 3";  // and its NUL: 16 bytes

std::string Printable(const std::uint8_t* bytes, std::size_t n) {
  std::string out;
  for (std::size_t i = 0; i < n; ++i) out += (bytes[i] >= 0x20 && bytes[i] < 0x7f) ? static_cast<char>(bytes[i]) : '?';
  return out;
}

}  // namespace

Result<std::unique_ptr<RosMessageSource>> OpenRosMessageSource(const std::string& path) {
  auto file = FileByteSource::Open(path);
  if (!file.ok()) return file.status();
  std::unique_ptr<ByteSource> bytes = std::move(*file);
  std::uint8_t head[16] = {};
  const std::size_t n = bytes->size() < sizeof(head) ? static_cast<std::size_t>(bytes->size()) : sizeof(head);
  if (Status st = bytes->ReadAt(0, n, head); !st.ok()) return st;
  if (n >= 9 && std::memcmp(head, "#ROSBAG V", 9) == 0) {
    ByteSource* raw = bytes.get();
    auto reader = Ros1BagReader::Open(raw);
    if (!reader.ok()) return reader.status();
    return std::unique_ptr<RosMessageSource>(new Ros1BagSource(std::move(bytes), std::move(*reader)));
  }
  if (n >= 5 && std::memcmp(head, kMcapMagic, 5) == 0) {  // "\x89MCAP": McapReader checks the version and the rest
    auto reader = McapReader::Open(bytes.get());
    if (!reader.ok()) return reader.status();
    return std::unique_ptr<RosMessageSource>(new OwningSource(std::move(bytes), std::move(*reader)));
  }
  if (n == sizeof(kSqliteMagic) && std::memcmp(head, kSqliteMagic, sizeof(kSqliteMagic)) == 0) {
    bytes.reset();  // sqlite opens the file itself
    auto reader = Rosbag2Db3Reader::Open(path);
    if (!reader.ok()) return reader.status();
    return std::unique_ptr<RosMessageSource>(std::move(*reader));
  }
  return InvalidArgument(path + ": not a recording commerge reads (a ROS 1 bag starts with \"#ROSBAG V2.0\", an MCAP "
                         "file with \"\\x89MCAP0\\r\\n\", a rosbag2 .db3 with \"SQLite format 3\"); its first bytes "
                         "are \"" + Printable(head, n) + "\"");
}

}  // namespace commerge::platform
