// SPDX-License-Identifier: BSD-3-Clause
// One interface over the recorded-message containers commerge imports: ROS 1 bags (ros1_bag.hpp), MCAP
// (mcap_reader.hpp) and rosbag2 sqlite3 files (rosbag2_db3.hpp). A source walks its messages in storage order,
// announcing each channel (topic + type + encoding) before its first message.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "platform/ros/ros_messages.hpp"

namespace commerge::platform {

struct RosChannel {
  std::uint32_t id = 0;
  std::string topic;
  std::string type;                          ///< "sensor_msgs/PointCloud2" or "sensor_msgs/msg/PointCloud2"
  RosEncoding encoding = RosEncoding::kRos1;  ///< how its messages are serialized
};

/// One message. `data` views the source's buffer: valid until the next call of Next().
struct RosRecord {
  std::uint32_t channel_id = 0;
  std::int64_t log_time_ns = 0;     ///< when it was recorded (not the message's header stamp)
  Span<const std::uint8_t> data;    ///< the serialized message
  std::uint64_t offset = 0;         ///< where it is in the file (its record, or the chunk / page holding it)
  std::uint64_t index = 0;          ///< 0-based count of messages before it
};

class RosMessageSource {
 public:
  enum class Item { kChannel, kMessage, kEnd };
  virtual ~RosMessageSource() = default;

  /// The next new channel, message or the end. Errors name the file, the offset and the record; after an error
  /// Next() returns it again.
  virtual Result<Item> Next() = 0;
  /// The channel of the last kChannel item.
  virtual const RosChannel& channel() const noexcept = 0;
  /// The last kMessage item.
  virtual const RosRecord& message() const noexcept = 0;
  /// A channel announced so far, or nullptr.
  virtual const RosChannel* FindChannel(std::uint32_t id) const noexcept = 0;
  /// Bytes consumed so far and the file size (progress).
  virtual std::uint64_t position() const noexcept = 0;
  virtual std::uint64_t size() const noexcept = 0;
  /// "ROS 1 bag", "MCAP", "rosbag2 sqlite3".
  virtual const char* format() const noexcept = 0;
};

/// Opens `path` by its first bytes: "#ROSBAG V2.0" (ROS 1 bag), "\x89MCAP0\r\n" (MCAP), "SQLite format 3" (rosbag2
/// .db3). Anything else is InvalidArgument naming the file and what its first bytes are.
Result<std::unique_ptr<RosMessageSource>> OpenRosMessageSource(const std::string& path);

}  // namespace commerge::platform
