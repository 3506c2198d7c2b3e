// SPDX-License-Identifier: BSD-3-Clause
#include "platform/ros/ros1_bag.hpp"

#include <bzlib.h>

#include <algorithm>
#include <cstring>
#include <optional>
#include <string_view>
#include <utility>

#include "core/common/little_endian.hpp"
#include "platform/ros/container_util.hpp"
#include "platform/ros/lz4_frame.hpp"

namespace commerge::platform {

// The helpers live in their own namespace: in a unity build other files of the library share this translation unit.
namespace bagfmt {
namespace {

using Bytes = Span<const std::uint8_t>;

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr std::size_t kMagicBytes = sizeof(kMagic) - 1;
constexpr std::size_t kMagicPrefixBytes = 9;  // "#ROSBAG V": a ROS bag of some version
constexpr std::uint32_t kNsecPerSec = 1000000000u;

// Record op codes (the header's "op" field).
constexpr std::uint8_t kOpMessage = 0x02;
constexpr std::uint8_t kOpBagHeader = 0x03;
constexpr std::uint8_t kOpIndexData = 0x04;
constexpr std::uint8_t kOpChunk = 0x05;
constexpr std::uint8_t kOpChunkInfo = 0x06;
constexpr std::uint8_t kOpConnection = 0x07;

// Which header block a field error is about.
constexpr const char* kRecordHeader = "the record header";
constexpr const char* kConnectionHeader = "the connection header (record data)";

using container::GetU64Le;
using container::Printable;

Bytes BytesOf(const std::string& s) { return Bytes(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()); }

std::string OpName(int op) {
  switch (op) {
    case -1: return "record";
    case kOpMessage: return "message data record";
    case kOpBagHeader: return "bag header record";
    case kOpIndexData: return "index data record";
    case kOpChunk: return "chunk record";
    case kOpChunkInfo: return "chunk info record";
    case kOpConnection: return "connection record";
    default: return "record of unknown op " + std::to_string(op);
  }
}

const char* CompressionName(int compression) {
  static const char* const kNames[] = {"none", "bz2", "lz4"};
  return kNames[compression];
}

/// Checks that a header block is a sequence of (int32 length, "name=value") fields inside the block.
Status CheckFields(Bytes block, const char* what) {
  std::size_t pos = 0;
  while (pos < block.size()) {
    if (block.size() - pos < 4) {
      return DataLoss(std::string(what) + ": the field length at byte " + std::to_string(pos) +
                      " ends past the end of the header (" + std::to_string(block.size()) + " bytes)");
    }
    const std::uint32_t len = GetU32Le(block.data() + pos);
    if (len > block.size() - pos - 4) {
      return DataLoss(std::string(what) + ": the field of " + std::to_string(len) + " bytes at byte " +
                      std::to_string(pos) + " ends past the end of the header (" + std::to_string(block.size()) +
                      " bytes)");
    }
    const Bytes field = block.subspan(pos + 4, len);
    if (len == 0 || std::memchr(field.data(), '=', len) == nullptr) {
      return DataLoss(std::string(what) + ": the field at byte " + std::to_string(pos) + " has no '=': " +
                      Printable(field));
    }
    pos += 4 + len;
  }
  return Status::Ok();
}

/// The value of the field `name` in a block that passed CheckFields; the last one when the name repeats.
std::optional<Bytes> FindField(Bytes block, std::string_view name) {
  std::optional<Bytes> found;
  std::size_t pos = 0;
  while (pos + 4 <= block.size()) {
    const std::uint32_t len = GetU32Le(block.data() + pos);
    const auto* field = reinterpret_cast<const char*>(block.data() + pos + 4);
    const std::size_t eq = static_cast<std::size_t>(static_cast<const char*>(std::memchr(field, '=', len)) - field);
    if (std::string_view(field, eq) == name) found = block.subspan(pos + 4 + eq + 1, len - eq - 1);
    pos += 4 + len;
  }
  return found;
}

/// The field's value; `width` > 0 requires exactly that many bytes.
Result<Bytes> RequireField(Bytes block, const char* what, std::string_view name, std::size_t width = 0) {
  const std::optional<Bytes> value = FindField(block, name);
  if (!value) return DataLoss(std::string(what) + " has no '" + std::string(name) + "' field");
  if (width != 0 && value->size() != width) {
    return DataLoss(std::string(what) + ": field '" + std::string(name) + "' has " + std::to_string(value->size()) +
                    " bytes, expected " + std::to_string(width));
  }
  return *value;
}

Result<std::uint32_t> RequireU32(Bytes block, const char* what, std::string_view name) {
  auto value = RequireField(block, what, name, 4);
  if (!value.ok()) return value.status();
  return GetU32Le(value->data());
}

Result<std::uint64_t> RequireU64(Bytes block, const char* what, std::string_view name) {
  auto value = RequireField(block, what, name, 8);
  if (!value.ok()) return value.status();
  return GetU64Le(value->data());
}

Result<std::string> RequireString(Bytes block, const char* what, std::string_view name) {
  auto value = RequireField(block, what, name);
  if (!value.ok()) return value.status();
  return std::string(reinterpret_cast<const char*>(value->data()), value->size());
}

/// A ROS time field: uint32 sec, uint32 nsec (< 1e9); returns nanoseconds.
Result<std::int64_t> RequireTime(Bytes block, const char* what, std::string_view name) {
  auto value = RequireField(block, what, name, 8);
  if (!value.ok()) return value.status();
  const std::uint32_t sec = GetU32Le(value->data());
  const std::uint32_t nsec = GetU32Le(value->data() + 4);
  if (nsec >= kNsecPerSec) {
    return DataLoss(std::string(what) + ": field '" + std::string(name) + "' has nsec " + std::to_string(nsec) +
                    ", not below 1e9");
  }
  return static_cast<std::int64_t>(sec) * kNsecPerSec + nsec;
}

/// A connection record: its header (conn, topic) and its data, a header block (type, md5sum, message_definition;
/// callerid and latching optional; latching is true for "1" only).
Result<Ros1Connection> ParseConnection(Bytes header, Bytes data) {
  Ros1Connection c;
  auto id = RequireU32(header, kRecordHeader, "conn");
  if (!id.ok()) return id.status();
  c.id = *id;
  auto topic = RequireString(header, kRecordHeader, "topic");
  if (!topic.ok()) return topic.status();
  c.topic = std::move(*topic);
  const Status fields = CheckFields(data, kConnectionHeader);
  if (!fields.ok()) return fields;
  std::string* const required[] = {&c.type, &c.md5sum, &c.message_definition};
  const char* const names[] = {"type", "md5sum", "message_definition"};
  for (int i = 0; i < 3; ++i) {
    auto value = RequireString(data, kConnectionHeader, names[i]);
    if (!value.ok()) return value.status();
    *required[i] = std::move(*value);
  }
  if (const auto callerid = FindField(data, "callerid")) {
    c.callerid.assign(reinterpret_cast<const char*>(callerid->data()), callerid->size());
  }
  const auto latching = FindField(data, "latching");
  c.latching = latching && latching->size() == 1 && (*latching)[0] == '1';
  return c;
}

/// One bzip2 stream into exactly `out_size` bytes.
Status DecompressBz2(Bytes in, std::uint8_t* out, std::size_t out_size) {
  auto out_len = static_cast<unsigned int>(out_size);  // both below 2^32: the lengths are uint32 fields
  char* const src = const_cast<char*>(reinterpret_cast<const char*>(in.data()));  // bzlib does not write it
  const int rc = BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(out), &out_len, src,
                                            static_cast<unsigned int>(in.size()), 0, 0);
  switch (rc) {
    case BZ_OK:
      if (out_len == out_size) return Status::Ok();
      return DataLoss("bz2: decompressed " + std::to_string(out_len) + " bytes, the chunk header says " +
                      std::to_string(out_size));
    case BZ_OUTBUFF_FULL:
      return DataLoss("bz2: the stream does not end within the " + std::to_string(out_size) +
                      " bytes the chunk header says (it holds more, or it is cut)");
    case BZ_UNEXPECTED_EOF: return DataLoss("bz2: the compressed data ends early (truncated)");
    case BZ_DATA_ERROR_MAGIC: return DataLoss("bz2: the data does not start with a bzip2 stream header");
    case BZ_DATA_ERROR: return DataLoss("bz2: corrupt compressed data (BZ_DATA_ERROR)");
    case BZ_MEM_ERROR: return ResourceExhausted("bz2: out of memory");
    default: return DataLoss("bz2: BZ2_bzBuffToBuffDecompress failed with code " + std::to_string(rc));
  }
}

}  // namespace
}  // namespace bagfmt

// ---- Opening: the magic line and the bag header record -------------------------------------------------------

Result<Ros1BagReader> Ros1BagReader::Open(ByteSource* source, const Ros1BagLimits& limits) {
  if (source == nullptr) return InvalidArgument("Ros1BagReader::Open: no byte source");
  Ros1BagReader reader;
  reader.source_ = source;
  reader.limits_ = limits;
  Status status = reader.ReadMagic();
  if (status.ok()) status = reader.ReadBagHeader();
  if (!status.ok()) return status;
  return Result<Ros1BagReader>(std::move(reader));
}

Status Ros1BagReader::ReadMagic() {
  const std::string& name = source_->name();
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(source_->size(), bagfmt::kMagicBytes));
  std::uint8_t line[bagfmt::kMagicBytes] = {};
  const Status read = source_->ReadAt(0, n, line);
  if (!read.ok()) return read;
  const bagfmt::Bytes got(line, n);
  if (std::memcmp(line, bagfmt::kMagic, std::min(n, bagfmt::kMagicPrefixBytes)) != 0) {
    return InvalidArgument(name + ": not a ROS bag: offset 0 holds " + bagfmt::Printable(got) +
                           ", not \"#ROSBAG V2.0\"");
  }
  if (std::memcmp(line, bagfmt::kMagic, n) == 0 && n < bagfmt::kMagicBytes) {
    return DataLoss(name + ": truncated at offset " + std::to_string(n) + ": the file ends inside the " +
                    "\"#ROSBAG V2.0\" line (" + std::to_string(n) + " bytes)");
  }
  if (std::memcmp(line, bagfmt::kMagic, bagfmt::kMagicBytes) != 0) {
    return InvalidArgument(name + ": offset 0: ROS bag version line " + bagfmt::Printable(got) +
                           " is not supported: this reader reads format 2.0");
  }
  file_pos_ = bagfmt::kMagicBytes;
  return Status::Ok();
}

Status Ros1BagReader::ReadBagHeader() {
  auto record = ReadFileRecord();
  if (!record.ok()) return record.status();
  if (record->op != bagfmt::kOpBagHeader) {
    return Located(DataLoss("the first record is not the bag header (op 3)"));
  }
  auto index_pos = bagfmt::RequireU64(record->header, bagfmt::kRecordHeader, "index_pos");
  auto conn_count = bagfmt::RequireU32(record->header, bagfmt::kRecordHeader, "conn_count");
  auto chunk_count = bagfmt::RequireU32(record->header, bagfmt::kRecordHeader, "chunk_count");
  for (const Status* s : {&index_pos.status(), &conn_count.status(), &chunk_count.status()}) {
    if (!s->ok()) return Located(*s);
  }
  const std::uint64_t end = file_pos_ + 8 + record->header.size() + record->data_len;
  if (*index_pos != 0 && *index_pos < end) {
    return Located(DataLoss("index_pos " + std::to_string(*index_pos) + " points before the end of the bag header (" +
                            std::to_string(end) + ")"));
  }
  index_pos_ = *index_pos;
  conn_count_ = *conn_count;
  chunk_count_ = *chunk_count;
  file_pos_ = end;  // the data is padding
  return Status::Ok();
}

// ---- The walk ----------------------------------------------------------------------------------------------------

Result<Ros1BagReader::Item> Ros1BagReader::Next() {
  if (source_ == nullptr) return InvalidArgument("Ros1BagReader::Next: the reader was not opened");
  while (error_.ok()) {
    Result<Step> step = in_chunk_ ? StepChunk() : StepFile();
    if (!step.ok()) {
      error_ = step.status();
      break;
    }
    switch (*step) {
      case Step::kConnection: return Item::kConnection;
      case Step::kMessage: return Item::kMessage;
      case Step::kEnd: return Item::kEnd;
      case Step::kSkipped: break;
    }
  }
  return error_;
}

Result<Ros1BagReader::Step> Ros1BagReader::StepFile() {
  const Status index = CheckIndexPosition();
  if (!index.ok()) return index;
  if (file_pos_ == source_->size()) {
    const Status end = CheckEnd();
    if (!end.ok()) return end;
    return Step::kEnd;
  }
  auto record = ReadFileRecord();
  if (!record.ok()) return record.status();
  const std::uint64_t data_offset = file_pos_ + 8 + record->header.size();
  Result<Step> step = OnFileRecord(*record, data_offset);
  if (step.ok()) file_pos_ = data_offset + record->data_len;
  return step;
}

Status Ros1BagReader::CheckIndexPosition() {
  if (index_pos_ == 0 || in_index_) return Status::Ok();
  if (file_pos_ == index_pos_) {
    in_index_ = true;
    return Status::Ok();
  }
  if (file_pos_ < index_pos_) return Status::Ok();
  return DataLoss(source_->name() + ": no record starts at offset " + std::to_string(index_pos_) +
                  ", where the bag header puts the index section (a record across it ends at offset " +
                  std::to_string(file_pos_) + ")");
}

Status Ros1BagReader::CheckEnd() const {
  if (index_pos_ == 0) return Status::Ok();  // unindexed: nothing to compare with
  if (!in_index_) {  // CheckIndexPosition() refused a walk past index_pos_: the file ends before it
    return DataLoss(source_->name() + ": truncated at offset " + std::to_string(source_->size()) +
                    ": the file ends before offset " + std::to_string(index_pos_) +
                    ", where the bag header puts the index section");
  }
  if (index_connections_ == conn_count_ && index_chunk_infos_ == chunk_count_ && stats_.chunks == chunk_count_) {
    return Status::Ok();
  }
  return DataLoss(source_->name() + ": truncated or corrupt at offset " + std::to_string(source_->size()) +
                  ": the file ends with " + std::to_string(index_connections_) + " connection and " +
                  std::to_string(index_chunk_infos_) + " chunk info records in the index section (at offset " +
                  std::to_string(index_pos_) + ") and " + std::to_string(stats_.chunks) +
                  " chunks; the bag header announces " + std::to_string(conn_count_) + " connections and " +
                  std::to_string(chunk_count_) + " chunks");
}

Result<Ros1BagReader::RawRecord> Ros1BagReader::ReadFileRecord() {
  record_offset_ = file_pos_;
  record_op_ = -1;
  const std::uint64_t left = source_->size() - file_pos_;
  std::uint8_t len_bytes[4];
  if (left < 4) return Truncated("the 4-byte record header length field", left);
  Status read = source_->ReadAt(file_pos_, 4, len_bytes);
  if (!read.ok()) return read;
  const std::uint32_t header_len = GetU32Le(len_bytes);
  const Status length = CheckHeaderLength(header_len, left);
  if (!length.ok()) return length;
  read = container::ReadInto(source_, file_pos_ + 4, std::size_t{header_len} + 4, &header_buf_);
  if (!read.ok()) return read;
  return ParseRecord(header_buf_.data(), header_len, left);
}

Status Ros1BagReader::CheckHeaderLength(std::uint32_t header_len, std::uint64_t left) const {
  if (header_len > limits_.max_header_bytes) {
    return AboveLimit("record header", header_len, limits_.max_header_bytes, "max_header_bytes");
  }
  if (std::uint64_t{header_len} + 8 > left) {
    return Truncated("the record header of " + std::to_string(header_len) + " bytes (and the data length after it)",
                     left);
  }
  return Status::Ok();
}

Result<Ros1BagReader::RawRecord> Ros1BagReader::ParseRecord(const std::uint8_t* header, std::uint32_t header_len,
                                                            std::uint64_t left) {
  RawRecord record;
  record.header = bagfmt::Bytes(header, header_len);
  record.data_len = GetU32Le(header + header_len);
  const Status fields = bagfmt::CheckFields(record.header, bagfmt::kRecordHeader);
  if (!fields.ok()) return Located(fields);
  auto op = bagfmt::RequireField(record.header, bagfmt::kRecordHeader, "op", 1);
  if (!op.ok()) return Located(op.status());
  record.op = (*op)[0];
  record_op_ = record.op;
  if (record.data_len > left - 8 - header_len) {
    return Truncated("the " + bagfmt::OpName(record.op) + "'s data of " + std::to_string(record.data_len) + " bytes",
                     left - 8 - header_len);
  }
  return record;
}

Result<Ros1BagReader::Step> Ros1BagReader::OnFileRecord(const RawRecord& record, std::uint64_t data_offset) {
  switch (record.op) {
    case bagfmt::kOpChunk: {
      const Status chunk = LoadChunk(record, data_offset);
      if (!chunk.ok()) return chunk;
      return Step::kSkipped;
    }
    case bagfmt::kOpConnection:
    case bagfmt::kOpMessage: {
      const bool connection = record.op == bagfmt::kOpConnection;
      const std::uint64_t limit = connection ? std::uint64_t{limits_.max_header_bytes} : limits_.max_chunk_bytes;
      if (record.data_len > limit) {
        return AboveLimit(connection ? "connection header" : "message data", record.data_len, limit,
                          connection ? "max_header_bytes" : "max_chunk_bytes");
      }
      const Status read = container::ReadInto(source_, data_offset, record.data_len, &data_buf_);
      if (!read.ok()) return read;
      const bagfmt::Bytes data(data_buf_.data(), record.data_len);
      return connection ? OnConnection(record.header, data) : OnMessage(record.header, data, record_offset_);
    }
    case bagfmt::kOpBagHeader: return Located(DataLoss("a second bag header record"));
    case bagfmt::kOpIndexData:
    case bagfmt::kOpChunkInfo: {
      const Status index = OnIndexRecord(record);
      if (!index.ok()) return index;
      return Step::kSkipped;
    }
    default:
      ++stats_.unknown_records_skipped;
      return Step::kSkipped;
  }
}

Status Ros1BagReader::OnIndexRecord(const RawRecord& record) {
  const bool info = record.op == bagfmt::kOpChunkInfo;
  auto version = bagfmt::RequireU32(record.header, bagfmt::kRecordHeader, "ver");
  if (!version.ok()) return Located(version.status());
  if (*version == 1) {  // other versions are skipped unchecked
    auto count = bagfmt::RequireU32(record.header, bagfmt::kRecordHeader, "count");
    if (!count.ok()) return Located(count.status());
    // Version 1 entries: chunk info (conn u32, count u32), index data (time u64, offset u32).
    const std::uint64_t expected = std::uint64_t{*count} * (info ? 8 : 12);
    if (record.data_len != expected) {
      return Located(DataLoss(std::to_string(record.data_len) + " bytes of data for " + std::to_string(*count) +
                              " entries of " + (info ? "8" : "12") + " bytes"));
    }
  }
  ++stats_.index_records_skipped;
  if (info && in_index_) ++index_chunk_infos_;
  return Status::Ok();
}

// ---- Chunks ------------------------------------------------------------------------------------------------------

Status Ros1BagReader::LoadChunk(const RawRecord& record, std::uint64_t data_offset) {
  auto compression = bagfmt::RequireField(record.header, bagfmt::kRecordHeader, "compression");
  if (!compression.ok()) return Located(compression.status());
  auto size = bagfmt::RequireU32(record.header, bagfmt::kRecordHeader, "size");
  if (!size.ok()) return Located(size.status());
  const std::string_view name(reinterpret_cast<const char*>(compression->data()), compression->size());
  if (name == "none") {
    chunk_compression_ = Compression::kNone;
  } else if (name == "bz2") {
    chunk_compression_ = Compression::kBz2;
  } else if (name == "lz4") {
    chunk_compression_ = Compression::kLz4;
  } else {
    return Located(DataLoss("unknown compression " + bagfmt::Printable(*compression) + " (expected none, bz2 or lz4)"));
  }
  chunk_offset_ = record_offset_;
  if (record.data_len > limits_.max_chunk_bytes) {
    return AboveLimit("chunk data", record.data_len, limits_.max_chunk_bytes, "max_chunk_bytes");
  }
  if (*size > limits_.max_chunk_bytes) {
    return AboveLimit("uncompressed chunk (its size field)", *size, limits_.max_chunk_bytes, "max_chunk_bytes");
  }
  const Status data = ReadChunkData(record, data_offset, *size);
  if (!data.ok()) return data;
  in_chunk_ = true;
  chunk_size_ = *size;
  chunk_pos_ = 0;
  chunk_record_ = 0;
  ++stats_.chunks;
  if (chunk_compression_ == Compression::kBz2) ++stats_.chunks_bz2;
  if (chunk_compression_ == Compression::kLz4) ++stats_.chunks_lz4;
  return Status::Ok();
}

Status Ros1BagReader::ReadChunkData(const RawRecord& record, std::uint64_t data_offset, std::uint32_t size) {
  container::EnsureSize(&chunk_buf_, std::max<std::size_t>(size, 1));
  if (chunk_compression_ == Compression::kNone) {
    if (record.data_len != size) {
      return ChunkLocated(DataLoss("the uncompressed chunk holds " + std::to_string(record.data_len) +
                                   " bytes, its size field says " + std::to_string(size)));
    }
    return source_->ReadAt(data_offset, size, chunk_buf_.data());
  }
  const Status read = container::ReadInto(source_, data_offset, record.data_len, &compressed_buf_);
  if (!read.ok()) return read;
  const bagfmt::Bytes in(compressed_buf_.data(), record.data_len);
  const Status unpacked =
      chunk_compression_ == Compression::kLz4
          ? DecompressLz4Frame(in, chunk_buf_.data(), size, "the chunk header says", Lz4Frames::kOne)
          : bagfmt::DecompressBz2(in, chunk_buf_.data(), size);
  return unpacked.ok() ? unpacked : ChunkLocated(unpacked);
}

Result<Ros1BagReader::Step> Ros1BagReader::StepChunk() {
  if (chunk_pos_ == chunk_size_) {
    in_chunk_ = false;
    return Step::kSkipped;
  }
  auto record = ParseChunkRecord();
  if (!record.ok()) return record.status();
  const std::size_t data_offset = chunk_pos_ + 8 + record->header.size();
  const bagfmt::Bytes data(chunk_buf_.data() + data_offset, record->data_len);
  Result<Step> step = OnChunkRecord(*record, data);
  if (step.ok()) {
    chunk_pos_ = data_offset + record->data_len;
    ++chunk_record_;
  }
  return step;
}

Result<Ros1BagReader::RawRecord> Ros1BagReader::ParseChunkRecord() {
  record_offset_ = chunk_pos_;
  record_op_ = -1;
  const std::size_t left = chunk_size_ - chunk_pos_;
  if (left < 4) return Truncated("the 4-byte record header length field", left);
  const std::uint8_t* const start = chunk_buf_.data() + chunk_pos_;
  const std::uint32_t header_len = GetU32Le(start);
  const Status length = CheckHeaderLength(header_len, left);
  if (!length.ok()) return length;
  return ParseRecord(start + 4, header_len, left);
}

Result<Ros1BagReader::Step> Ros1BagReader::OnChunkRecord(const RawRecord& record, bagfmt::Bytes data) {
  switch (record.op) {
    case bagfmt::kOpMessage: return OnMessage(record.header, data, chunk_offset_);
    case bagfmt::kOpConnection:
      if (record.data_len > limits_.max_header_bytes) {
        return AboveLimit("connection header", record.data_len, limits_.max_header_bytes, "max_header_bytes");
      }
      return OnConnection(record.header, data);
    case bagfmt::kOpBagHeader:
    case bagfmt::kOpIndexData:
    case bagfmt::kOpChunk:
    case bagfmt::kOpChunkInfo: return Located(DataLoss("a " + bagfmt::OpName(record.op) + " inside a chunk"));
    default:
      ++stats_.unknown_records_skipped;
      return Step::kSkipped;
  }
}

// ---- Connections and messages ------------------------------------------------------------------------------------

Result<Ros1BagReader::Step> Ros1BagReader::OnConnection(bagfmt::Bytes header, bagfmt::Bytes data) {
  auto parsed = bagfmt::ParseConnection(header, data);
  if (!parsed.ok()) return Located(parsed.status());
  ++stats_.connection_records;
  if (!in_chunk_ && in_index_) ++index_connections_;
  Ros1Connection& c = *parsed;
  const auto known = connection_index_.find(c.id);
  if (known != connection_index_.end()) {
    const Ros1Connection& first = connections_[known->second];
    if (first.topic == c.topic && first.type == c.type) return Step::kSkipped;
    const auto quote = [](const std::string& s) { return bagfmt::Printable(bagfmt::BytesOf(s)); };
    return Located(DataLoss("connection " + std::to_string(c.id) + " declared again with topic " + quote(c.topic) +
                            " and type " + quote(c.type) + "; it was first declared with topic " +
                            quote(first.topic) + " and type " + quote(first.type)));
  }
  if (connections_.size() >= limits_.max_connections) {
    return Located(DataLoss("more than " + std::to_string(limits_.max_connections) +
                            " distinct connection ids (Ros1BagLimits::max_connections)"));
  }
  connection_index_.emplace(c.id, connections_.size());
  last_connection_ = connections_.size();
  connections_.push_back(std::move(c));
  return Step::kConnection;
}

Result<Ros1BagReader::Step> Ros1BagReader::OnMessage(bagfmt::Bytes header, bagfmt::Bytes data, std::uint64_t offset) {
  auto conn = bagfmt::RequireU32(header, bagfmt::kRecordHeader, "conn");
  if (!conn.ok()) return Located(conn.status());
  auto time_ns = bagfmt::RequireTime(header, bagfmt::kRecordHeader, "time");
  if (!time_ns.ok()) return Located(time_ns.status());
  if (FindConnection(*conn) == nullptr) {
    return Located(DataLoss("connection " + std::to_string(*conn) + " was never declared"));
  }
  message_.connection_id = *conn;
  message_.time_ns = *time_ns;
  message_.data = data;
  message_.record_offset = offset;
  message_.record_index = stats_.messages++;
  return Step::kMessage;
}

const Ros1Connection* Ros1BagReader::FindConnection(std::uint32_t id) const noexcept {
  const auto it = connection_index_.find(id);
  return it == connection_index_.end() ? nullptr : &connections_[it->second];
}

std::uint64_t Ros1BagReader::size() const noexcept { return source_ ? source_->size() : 0; }

// ---- Error messages ----------------------------------------------------------------------------------------------

std::string Ros1BagReader::ChunkWhere() const {
  return container::ChunkWhere(source_->name(), chunk_offset_,
                               bagfmt::CompressionName(static_cast<int>(chunk_compression_)));
}

std::string Ros1BagReader::Where() const {
  if (in_chunk_) {
    return container::InChunkWhere(ChunkWhere(), bagfmt::OpName(record_op_), chunk_record_, record_offset_);
  }
  if (record_op_ == bagfmt::kOpChunk && chunk_offset_ == record_offset_) return ChunkWhere();
  return container::InFileWhere(source_->name(), bagfmt::OpName(record_op_), record_offset_);
}

Status Ros1BagReader::Located(const Status& status) const { return container::Prefixed(Where(), status); }

Status Ros1BagReader::ChunkLocated(const Status& status) const { return container::Prefixed(ChunkWhere(), status); }

Status Ros1BagReader::Truncated(const std::string& what, std::uint64_t left) const {
  if (in_chunk_) return Located(container::PastChunkEnd(what, left, chunk_size_));
  return container::PastFileEnd(*source_, record_offset_, what, left);
}

Status Ros1BagReader::AboveLimit(const std::string& what, std::uint64_t bytes, std::uint64_t limit,
                                 const char* field) const {
  return Located(container::AboveLimit(what, bytes, limit, "Ros1BagLimits", field));
}

}  // namespace commerge::platform
