// SPDX-License-Identifier: BSD-3-Clause
// MCAP (https://mcap.dev/spec, major version 0): a streaming reader of our own over liblz4 (LZ4 frame format),
// libzstd and zlib's crc32. It walks the data section in file order: the leading magic, the Header record, then
// records (opcode u8, content length u64, content) up to the Data End record. Chunks (compression "", "lz4" or
// "zstd") are decompressed one at a time into a reused buffer, their uncompressed_crc checked when it is not 0,
// and the Schema, Channel and Message records inside them read in order. Message Index, Chunk Index, Attachment,
// Attachment Index, Statistics, Metadata, Metadata Index and Summary Offset records, and records of opcodes this
// reader does not know (0x10..0xFF: later minor versions, private records), are skipped by their length after a
// check that the length stays inside the file (or the chunk). Opcode 0x00 (reserved) is an error: zeroed or
// corrupt bytes. Extra bytes at the end of a known record (fields of a later minor version) are ignored.
//
// The summary section after Data End is not read; at Data End the end of the file is checked instead: it must be
// a Footer record (opcode 0x02, 20 bytes) and the trailing magic, so a file cut anywhere before its last byte is
// an error naming the offset, never a silent end. A Footer met in place of Data End ends the walk the same way
// when it is followed by the trailing magic and nothing else.
//
// Channels: RosChannel::type is the name of the channel's schema ("sensor_msgs/msg/PointCloud2"; "(no schema)"
// for schema id 0), encoding kCdr for message_encoding "cdr", kRos1 for "ros1". A channel of any other message
// encoding (json, protobuf, flatbuffer, ...) is announced too, with the encoding appended to its type in
// parentheses ("sensor_msgs/msg/PointCloud2 (json)") and encoding kCdr: RosMessageKindOf() of that type is
// kUnsupported, so `commerge import` lists it as a topic it does not read and refuses it as --scan-topic /
// --pose-topic, and no decoder ever sees its bytes.
//
// Memory is bounded by the largest chunk (compressed + uncompressed) or the largest record read whole, never by
// the file: McapLimits caps every length read from the file before anything is allocated for it, and every
// length is also checked against the bytes left in the file (or the chunk) first.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "platform/ros/byte_source.hpp"
#include "platform/ros/message_source.hpp"

namespace commerge::platform {

/// Caps on lengths read from the file (a length above its cap is a DataLoss error naming the record).
struct McapLimits {
  /// One record read whole outside chunks: Header, Schema, Channel, Message [bytes]. Skipped records are not read
  /// and not capped (only checked against the file's size).
  std::uint64_t max_record_bytes = 512ull << 20;
  /// One chunk, its compressed records or its uncompressed_size [bytes].
  std::uint64_t max_chunk_bytes = 512ull << 20;
};

struct McapStats {
  std::uint64_t chunks = 0;
  std::uint64_t chunks_lz4 = 0;
  std::uint64_t chunks_zstd = 0;
  std::uint64_t messages = 0;
  std::uint64_t schema_records = 0;
  std::uint64_t channel_records = 0;
  std::uint64_t records_skipped = 0;  ///< indexes, attachments, metadata, statistics, unknown opcodes
};

class McapReader final : public RosMessageSource {
 public:
  /// Checks the leading magic and the Header record. `source` is not owned and must outlive the reader. Errors:
  /// InvalidArgument (not an MCAP file, another major version), DataLoss (truncated, corrupt); both name the
  /// source and the byte offset. A failed read passes on the source's error.
  static Result<std::unique_ptr<McapReader>> Open(ByteSource* source, const McapLimits& limits = {});

  /// The next new channel (the first Channel record of its id; a repeat with the same topic, schema and encoding
  /// is not reported again, a different one is an error) or message, in file order; kEnd after Data End once the
  /// Footer and trailing magic are found. A message on a channel id never declared, a channel on a schema id never
  /// declared: DataLoss. Every error names the source, the offset and the record ("a.mcap: chunk at offset 4117
  /// (zstd): Message record 12 at chunk byte 3081: ..."); after an error Next() returns it again.
  Result<Item> Next() override;
  const RosChannel& channel() const noexcept override { return channels_[last_channel_]; }
  const RosRecord& message() const noexcept override { return message_; }
  const RosChannel* FindChannel(std::uint32_t id) const noexcept override;
  /// Offset of the next record outside chunks (after the current chunk when in one); size() at kEnd.
  std::uint64_t position() const noexcept override { return file_pos_; }
  std::uint64_t size() const noexcept override { return source_->size(); }
  const char* format() const noexcept override { return "MCAP"; }

  /// The Header record's profile ("ros2", "ros1", or "") and library.
  const std::string& profile() const noexcept { return profile_; }
  const std::string& library() const noexcept { return library_; }
  const McapStats& stats() const noexcept { return stats_; }

  ~McapReader() override;
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

 private:
  enum class Step { kSkipped, kChannel, kMessage, kEnd };
  enum class Compression : std::uint8_t { kNone, kLz4, kZstd };
  struct SchemaInfo {
    std::string name;
    std::string encoding;
  };
  struct ZstdFree {
    void operator()(void* dctx) const noexcept;
  };

  McapReader(ByteSource* source, const McapLimits& limits) : source_(source), limits_(limits) {}
  Status ReadMagic();
  Status ReadHeaderRecord();
  Result<Step> StepFile();
  Result<Step> StepChunk();
  /// Reads the opcode and length of the record at file_pos_ and checks the length against the file.
  Status ReadFileRecordHead(std::uint8_t* op, std::uint64_t* length);
  /// Reads a whole record's content into record_buf_ (capped by max_record_bytes).
  Result<Span<const std::uint8_t>> ReadContent(std::uint64_t offset, std::uint64_t length);
  /// Schema, Channel and Message records, in a chunk or not.
  Result<Step> OnDataRecord(std::uint8_t op, Span<const std::uint8_t> content, std::uint64_t message_offset);
  Result<Step> OnSchema(Span<const std::uint8_t> content);
  Result<Step> OnChannel(Span<const std::uint8_t> content);
  Result<Step> OnMessage(Span<const std::uint8_t> content, std::uint64_t offset);
  Status LoadChunk(std::uint64_t content_offset, std::uint64_t length);
  Status ReadChunkRecords(std::uint64_t offset, std::uint64_t compressed, std::uint64_t uncompressed,
                          std::uint32_t crc);
  Status Decompress(Span<const std::uint8_t> in, std::uint64_t size);
  /// At Data End (or a Footer): the Footer record and the trailing magic end the file.
  Status CheckEnd(bool at_footer, std::uint64_t record_end);

  /// "<source>: <Op> record at offset N" or "<source>: chunk at offset N (lz4): <Op> record K at chunk byte B".
  std::string Where() const;
  std::string ChunkWhere() const;
  Status Located(const Status& status) const;
  Status ChunkLocated(const Status& status) const;
  /// A length from the file that runs past the end of the file (or of the chunk when in one).
  Status Truncated(const std::string& what, std::uint64_t left) const;
  Status AboveLimit(const std::string& what, std::uint64_t bytes, std::uint64_t limit, const char* field) const;

  ByteSource* source_ = nullptr;
  McapLimits limits_;
  std::uint64_t file_pos_ = 0;
  bool ended_ = false;
  Status error_;
  std::string profile_;
  std::string library_;
  McapStats stats_;

  std::unordered_map<std::uint16_t, SchemaInfo> schemas_;
  struct ChannelKey {
    std::uint16_t schema_id = 0;
    std::string topic;
    std::string message_encoding;
  };
  std::vector<RosChannel> channels_;
  std::vector<ChannelKey> channel_keys_;  ///< parallel to channels_: what a repeated record is compared with
  std::unordered_map<std::uint32_t, std::size_t> channel_index_;
  std::size_t last_channel_ = 0;
  RosRecord message_;

  // The record being read, for error messages: its offset in the file, or in the chunk buffer when in a chunk.
  std::uint64_t record_offset_ = 0;
  int record_op_ = -1;

  bool in_chunk_ = false;
  std::uint64_t chunk_offset_ = 0;
  Compression chunk_compression_ = Compression::kNone;
  std::size_t chunk_size_ = 0;
  std::size_t chunk_pos_ = 0;
  std::uint64_t chunk_record_ = 0;
  std::vector<std::uint8_t> chunk_buf_;
  std::vector<std::uint8_t> compressed_buf_;
  std::vector<std::uint8_t> record_buf_;
  std::unique_ptr<void, ZstdFree> zstd_;
};

}  // namespace commerge::platform
