// SPDX-License-Identifier: BSD-3-Clause
#include "platform/ros/mcap_reader.hpp"

#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstring>
#include <utility>

#include "core/common/little_endian.hpp"
#include "platform/ros/container_util.hpp"
#include "platform/ros/lz4_frame.hpp"

namespace commerge::platform {

// The helpers live in their own namespace: in a unity build other files of the library share this translation unit.
namespace mcapfmt {
namespace {

using Bytes = Span<const std::uint8_t>;

constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};
constexpr std::size_t kMagicBytes = sizeof(kMagic);
constexpr std::size_t kRecordHeadBytes = 9;    // opcode u8, content length u64
constexpr std::uint64_t kFooterContent = 20;   // summary_start u64, summary_offset_start u64, summary_crc u32
constexpr std::size_t kMaxCompressionName = 64;

constexpr std::uint8_t kOpHeader = 0x01;
constexpr std::uint8_t kOpFooter = 0x02;
constexpr std::uint8_t kOpSchema = 0x03;
constexpr std::uint8_t kOpChannel = 0x04;
constexpr std::uint8_t kOpMessage = 0x05;
constexpr std::uint8_t kOpChunk = 0x06;
constexpr std::uint8_t kOpDataEnd = 0x0F;

using container::GetU64Le;
using container::Printable;

std::string OpName(int op) {
  static const char* const kNames[] = {"record of opcode 0x00 (reserved)", "Header record", "Footer record",
                                       "Schema record", "Channel record", "Message record", "Chunk record",
                                       "Message Index record", "Chunk Index record", "Attachment record",
                                       "Attachment Index record", "Statistics record", "Metadata record",
                                       "Metadata Index record", "Summary Offset record", "Data End record"};
  if (op < 0) return "record";
  if (op < 16) return kNames[op];
  return "record of unknown opcode " + std::to_string(op);
}

const char* CompressionName(int compression) {
  static const char* const kNames[] = {"uncompressed", "lz4", "zstd"};
  return kNames[compression];
}

/// Reads the fields of one record's content in order, each checked against the content's end.
class FieldReader {
 public:
  explicit FieldReader(Bytes content) : content_(content) {}
  Status U16(const char* name, std::uint16_t* out) {
    return Fixed(name, 2, [&](const std::uint8_t* p) { *out = GetU16Le(p); });
  }
  Status U32(const char* name, std::uint32_t* out) {
    return Fixed(name, 4, [&](const std::uint8_t* p) { *out = GetU32Le(p); });
  }
  Status U64(const char* name, std::uint64_t* out) {
    return Fixed(name, 8, [&](const std::uint8_t* p) { *out = GetU64Le(p); });
  }
  /// A u32 length-prefixed string or byte array (also a Map's byte length: its entries are skipped).
  Status Prefixed(const char* name, Bytes* out) {
    const std::size_t at = pos_;
    std::uint32_t len = 0;
    const Status st = U32(name, &len);
    if (!st.ok()) return st;
    if (len > content_.size() - pos_) {
      return DataLoss(std::string("field ") + name + " of " + std::to_string(len) + " bytes at byte " +
                      std::to_string(at) + " ends past the end of the record (" + std::to_string(content_.size()) +
                      " bytes)");
    }
    *out = content_.subspan(pos_, len);
    pos_ += len;
    return Status::Ok();
  }
  Status String(const char* name, std::string* out) {
    Bytes bytes;
    const Status st = Prefixed(name, &bytes);
    if (st.ok()) out->assign(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    return st;
  }
  Bytes Rest() const { return content_.subspan(pos_, content_.size() - pos_); }

 private:
  template <typename F>
  Status Fixed(const char* name, std::size_t width, F&& load) {
    if (content_.size() - pos_ < width) {
      return DataLoss(std::string("field ") + name + " (" + std::to_string(width) + " bytes) at byte " +
                      std::to_string(pos_) + " ends past the end of the record (" + std::to_string(content_.size()) +
                      " bytes)");
    }
    load(content_.data() + pos_);
    pos_ += width;
    return Status::Ok();
  }
  Bytes content_;
  std::size_t pos_ = 0;
};

/// zlib's crc32 (CRC-32 IEEE, as MCAP uses) over any length.
std::uint32_t Crc32(const std::uint8_t* data, std::size_t n) {
  uLong crc = crc32(0L, Z_NULL, 0);
  while (n > 0) {
    const std::size_t piece = std::min<std::size_t>(n, 1u << 30);
    crc = crc32(crc, data, static_cast<uInt>(piece));
    data += piece;
    n -= piece;
  }
  return static_cast<std::uint32_t>(crc);
}

/// zstd frames into exactly `out_size` bytes.
Status DecompressZstd(ZSTD_DCtx* dctx, Bytes in, std::uint8_t* out, std::size_t out_size) {
  const std::size_t n = ZSTD_decompressDCtx(dctx, out, out_size, in.data(), in.size());
  if (ZSTD_isError(n)) {
    return DataLoss(std::string("zstd: ") + ZSTD_getErrorName(n) + " (" + std::to_string(in.size()) +
                    " compressed bytes, uncompressed_size " + std::to_string(out_size) + ")");
  }
  if (n != out_size) {
    return DataLoss("zstd: decompressed " + std::to_string(n) + " bytes, the chunk's uncompressed_size is " +
                    std::to_string(out_size));
  }
  return Status::Ok();
}

/// The channel's type and encoding as RosChannel holds them (see mcap_reader.hpp).
void ChannelType(const std::string& schema_name, const std::string& message_encoding, RosChannel* c) {
  c->type = schema_name.empty() ? "(no schema)" : schema_name;
  c->encoding = RosEncoding::kCdr;
  if (message_encoding == "ros1") {
    c->encoding = RosEncoding::kRos1;
  } else if (message_encoding != "cdr") {
    c->type += " (" + (message_encoding.empty() ? std::string("no message encoding") : message_encoding) + ")";
  }
}

}  // namespace
}  // namespace mcapfmt

void McapReader::ZstdFree::operator()(void* dctx) const noexcept { ZSTD_freeDCtx(static_cast<ZSTD_DCtx*>(dctx)); }

McapReader::~McapReader() = default;

// ---- Opening: the magic and the Header record --------------------------------------------------------------------

Result<std::unique_ptr<McapReader>> McapReader::Open(ByteSource* source, const McapLimits& limits) {
  if (source == nullptr) return InvalidArgument("McapReader::Open: no byte source");
  std::unique_ptr<McapReader> reader(new McapReader(source, limits));
  Status status = reader->ReadMagic();
  if (status.ok()) status = reader->ReadHeaderRecord();
  if (!status.ok()) return status;
  return reader;
}

Status McapReader::ReadMagic() {
  const std::string& name = source_->name();
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(source_->size(), mcapfmt::kMagicBytes));
  std::uint8_t head[mcapfmt::kMagicBytes] = {};
  const Status read = source_->ReadAt(0, n, head);
  if (!read.ok()) return read;
  const mcapfmt::Bytes got(head, n);
  if (std::memcmp(head, mcapfmt::kMagic, std::min<std::size_t>(n, 5)) != 0) {
    return InvalidArgument(name + ": not an MCAP file: offset 0 holds " + mcapfmt::Printable(got) +
                           ", not \"\\x89MCAP0\\r\\n\"");
  }
  if (n < mcapfmt::kMagicBytes && std::memcmp(head, mcapfmt::kMagic, n) == 0) {
    return DataLoss(name + ": truncated at offset " + std::to_string(n) + ": the file ends inside the MCAP magic");
  }
  if (head[5] != mcapfmt::kMagic[5]) {
    return InvalidArgument(name + ": offset 5: MCAP major version byte " + std::to_string(head[5]) +
                           " is not supported: this reader reads major version 0 ('0')");
  }
  if (std::memcmp(head, mcapfmt::kMagic, mcapfmt::kMagicBytes) != 0) {
    return DataLoss(name + ": offset 0: corrupt MCAP magic " + mcapfmt::Printable(got));
  }
  file_pos_ = mcapfmt::kMagicBytes;
  return Status::Ok();
}

Status McapReader::ReadHeaderRecord() {
  std::uint8_t op = 0;
  std::uint64_t length = 0;
  Status st = ReadFileRecordHead(&op, &length);
  if (!st.ok()) return st;
  if (op != mcapfmt::kOpHeader) return Located(DataLoss("the first record is not the Header record (opcode 0x01)"));
  auto content = ReadContent(file_pos_ + mcapfmt::kRecordHeadBytes, length);
  if (!content.ok()) return content.status();
  mcapfmt::FieldReader fields(*content);
  st = fields.String("profile", &profile_);
  if (st.ok()) st = fields.String("library", &library_);
  if (!st.ok()) return Located(st);
  file_pos_ += mcapfmt::kRecordHeadBytes + length;
  return Status::Ok();
}

// ---- The walk ----------------------------------------------------------------------------------------------------

Result<RosMessageSource::Item> McapReader::Next() {
  while (error_.ok()) {
    if (ended_) return Item::kEnd;
    Result<Step> step = in_chunk_ ? StepChunk() : StepFile();
    if (!step.ok()) {
      error_ = step.status();
      break;
    }
    switch (*step) {
      case Step::kChannel: return Item::kChannel;
      case Step::kMessage: return Item::kMessage;
      case Step::kEnd: ended_ = true; return Item::kEnd;
      case Step::kSkipped: break;
    }
  }
  return error_;
}

Status McapReader::ReadFileRecordHead(std::uint8_t* op, std::uint64_t* length) {
  record_offset_ = file_pos_;
  record_op_ = -1;
  const std::uint64_t left = source_->size() - file_pos_;
  if (left < mcapfmt::kRecordHeadBytes) {
    return Truncated("the record's opcode and length (9 bytes)" +
                     std::string(left == 0 ? "; the file ends before the Data End record" : ""), left);
  }
  std::uint8_t head[mcapfmt::kRecordHeadBytes];
  const Status read = source_->ReadAt(file_pos_, sizeof(head), head);
  if (!read.ok()) return read;
  *op = head[0];
  record_op_ = head[0];
  *length = mcapfmt::GetU64Le(head + 1);
  if (*length > left - mcapfmt::kRecordHeadBytes) {
    return Truncated("the " + mcapfmt::OpName(*op) + "'s content of " + std::to_string(*length) + " bytes",
                     left - mcapfmt::kRecordHeadBytes);
  }
  return Status::Ok();
}

Result<Span<const std::uint8_t>> McapReader::ReadContent(std::uint64_t offset, std::uint64_t length) {
  if (length > limits_.max_record_bytes) {
    return AboveLimit(mcapfmt::OpName(record_op_) + " content", length, limits_.max_record_bytes, "max_record_bytes");
  }
  const Status read = container::ReadInto(source_, offset, static_cast<std::size_t>(length), &record_buf_);
  if (!read.ok()) return read;
  return mcapfmt::Bytes(record_buf_.data(), static_cast<std::size_t>(length));
}

Result<McapReader::Step> McapReader::StepFile() {
  std::uint8_t op = 0;
  std::uint64_t length = 0;
  const Status head = ReadFileRecordHead(&op, &length);
  if (!head.ok()) return head;
  const std::uint64_t content_offset = file_pos_ + mcapfmt::kRecordHeadBytes;
  const std::uint64_t end = content_offset + length;
  Result<Step> step = Step::kSkipped;
  switch (op) {
    case mcapfmt::kOpSchema:
    case mcapfmt::kOpChannel:
    case mcapfmt::kOpMessage: {
      auto content = ReadContent(content_offset, length);
      if (!content.ok()) return content.status();
      step = OnDataRecord(op, *content, record_offset_);
      break;
    }
    case mcapfmt::kOpChunk: {
      const Status chunk = LoadChunk(content_offset, length);
      if (!chunk.ok()) return chunk;
      break;
    }
    case mcapfmt::kOpDataEnd:
    case mcapfmt::kOpFooter: {
      if (op == mcapfmt::kOpDataEnd && length < 4) {
        return Located(DataLoss("content of " + std::to_string(length) + " bytes, below the 4 of data_section_crc"));
      }
      const Status st = CheckEnd(op == mcapfmt::kOpFooter, end);
      if (!st.ok()) return st;
      file_pos_ = source_->size();
      return Step::kEnd;
    }
    case 0x00:
    case mcapfmt::kOpHeader: return Located(DataLoss("unexpected in the data section"));
    default: ++stats_.records_skipped; break;
  }
  if (step.ok()) file_pos_ = end;
  return step;
}

Status McapReader::CheckEnd(bool at_footer, std::uint64_t record_end) {
  const std::uint64_t size = source_->size();
  constexpr std::uint64_t kFooterBytes = mcapfmt::kRecordHeadBytes + mcapfmt::kFooterContent;
  constexpr std::uint64_t kTail = kFooterBytes + mcapfmt::kMagicBytes;
  const std::string after = "after the " + mcapfmt::OpName(record_op_) + " at offset " + std::to_string(record_offset_);
  if (at_footer && record_end - record_offset_ != kFooterBytes) {
    return Located(DataLoss("content of " + std::to_string(record_end - record_offset_ - mcapfmt::kRecordHeadBytes) +
                            " bytes, not 20"));
  }
  // At a Footer only the magic may follow; at Data End the summary (not read), then the Footer and the magic.
  const std::uint64_t needed = at_footer ? mcapfmt::kMagicBytes : kTail;
  if (size - record_end < needed) {
    return DataLoss(source_->name() + ": truncated at offset " + std::to_string(size) + ": the file ends " +
                    std::to_string(size - record_end) + " bytes " + after + ", before the Footer record and the " +
                    "MCAP magic");
  }
  if (at_footer && size - record_end != needed) {
    return DataLoss(source_->name() + ": offset " + std::to_string(record_end + needed) + ": " +
                    std::to_string(size - record_end - needed) + " bytes after the Footer record and the MCAP magic");
  }
  std::uint8_t bytes[kTail];
  const Status read = source_->ReadAt(size - kTail, sizeof(bytes), bytes);
  if (!read.ok()) return read;
  const bool footer = bytes[0] == mcapfmt::kOpFooter && mcapfmt::GetU64Le(bytes + 1) == mcapfmt::kFooterContent;
  if (!footer || std::memcmp(bytes + kFooterBytes, mcapfmt::kMagic, mcapfmt::kMagicBytes) != 0) {
    return DataLoss(source_->name() + ": truncated or corrupt at offset " + std::to_string(size - kTail) + ": the " +
                    std::to_string(kTail) + " bytes at the end of the file are not a Footer record (opcode 0x02, " +
                    "20 bytes) and the MCAP magic (" + after + ")");
  }
  return Status::Ok();
}

// ---- Chunks ------------------------------------------------------------------------------------------------------

Status McapReader::LoadChunk(std::uint64_t content_offset, std::uint64_t length) {
  chunk_offset_ = record_offset_;
  // message_start_time, message_end_time, uncompressed_size u64, uncompressed_crc u32, compression length u32.
  std::uint8_t fixed[32];
  if (length < sizeof(fixed) + 8) {
    return Located(DataLoss("content of " + std::to_string(length) + " bytes, below the 40 of its fixed fields"));
  }
  Status st = source_->ReadAt(content_offset, sizeof(fixed), fixed);
  if (!st.ok()) return st;
  const std::uint64_t uncompressed = mcapfmt::GetU64Le(fixed + 16);
  const std::uint32_t crc = GetU32Le(fixed + 24);
  const std::uint32_t name_len = GetU32Le(fixed + 28);
  if (name_len > length - sizeof(fixed) - 8) {
    return Located(DataLoss("compression name of " + std::to_string(name_len) + " bytes ends past the record"));
  }
  std::uint8_t name[mcapfmt::kMaxCompressionName + 8];
  const std::size_t name_read = std::min<std::size_t>(name_len, mcapfmt::kMaxCompressionName);
  st = source_->ReadAt(content_offset + sizeof(fixed), name_read, name);
  if (!st.ok()) return st;
  const std::string compression(reinterpret_cast<const char*>(name), name_read);
  if (name_len <= mcapfmt::kMaxCompressionName && (compression.empty() || compression == "lz4" ||
                                                   compression == "zstd")) {
    chunk_compression_ = compression.empty() ? Compression::kNone
                         : compression == "lz4" ? Compression::kLz4 : Compression::kZstd;
  } else {
    return Located(DataLoss("unknown compression " + mcapfmt::Printable(mcapfmt::Bytes(name, name_read)) +
                            " (this reader reads \"\", \"lz4\" and \"zstd\")"));
  }
  const std::uint64_t records_len_at = content_offset + sizeof(fixed) + name_len;
  st = source_->ReadAt(records_len_at, 8, name);
  if (!st.ok()) return st;
  const std::uint64_t records_len = mcapfmt::GetU64Le(name);
  if (records_len > length - sizeof(fixed) - name_len - 8) {
    return Located(DataLoss("records of " + std::to_string(records_len) + " bytes end past the record's " +
                            std::to_string(length) + " bytes"));
  }
  return ReadChunkRecords(records_len_at + 8, records_len, uncompressed, crc);
}

Status McapReader::ReadChunkRecords(std::uint64_t offset, std::uint64_t compressed, std::uint64_t uncompressed,
                                    std::uint32_t crc) {
  if (compressed > limits_.max_chunk_bytes) {
    return AboveLimit("compressed chunk", compressed, limits_.max_chunk_bytes, "max_chunk_bytes");
  }
  if (uncompressed > limits_.max_chunk_bytes) {
    return AboveLimit("uncompressed chunk (uncompressed_size)", uncompressed, limits_.max_chunk_bytes,
                      "max_chunk_bytes");
  }
  const auto size = static_cast<std::size_t>(uncompressed);
  if (chunk_compression_ == Compression::kNone) {
    if (compressed != uncompressed) {
      return ChunkLocated(DataLoss("the uncompressed chunk holds " + std::to_string(compressed) +
                                   " bytes of records, its uncompressed_size says " + std::to_string(uncompressed)));
    }
    const Status read = container::ReadInto(source_, offset, size, &chunk_buf_);
    if (!read.ok()) return read;
  } else {
    const Status read = container::ReadInto(source_, offset, static_cast<std::size_t>(compressed), &compressed_buf_);
    if (!read.ok()) return read;
    const Status unpacked = Decompress(mcapfmt::Bytes(compressed_buf_.data(), compressed), uncompressed);
    if (!unpacked.ok()) return ChunkLocated(unpacked);
  }
  if (crc != 0 && mcapfmt::Crc32(chunk_buf_.data(), size) != crc) {
    return ChunkLocated(DataLoss("uncompressed_crc mismatch: the records' CRC-32 is " +
                                 std::to_string(mcapfmt::Crc32(chunk_buf_.data(), size)) + ", the chunk says " +
                                 std::to_string(crc)));
  }
  in_chunk_ = true;
  chunk_size_ = size;
  chunk_pos_ = 0;
  chunk_record_ = 0;
  ++stats_.chunks;
  if (chunk_compression_ == Compression::kLz4) ++stats_.chunks_lz4;
  if (chunk_compression_ == Compression::kZstd) ++stats_.chunks_zstd;
  return Status::Ok();
}

Status McapReader::Decompress(Span<const std::uint8_t> in, std::uint64_t size) {
  const auto n = static_cast<std::size_t>(size);
  container::EnsureSize(&chunk_buf_, std::max<std::size_t>(n, 1));
  if (chunk_compression_ == Compression::kLz4) {
    return DecompressLz4Frame(in, chunk_buf_.data(), n, "the chunk's uncompressed_size says", Lz4Frames::kOneOrMore);
  }
  if (!zstd_) {
    zstd_.reset(ZSTD_createDCtx());
    if (!zstd_) return ResourceExhausted("zstd: cannot create a decompression context");
  }
  return mcapfmt::DecompressZstd(static_cast<ZSTD_DCtx*>(zstd_.get()), in, chunk_buf_.data(), n);
}

Result<McapReader::Step> McapReader::StepChunk() {
  if (chunk_pos_ == chunk_size_) {  // file_pos_ is already past the chunk
    in_chunk_ = false;
    return Step::kSkipped;
  }
  record_offset_ = chunk_pos_;
  record_op_ = -1;
  const std::size_t left = chunk_size_ - chunk_pos_;
  if (left < mcapfmt::kRecordHeadBytes) return Truncated("the record's opcode and length (9 bytes)", left);
  const std::uint8_t* const start = chunk_buf_.data() + chunk_pos_;
  const std::uint8_t op = start[0];
  record_op_ = op;
  const std::uint64_t length = mcapfmt::GetU64Le(start + 1);
  if (length > left - mcapfmt::kRecordHeadBytes) {
    return Truncated("the " + mcapfmt::OpName(op) + "'s content of " + std::to_string(length) + " bytes",
                     left - mcapfmt::kRecordHeadBytes);
  }
  Result<Step> step = Step::kSkipped;
  if (op == mcapfmt::kOpSchema || op == mcapfmt::kOpChannel || op == mcapfmt::kOpMessage) {
    step = OnDataRecord(op, mcapfmt::Bytes(start + mcapfmt::kRecordHeadBytes, length), chunk_offset_);
  } else if (op <= mcapfmt::kOpDataEnd) {
    return Located(DataLoss("not allowed inside a chunk"));
  } else {
    ++stats_.records_skipped;
  }
  if (step.ok()) {
    chunk_pos_ += mcapfmt::kRecordHeadBytes + static_cast<std::size_t>(length);
    ++chunk_record_;
  }
  return step;
}

// ---- Schemas, channels and messages ------------------------------------------------------------------------------

Result<McapReader::Step> McapReader::OnDataRecord(std::uint8_t op, Span<const std::uint8_t> content,
                                                  std::uint64_t message_offset) {
  if (op == mcapfmt::kOpSchema) return OnSchema(content);
  if (op == mcapfmt::kOpChannel) return OnChannel(content);
  return OnMessage(content, message_offset);
}

Result<McapReader::Step> McapReader::OnSchema(Span<const std::uint8_t> content) {
  mcapfmt::FieldReader fields(content);
  std::uint16_t id = 0;
  SchemaInfo schema;
  mcapfmt::Bytes data;
  Status st = fields.U16("id", &id);
  if (st.ok()) st = fields.String("name", &schema.name);
  if (st.ok()) st = fields.String("encoding", &schema.encoding);
  if (st.ok()) st = fields.Prefixed("data", &data);
  if (!st.ok()) return Located(st);
  if (id == 0) return Located(DataLoss("schema id 0 is reserved (no schema)"));
  ++stats_.schema_records;
  const auto known = schemas_.find(id);
  if (known == schemas_.end()) {
    schemas_.emplace(id, std::move(schema));
  } else if (known->second.name != schema.name || known->second.encoding != schema.encoding) {
    return Located(DataLoss("schema " + std::to_string(id) + " declared again as \"" + schema.name + "\" (" +
                            schema.encoding + "); it was first \"" + known->second.name + "\" (" +
                            known->second.encoding + ")"));
  }
  return Step::kSkipped;
}

Result<McapReader::Step> McapReader::OnChannel(Span<const std::uint8_t> content) {
  mcapfmt::FieldReader fields(content);
  std::uint16_t id = 0;
  ChannelKey key;
  mcapfmt::Bytes metadata;
  Status st = fields.U16("id", &id);
  if (st.ok()) st = fields.U16("schema_id", &key.schema_id);
  if (st.ok()) st = fields.String("topic", &key.topic);
  if (st.ok()) st = fields.String("message_encoding", &key.message_encoding);
  if (st.ok()) st = fields.Prefixed("metadata", &metadata);
  if (!st.ok()) return Located(st);
  ++stats_.channel_records;
  const auto known = channel_index_.find(id);
  if (known != channel_index_.end()) {
    const ChannelKey& first = channel_keys_[known->second];
    if (first.schema_id == key.schema_id && first.topic == key.topic &&
        first.message_encoding == key.message_encoding) {
      return Step::kSkipped;
    }
    return Located(DataLoss("channel " + std::to_string(id) + " declared again with topic \"" + key.topic +
                            "\", schema " + std::to_string(key.schema_id) + "; it was first topic \"" + first.topic +
                            "\", schema " + std::to_string(first.schema_id)));
  }
  const auto schema = schemas_.find(key.schema_id);
  if (key.schema_id != 0 && schema == schemas_.end()) {
    return Located(DataLoss("channel " + std::to_string(id) + " (topic \"" + key.topic + "\") uses schema " +
                            std::to_string(key.schema_id) + ", which was never declared"));
  }
  RosChannel c;
  c.id = id;
  c.topic = key.topic;
  mcapfmt::ChannelType(key.schema_id == 0 ? std::string() : schema->second.name, key.message_encoding, &c);
  channel_index_.emplace(id, channels_.size());
  last_channel_ = channels_.size();
  channels_.push_back(std::move(c));
  channel_keys_.push_back(std::move(key));
  return Step::kChannel;
}

Result<McapReader::Step> McapReader::OnMessage(Span<const std::uint8_t> content, std::uint64_t offset) {
  mcapfmt::FieldReader fields(content);
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0;
  std::uint64_t publish_time = 0;
  Status st = fields.U16("channel_id", &channel_id);
  if (st.ok()) st = fields.U32("sequence", &sequence);
  if (st.ok()) st = fields.U64("log_time", &log_time);
  if (st.ok()) st = fields.U64("publish_time", &publish_time);
  if (!st.ok()) return Located(st);
  if (channel_index_.find(channel_id) == channel_index_.end()) {
    return Located(DataLoss("channel " + std::to_string(channel_id) + " was never declared"));
  }
  message_.channel_id = channel_id;
  message_.log_time_ns = static_cast<std::int64_t>(log_time);
  message_.data = fields.Rest();
  message_.offset = offset;
  message_.index = stats_.messages++;
  return Step::kMessage;
}

const RosChannel* McapReader::FindChannel(std::uint32_t id) const noexcept {
  const auto it = channel_index_.find(id);
  return it == channel_index_.end() ? nullptr : &channels_[it->second];
}

// ---- Error messages ----------------------------------------------------------------------------------------------

std::string McapReader::ChunkWhere() const {
  return container::ChunkWhere(source_->name(), chunk_offset_,
                               mcapfmt::CompressionName(static_cast<int>(chunk_compression_)));
}

std::string McapReader::Where() const {
  if (in_chunk_) {
    return container::InChunkWhere(ChunkWhere(), mcapfmt::OpName(record_op_), chunk_record_, record_offset_);
  }
  return container::InFileWhere(source_->name(), mcapfmt::OpName(record_op_), record_offset_);
}

Status McapReader::Located(const Status& status) const { return container::Prefixed(Where(), status); }

Status McapReader::ChunkLocated(const Status& status) const { return container::Prefixed(ChunkWhere(), status); }

Status McapReader::Truncated(const std::string& what, std::uint64_t left) const {
  if (in_chunk_) return Located(container::PastChunkEnd(what, left, chunk_size_));
  return container::PastFileEnd(*source_, record_offset_, what, left);
}

Status McapReader::AboveLimit(const std::string& what, std::uint64_t bytes, std::uint64_t limit,
                              const char* field) const {
  return Located(container::AboveLimit(what, bytes, limit, "McapLimits", field));
}

}  // namespace commerge::platform
