// SPDX-License-Identifier: BSD-3-Clause
// McapReader on MCAP files built here record by record (a small writer of our own, chunks compressed by liblz4 and
// libzstd directly), whole and damaged: cut at every byte, bytes changed, CRCs and compressed data corrupted,
// lengths that lie, channels and schemas never declared. Files by the official writer (@mcap/core) are read in
// the end-to-end test tests/apps/ros2_import_test.sh.
#include <doctest/doctest.h>
#include <lz4frame.h>
#include <zlib.h>
#include <zstd.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "platform/ros/byte_source.hpp"
#include "platform/ros/mcap_reader.hpp"
#include "platform/ros/message_source.hpp"
#include "tests/support/test_data.hpp"

// A named namespace: in a unity build the other test files of this binary share the translation unit.
namespace commerge::platform::mcap_reader_test {

// ---- A minimal MCAP writer ---------------------------------------------------------------------------------------

const std::string kMagic("\x89MCAP0\r\n", 8);

std::string U16(std::uint16_t v) { return std::string{static_cast<char>(v & 0xFF), static_cast<char>(v >> 8)}; }

std::string U32(std::uint32_t v) {
  std::string s(4, '\0');
  for (int i = 0; i < 4; ++i) s[i] = static_cast<char>((v >> (8 * i)) & 0xFFu);
  return s;
}

std::string U64(std::uint64_t v) {
  return U32(static_cast<std::uint32_t>(v)) + U32(static_cast<std::uint32_t>(v >> 32));
}

std::string Str(const std::string& s) { return U32(static_cast<std::uint32_t>(s.size())) + s; }

std::string Rec(std::uint8_t op, const std::string& content) {
  return std::string(1, static_cast<char>(op)) + U64(content.size()) + content;
}

std::string Header() { return Rec(0x01, Str("ros2") + Str("commerge test")); }
std::string Schema(std::uint16_t id, const std::string& name, const std::string& encoding = "ros2msg") {
  return Rec(0x03, U16(id) + Str(name) + Str(encoding) + Str("# definition"));
}
std::string Channel(std::uint16_t id, std::uint16_t schema, const std::string& topic,
                    const std::string& encoding = "cdr") {
  const std::string metadata = Str("offered_qos_profiles") + Str("");
  return Rec(0x04, U16(id) + U16(schema) + Str(topic) + Str(encoding) + Str(metadata));
}
std::string Message(std::uint16_t channel, std::uint64_t log_time, const std::string& data) {
  return Rec(0x05, U16(channel) + U32(7) + U64(log_time) + U64(log_time + 1) + data);
}
std::string DataEnd() { return Rec(0x0F, U32(0)); }
std::string Footer() { return Rec(0x02, U64(0) + U64(0) + U32(0)); }

std::uint32_t Crc(const std::string& s) {
  return static_cast<std::uint32_t>(crc32(0L, reinterpret_cast<const Bytef*>(s.data()), static_cast<uInt>(s.size())));
}

std::string Compress(const std::string& records, const std::string& compression) {
  if (compression == "lz4") {
    std::string out(LZ4F_compressFrameBound(records.size(), nullptr), '\0');
    const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), records.data(), records.size(), nullptr);
    REQUIRE_FALSE(LZ4F_isError(n));
    out.resize(n);
    return out;
  }
  if (compression == "zstd") {
    std::string out(ZSTD_compressBound(records.size()), '\0');
    const std::size_t n = ZSTD_compress(out.data(), out.size(), records.data(), records.size(), 3);
    REQUIRE_FALSE(ZSTD_isError(n));
    out.resize(n);
    return out;
  }
  return records;
}

/// A chunk of `records`; `crc` and `compressed` override what is written when given.
std::string ChunkRaw(const std::string& compression, std::uint32_t crc,
                     const std::string& compressed, std::uint64_t uncompressed_size) {
  return Rec(0x06, U64(100) + U64(200) + U64(uncompressed_size) + U32(crc) + Str(compression) +
                       U64(compressed.size()) + compressed);
}
std::string Chunk(const std::string& records, const std::string& compression = "", bool with_crc = true) {
  return ChunkRaw(compression, with_crc ? Crc(records) : 0, Compress(records, compression), records.size());
}

/// Magic, Header, the data section's records, Data End, `summary`, Footer, magic.
std::string File(const std::string& data, const std::string& summary = "") {
  return kMagic + Header() + data + DataEnd() + summary + Footer() + kMagic;
}

/// Offset of the first record after the Header.
std::string First() { return std::to_string(kMagic.size() + Header().size()); }

std::string Definitions() {
  return Schema(1, "sensor_msgs/msg/PointCloud2") + Channel(3, 1, "/points") + Schema(2, "nav_msgs/msg/Odometry") +
         Channel(4, 2, "/odom");
}

// ---- Reading -----------------------------------------------------------------------------------------------------

struct Walked {
  std::vector<RosChannel> channels;
  std::vector<std::string> messages;  // "<channel id>@<log time>:<data>"
  Status status;
  bool ended = false;
  McapStats stats;
};

Walked Walk(const std::string& file, const McapLimits& limits = {}) {
  Walked w;
  MemoryByteSource source(Span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(file.data()), file.size()),
                          "t.mcap");
  auto reader = McapReader::Open(&source, limits);
  if (!reader.ok()) {
    w.status = reader.status();
    return w;
  }
  for (int i = 0; i < 100000; ++i) {
    auto item = (*reader)->Next();
    if (!item.ok()) {
      w.status = item.status();
      auto again = (*reader)->Next();
      CHECK_FALSE(again.ok());
      CHECK(again.status().message() == item.status().message());
      break;
    }
    if (*item == RosMessageSource::Item::kEnd) {
      w.ended = true;
      CHECK((*reader)->position() == (*reader)->size());
      break;
    }
    if (*item == RosMessageSource::Item::kChannel) {
      w.channels.push_back((*reader)->channel());
      continue;
    }
    const RosRecord& m = (*reader)->message();
    REQUIRE((*reader)->FindChannel(m.channel_id) != nullptr);
    w.messages.push_back(std::to_string(m.channel_id) + "@" + std::to_string(m.log_time_ns) + ":" +
                         std::string(reinterpret_cast<const char*>(m.data.data()), m.data.size()));
  }
  w.stats = (*reader)->stats();
  return w;
}

bool Has(const Status& status, const std::string& text) {
  return status.message().find(text) != std::string::npos;
}

std::string TwoMessages() { return Message(3, 1000, "cloud-a") + Message(4, 1001, "odom-a"); }

// ---- Tests -------------------------------------------------------------------------------------------------------

TEST_CASE("mcap: channels and messages come back in file order from uncompressed, lz4 and zstd chunks") {
  const std::string file =
      File(Chunk(Definitions() + TwoMessages(), "") + Chunk(Message(3, 2000, "cloud-b"), "lz4") +
           Chunk(Message(4, 2001, "odom-b") + Message(3, 3000, "cloud-c"), "zstd") + Message(4, 3001, "odom-c"));
  const Walked w = Walk(file);
  REQUIRE(w.status.ok());
  CHECK(w.ended);
  REQUIRE(w.channels.size() == 2);
  CHECK(w.channels[0].id == 3);
  CHECK(w.channels[0].topic == "/points");
  CHECK(w.channels[0].type == "sensor_msgs/msg/PointCloud2");
  CHECK(w.channels[0].encoding == RosEncoding::kCdr);
  CHECK(w.channels[1].type == "nav_msgs/msg/Odometry");
  const std::vector<std::string> expected = {"3@1000:cloud-a", "4@1001:odom-a",  "3@2000:cloud-b",
                                             "4@2001:odom-b",  "3@3000:cloud-c", "4@3001:odom-c"};
  CHECK(w.messages == expected);
  CHECK(w.stats.chunks == 3);
  CHECK(w.stats.chunks_lz4 == 1);
  CHECK(w.stats.chunks_zstd == 1);
  CHECK(w.stats.messages == 6);
}

TEST_CASE("mcap: message encodings ros1 and cdr are read, others and schemaless channels are typed unsupported") {
  const std::string data = Schema(1, "sensor_msgs/PointCloud2", "ros1msg") + Channel(1, 1, "/ros1", "ros1") +
                           Schema(2, "foxglove.PointCloud", "protobuf") + Channel(2, 2, "/pb", "protobuf") +
                           Channel(3, 0, "/json", "json") + Message(1, 5, "x") + Message(3, 6, "{}");
  const Walked w = Walk(File(data));
  REQUIRE(w.status.ok());
  REQUIRE(w.channels.size() == 3);
  CHECK(w.channels[0].type == "sensor_msgs/PointCloud2");
  CHECK(w.channels[0].encoding == RosEncoding::kRos1);
  CHECK(RosMessageKindOf(w.channels[0].type) == RosMessageKind::kPointCloud2);
  CHECK(w.channels[1].type == "foxglove.PointCloud (protobuf)");
  CHECK(w.channels[2].type == "(no schema) (json)");
  for (int i = 1; i < 3; ++i) CHECK(RosMessageKindOf(w.channels[i].type) == RosMessageKind::kUnsupported);
  const std::string json_cloud = Schema(1, "sensor_msgs/msg/PointCloud2", "jsonschema") +
                                 Channel(1, 1, "/j", "json");
  const Walked j = Walk(File(json_cloud));
  REQUIRE(j.channels.size() == 1);
  CHECK(j.channels[0].type == "sensor_msgs/msg/PointCloud2 (json)");
  CHECK(RosMessageKindOf(j.channels[0].type) == RosMessageKind::kUnsupported);
}

TEST_CASE("mcap: index, attachment, metadata and unknown records are skipped and the summary is not read") {
  const std::string skipped = Rec(0x07, U16(3) + U32(0)) + Rec(0x09, std::string(40, 'a')) +
                              Rec(0x0C, Str("name") + U32(0)) + Rec(0x80, "private record") + Rec(0x0B, "stats");
  const std::string in_chunk_unknown = Rec(0x99, "later minor version");
  const std::string summary = Definitions() + Rec(0x08, std::string(60, 's')) + Rec(0x0E, std::string(17, 'o'));
  const Walked w = Walk(File(Chunk(Definitions() + in_chunk_unknown + TwoMessages()) + skipped, summary));
  REQUIRE(w.status.ok());
  CHECK(w.ended);
  CHECK(w.messages.size() == 2);
  CHECK(w.stats.records_skipped == 6);
}

TEST_CASE("mcap: a channel repeated with the same fields is reported once, with other fields it is DataLoss") {
  const Walked same = Walk(File(Chunk(Definitions() + TwoMessages()) + Chunk(Definitions() + TwoMessages())));
  REQUIRE(same.status.ok());
  CHECK(same.channels.size() == 2);
  CHECK(same.messages.size() == 4);
  const Walked other = Walk(File(Definitions() + Channel(3, 1, "/other")));
  CHECK(other.status.code() == StatusCode::kDataLoss);
  CHECK(Has(other.status, "channel 3 declared again"));
  const Walked schema = Walk(File(Definitions() + Schema(1, "other/msg/Type")));
  CHECK(Has(schema.status, "schema 1 declared again"));
}

TEST_CASE("mcap: a message on an undeclared channel or a channel on an undeclared schema is DataLoss") {
  const Walked m = Walk(File(Chunk(Definitions() + Message(9, 1, "x"))));
  CHECK(m.status.code() == StatusCode::kDataLoss);
  CHECK(Has(m.status, "t.mcap: chunk at offset "));
  CHECK(Has(m.status, "Message record 4 at chunk byte"));
  CHECK(Has(m.status, "channel 9 was never declared"));
  const Walked outside = Walk(File(Message(9, 1, "x")));
  CHECK(Has(outside.status, "t.mcap: Message record at offset " + First() + ": channel 9 was never declared"));
  const Walked c = Walk(File(Channel(1, 5, "/x")));
  CHECK(Has(c.status, "uses schema 5, which was never declared"));
  const Walked zero = Walk(File(Schema(0, "a/msg/B")));
  CHECK(Has(zero.status, "schema id 0 is reserved"));
}

TEST_CASE("mcap: every cut of a small file is a clean error naming an offset, only the whole file reads to the end") {
  const std::string file =
      File(Chunk(Definitions() + TwoMessages(), "zstd") + Message(3, 9, "outside") + Chunk(TwoMessages(), "lz4"),
           Definitions());
  for (std::size_t cut = 0; cut <= file.size(); ++cut) {
    CAPTURE(cut);
    const Walked w = Walk(file.substr(0, cut));
    if (cut == file.size()) {
      CHECK(w.status.ok());
      CHECK(w.ended);
      CHECK(w.messages.size() == 5);
    } else {
      CHECK_FALSE(w.ended);
      REQUIRE_FALSE(w.status.ok());
      CHECK((w.status.code() == StatusCode::kDataLoss || w.status.code() == StatusCode::kInvalidArgument));
      CHECK(Has(w.status, "t.mcap"));
      if (cut >= 5) CHECK(Has(w.status, "offset"));
    }
  }
}

TEST_CASE("mcap: a file with any one byte changed is read or refused cleanly, never a crash") {
  const std::string file = File(Chunk(Definitions() + TwoMessages(), "lz4") + Chunk(TwoMessages(), "zstd") +
                                Chunk(Message(4, 5, "plain")));
  int refused = 0;
  for (std::size_t i = 0; i < file.size(); ++i) {
    for (const unsigned char value : {0x00, 0xFF, 0x7F}) {
      std::string bad = file;
      if (static_cast<unsigned char>(bad[i]) == value) continue;
      bad[i] = static_cast<char>(value);
      const Walked w = Walk(bad);
      if (!w.status.ok()) {
        ++refused;
        CHECK(Has(w.status, "t.mcap"));
      }
    }
  }
  CHECK(refused > 0);
}

TEST_CASE("mcap: a corrupt chunk is DataLoss naming the chunk: crc mismatch, bad lz4, bad zstd") {
  const std::string records = Definitions() + TwoMessages();
  const Walked crc = Walk(File(ChunkRaw("", Crc(records) ^ 1u, records, records.size())));
  CHECK(crc.status.code() == StatusCode::kDataLoss);
  CHECK(Has(crc.status, "t.mcap: chunk at offset " + First() + " (uncompressed): uncompressed_crc mismatch"));
  const Walked no_crc = Walk(File(ChunkRaw("", 0, records, records.size())));
  CHECK(no_crc.status.ok());  // crc 0: not computed by the writer, not checked
  for (const char* compression : {"lz4", "zstd"}) {
    CAPTURE(compression);
    std::string packed = Compress(records, compression);
    for (std::size_t i = packed.size() / 3; i < packed.size() / 3 + 8; ++i) packed[i] = static_cast<char>(~packed[i]);
    const Walked w = Walk(File(ChunkRaw(compression, 0, packed, records.size())));
    CHECK(w.status.code() == StatusCode::kDataLoss);
    CHECK(Has(w.status, "t.mcap: chunk at offset " + First() + " (" + compression + "): "));
    const std::string good = Compress(records, compression);
    const Walked cut = Walk(File(ChunkRaw(compression, 0, good.substr(0, good.size() - 3), records.size())));
    CHECK(Has(cut.status, std::string("(") + compression + "): "));
    const Walked size = Walk(File(ChunkRaw(compression, 0, good, records.size() - 1)));
    CHECK(Has(size.status, std::string("(") + compression + "): "));
  }
  const Walked unknown = Walk(File(ChunkRaw("bz2", 0, records, records.size())));
  CHECK(Has(unknown.status, "unknown compression \"bz2\""));
}

TEST_CASE("mcap: lengths that lie are refused by the file size or the limits, never allocated") {
  McapLimits limits;
  limits.max_chunk_bytes = 1u << 20;
  limits.max_record_bytes = 1u << 16;
  // A record length of 2^63: past the end of the file.
  const std::string huge = kMagic + Header() + std::string(1, '\x05') + U64(1ull << 63) + std::string(30, 'x');
  const Walked w = Walk(huge + Footer() + kMagic, limits);
  CHECK(Has(w.status, "t.mcap: truncated at offset " + First() +
                          ": the Message record's content of 9223372036854775808 bytes"));
  // uncompressed_size above the limit.
  const std::string records = Definitions() + TwoMessages();
  const Walked big = Walk(File(ChunkRaw("zstd", 0, Compress(records, "zstd"), 1ull << 40)), limits);
  CHECK(Has(big.status, "uncompressed chunk (uncompressed_size) of 1099511627776 bytes is above the limit"));
  // A message outside chunks above max_record_bytes.
  const Walked record = Walk(File(Definitions() + Message(3, 1, std::string(70000, 'p'))), limits);
  CHECK(Has(record.status, "McapLimits::max_record_bytes"));
  // The chunk's records length runs past the chunk record.
  std::string chunk = Chunk(records);
  const std::size_t records_len_at = 1 + 8 + 28 + 4;  // opcode, length, fixed fields, empty compression name
  chunk.replace(records_len_at, 8, U64(1ull << 62));
  CHECK(Has(Walk(File(chunk), limits).status, "end past the record's"));
  // A record inside the chunk whose length runs past the chunk.
  const std::string lying = Definitions() + std::string(1, '\x05') + U64(1ull << 40) + "abc";
  const Walked inner = Walk(File(Chunk(lying)), limits);
  CHECK(Has(inner.status, "ends past the end of the chunk"));
  // A field length inside a record that runs past the record.
  const Walked field = Walk(File(Rec(0x03, U16(1) + U32(0xFFFFFFFFu) + "x")), limits);
  CHECK(Has(field.status, "field name of 4294967295 bytes at byte 2 ends past the end of the record"));
}

TEST_CASE("mcap: the end of the file must be a Footer and the magic, a Footer in place of Data End is accepted") {
  const std::string body = kMagic + Header() + Definitions() + TwoMessages();
  const Walked footer_only = Walk(body + Footer() + kMagic);
  CHECK(footer_only.status.ok());
  CHECK(footer_only.ended);
  const Walked no_footer = Walk(body + DataEnd() + std::string(37, '\0'));
  CHECK(Has(no_footer.status, "are not a Footer record"));
  const Walked trailing = Walk(body + Footer() + kMagic + "x");
  CHECK(Has(trailing.status, "1 bytes after the Footer record and the MCAP magic"));
  const Walked no_end = Walk(body);
  CHECK(Has(no_end.status, "the file ends before the Data End record"));
  const Walked zero_op = Walk(body + std::string(9, '\0') + DataEnd() + Footer() + kMagic);
  CHECK(Has(zero_op.status, "opcode 0x00 (reserved)"));
}

TEST_CASE("mcap: a file that is not MCAP or of another major version is InvalidArgument") {
  const Walked text = Walk("hello, world\n");
  CHECK(text.status.code() == StatusCode::kInvalidArgument);
  CHECK(Has(text.status, "t.mcap: not an MCAP file"));
  std::string v1 = File(Definitions());
  v1[5] = '1';
  CHECK(Has(Walk(v1).status, "major version byte 49 is not supported"));
  const Walked no_header = Walk(kMagic + Definitions() + DataEnd() + Footer() + kMagic);
  CHECK(Has(no_header.status, "the first record is not the Header record"));
}

TEST_CASE("mcap: OpenRosMessageSource reads an MCAP file by its magic") {
  const std::string path = test::ScratchFile("dispatch.mcap");
  const std::string file = File(Chunk(Definitions() + TwoMessages(), "zstd"));
  std::FILE* f = std::fopen(path.c_str(), "wb");
  REQUIRE(f != nullptr);
  REQUIRE(std::fwrite(file.data(), 1, file.size(), f) == file.size());
  std::fclose(f);
  auto source = OpenRosMessageSource(path);
  REQUIRE(source.ok());
  CHECK(std::string((*source)->format()) == "MCAP");
  int messages = 0;
  for (;;) {
    auto item = (*source)->Next();
    REQUIRE(item.ok());
    if (*item == RosMessageSource::Item::kEnd) break;
    if (*item == RosMessageSource::Item::kMessage) ++messages;
  }
  CHECK(messages == 2);
  CHECK((*source)->position() == file.size());
}

}  // namespace commerge::platform::mcap_reader_test
