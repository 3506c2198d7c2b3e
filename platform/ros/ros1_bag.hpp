// SPDX-License-Identifier: BSD-3-Clause
// ROS 1 bags, format 2.0 (http://wiki.ros.org/Bags/Format/2.0): a streaming reader of our own over liblz4 and
// libbz2. It walks the records in file order: the bag header, chunks (compression none, bz2 or lz4; decompressed
// one at a time into a reused buffer) holding connection and message data records, each followed by its index
// data records, then the index section (connection records again, and chunk info records). Index data and chunk
// info records are skipped after a check of their lengths.
// Memory is bounded by the largest chunk, never by the file: Ros1BagLimits caps every length read from the file
// before anything is allocated for it.
//
// Details of the reading: a header field name that repeats takes its last value (as the official readers do); a
// connection's "latching" is true for "1" only. When the bag header gives an index position (a bag closed by its
// writer), the end of the file is checked against it: the index section must start at that offset and hold the
// announced numbers of connection and chunk info records, so a file cut between two records is an error too. A
// bag with index position 0 (its writer did not close it) is read to the end of the file without that check.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "platform/ros/byte_source.hpp"

namespace commerge::platform {

/// Caps on lengths read from the file (a length above its cap is a DataLoss error naming the record).
struct Ros1BagLimits {
  std::uint32_t max_header_bytes = 1u << 20;        ///< one record header [bytes]
  std::uint64_t max_chunk_bytes = 512ull << 20;     ///< one chunk, compressed or uncompressed [bytes]
  std::uint32_t max_connections = 65536;            ///< distinct connection ids
};

struct Ros1Connection {
  std::uint32_t id = 0;
  std::string topic;               ///< the connection record's topic (the header's "topic" field)
  std::string type;                ///< e.g. "sensor_msgs/PointCloud2"
  std::string md5sum;
  std::string message_definition;
  std::string callerid;            ///< empty when absent
  bool latching = false;
};

/// One message data record. `data` views the reader's buffer: valid until the next call of Next().
struct Ros1Message {
  std::uint32_t connection_id = 0;
  std::int64_t time_ns = 0;        ///< the record's receive time (sec * 1e9 + nsec), not the message's header stamp
  Span<const std::uint8_t> data;   ///< the serialized message (ROS 1 serialization)
  std::uint64_t record_offset = 0; ///< file offset of the record, or of its chunk when it lies in one
  std::uint64_t record_index = 0;  ///< 0-based count of message records read before it
};

struct Ros1BagStats {
  std::uint64_t chunks = 0;
  std::uint64_t chunks_bz2 = 0;
  std::uint64_t chunks_lz4 = 0;
  std::uint64_t messages = 0;
  std::uint64_t connection_records = 0;
  std::uint64_t index_records_skipped = 0;   ///< index data and chunk info records
  std::uint64_t unknown_records_skipped = 0; ///< an op code this reader does not know (skipped by its lengths)
};

class Ros1BagReader {
 public:
  enum class Item { kConnection, kMessage, kEnd };

  Ros1BagReader() = default;  ///< an unusable reader (for Result); use Open()
  /// Checks the "#ROSBAG V2.0\n" line and the bag header record. `source` is not owned and must outlive the
  /// reader. Errors (DataLoss / InvalidArgument; a failed read passes on the source's IoError) name the source and
  /// the byte offset.
  static Result<Ros1BagReader> Open(ByteSource* source, const Ros1BagLimits& limits = {});

  /// The next connection (first time its id is seen; a repeated record of a known id is not reported again) or
  /// message, in file order; kEnd after the last record. A message whose connection id was never declared is a
  /// DataLoss error. Every error names the source, the byte offset and the record ("a.bag: chunk at offset 4117
  /// (lz4): message data record 12 at chunk byte 3081: ..."), and the reader stays at that error (calling Next()
  /// again returns it again).
  Result<Item> Next();

  /// The connection of the last kConnection item.
  const Ros1Connection& connection() const noexcept { return connections_[last_connection_]; }
  /// The last kMessage item.
  const Ros1Message& message() const noexcept { return message_; }
  /// The connection with this id, or nullptr.
  const Ros1Connection* FindConnection(std::uint32_t id) const noexcept;
  const std::vector<Ros1Connection>& connections() const noexcept { return connections_; }

  /// Bytes of the file consumed so far (for progress), and the file size.
  std::uint64_t position() const noexcept { return file_pos_; }
  std::uint64_t size() const noexcept;
  const Ros1BagStats& stats() const noexcept { return stats_; }

 private:
  /// What one step of the walk produced (kSkipped: a record that is not reported; the walk goes on).
  enum class Step { kSkipped, kConnection, kMessage, kEnd };
  enum class Compression : std::uint8_t { kNone, kBz2, kLz4 };
  /// A record's lengths and op, its header viewed in header_buf_ or in the chunk buffer.
  struct RawRecord {
    Span<const std::uint8_t> header;
    std::uint32_t data_len = 0;
    std::uint8_t op = 0;
  };

  Status ReadMagic();
  Status ReadBagHeader();
  Result<Step> StepFile();
  Result<Step> StepChunk();
  Result<RawRecord> ReadFileRecord();
  Result<RawRecord> ParseChunkRecord();
  /// The header length against the limit and the bytes `left` from the record's start.
  Status CheckHeaderLength(std::uint32_t header_len, std::uint64_t left) const;
  /// The record whose header of `header_len` bytes (then the u32 data length) is at `header`: its fields and op
  /// checked, its data length against the bytes `left` from the record's start.
  Result<RawRecord> ParseRecord(const std::uint8_t* header, std::uint32_t header_len, std::uint64_t left);
  Result<Step> OnFileRecord(const RawRecord& record, std::uint64_t data_offset);
  Result<Step> OnChunkRecord(const RawRecord& record, Span<const std::uint8_t> data);
  Status LoadChunk(const RawRecord& record, std::uint64_t data_offset);
  Status ReadChunkData(const RawRecord& record, std::uint64_t data_offset, std::uint32_t size);
  Result<Step> OnConnection(Span<const std::uint8_t> header, Span<const std::uint8_t> data);
  Result<Step> OnMessage(Span<const std::uint8_t> header, Span<const std::uint8_t> data, std::uint64_t offset);
  Status OnIndexRecord(const RawRecord& record);
  Status CheckIndexPosition();
  Status CheckEnd() const;
  /// "<source>: <record> at offset N" or "<source>: chunk at offset N (lz4): <record> K at chunk byte B".
  std::string Where() const;
  std::string ChunkWhere() const;
  /// `status` with Where() (or ChunkWhere()) before its message.
  Status Located(const Status& status) const;
  Status ChunkLocated(const Status& status) const;
  /// A length from the file that runs past the end of the file (or of the chunk when in one).
  Status Truncated(const std::string& what, std::uint64_t left) const;
  /// A length from the file above its limit in Ros1BagLimits.
  Status AboveLimit(const std::string& what, std::uint64_t bytes, std::uint64_t limit, const char* field) const;

  ByteSource* source_ = nullptr;
  Ros1BagLimits limits_;
  std::uint64_t file_pos_ = 0;  ///< offset of the next record outside chunks (after the current chunk when in one)
  std::vector<Ros1Connection> connections_;
  std::unordered_map<std::uint32_t, std::size_t> connection_index_;  ///< id -> index in connections_
  std::size_t last_connection_ = 0;
  Ros1Message message_;
  Ros1BagStats stats_;
  Status error_;  ///< the first error; Next() returns it from then on

  // From the bag header record: 0 = an unindexed bag (not closed by its writer), whose end is not checked.
  std::uint64_t index_pos_ = 0;
  std::uint32_t conn_count_ = 0;
  std::uint32_t chunk_count_ = 0;
  bool in_index_ = false;  ///< the walk has reached index_pos_
  std::uint64_t index_connections_ = 0;  ///< connection records read in the index section
  std::uint64_t index_chunk_infos_ = 0;  ///< chunk info records read in the index section

  // The record being read, for error messages: its offset in the file, or in the chunk buffer when in a chunk.
  std::uint64_t record_offset_ = 0;
  int record_op_ = -1;  ///< -1 until the op field is read

  // The current chunk: decompressed whole into chunk_buf_, whose capacity grows to the largest chunk.
  bool in_chunk_ = false;
  std::uint64_t chunk_offset_ = 0;
  Compression chunk_compression_ = Compression::kNone;
  std::size_t chunk_size_ = 0;
  std::size_t chunk_pos_ = 0;
  std::uint64_t chunk_record_ = 0;  ///< 0-based index of the current record in the chunk
  std::vector<std::uint8_t> chunk_buf_;
  std::vector<std::uint8_t> compressed_buf_;
  std::vector<std::uint8_t> header_buf_;  ///< a record header outside chunks, with the data length after it
  std::vector<std::uint8_t> data_buf_;    ///< a connection's or message's data outside chunks
};

}  // namespace commerge::platform
