// SPDX-License-Identifier: BSD-3-Clause
#include "platform/ros/message_source.hpp"

#include <cstring>
#include <utility>

#include "platform/ros/byte_source.hpp"
#include "platform/ros/ros1_bag.hpp"

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
  return InvalidArgument(path + ": not a recording commerge reads (a ROS 1 bag starts with \"#ROSBAG V2.0\", an MCAP "
                         "file with \"\\x89MCAP0\\r\\n\", a rosbag2 .db3 with \"SQLite format 3\"); its first bytes "
                         "are \"" + Printable(head, n) + "\"");
}

}  // namespace commerge::platform
