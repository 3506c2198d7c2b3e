// SPDX-License-Identifier: BSD-3-Clause
// Ros1BagReader and the byte sources, on bags built here record by record (a small writer of our own, with the
// chunks compressed by libbz2 and liblz4 directly), whole and damaged: cut at every byte, bytes flipped, lengths
// and size fields that lie, fields missing.
#include <bzlib.h>
#include <doctest/doctest.h>
#include <lz4frame.h>

#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "platform/ros/byte_source.hpp"
#include "platform/ros/ros1_bag.hpp"
#include "tests/support/test_data.hpp"

// A named namespace: in a unity build the other test files of this binary share the translation unit.
namespace commerge::platform::ros1_bag_test {

// ---- A minimal bag writer ----------------------------------------------------------------------------------------

constexpr std::uint64_t kBodyStart = 13 + 4096;  // the magic line, then the bag header record padded to 4096 bytes

std::string U32(std::uint32_t v) {
  std::string s(4, '\0');
  for (int i = 0; i < 4; ++i) s[i] = static_cast<char>((v >> (8 * i)) & 0xFFu);
  return s;
}

std::string U64(std::uint64_t v) {
  return U32(static_cast<std::uint32_t>(v)) + U32(static_cast<std::uint32_t>(v >> 32));
}

std::string Field(const std::string& name, const std::string& value) {
  return U32(static_cast<std::uint32_t>(name.size() + 1 + value.size())) + name + "=" + value;
}

std::string OpField(std::uint8_t op) { return Field("op", std::string(1, static_cast<char>(op))); }

std::string Record(const std::string& header, const std::string& data) {
  return U32(static_cast<std::uint32_t>(header.size())) + header + U32(static_cast<std::uint32_t>(data.size())) + data;
}

std::string TimeBytes(std::uint32_t sec, std::uint32_t nsec) { return U32(sec) + U32(nsec); }

struct TestConnection {
  std::uint32_t id = 0;
  std::string topic;
  std::string type;
  std::string md5sum;
  std::string definition;
  std::string callerid;
  bool latching = false;
};

std::string ConnectionRecord(const TestConnection& c) {
  const std::string header = OpField(0x07) + Field("conn", U32(c.id)) + Field("topic", c.topic);
  std::string data = Field("topic", c.topic) + Field("type", c.type) + Field("md5sum", c.md5sum) +
                     Field("message_definition", c.definition);
  if (!c.callerid.empty()) data += Field("callerid", c.callerid);
  data += Field("latching", c.latching ? "1" : "0");
  return Record(header, data);
}

std::string MessageRecord(std::uint32_t conn, std::uint32_t sec, std::uint32_t nsec, const std::string& payload) {
  return Record(OpField(0x02) + Field("conn", U32(conn)) + Field("time", TimeBytes(sec, nsec)), payload);
}

std::string Compress(const std::string& raw, const std::string& compression) {
  if (compression == "bz2") {
    std::string out(raw.size() + raw.size() / 100 + 600, '\0');
    auto out_len = static_cast<unsigned int>(out.size());
    std::string in = raw;
    // 100 kB blocks: the decompressor then allocates 400 kB of state, not 3.6 MB (the damaged-bag sweeps are long).
    REQUIRE(BZ2_bzBuffToBuffCompress(&out[0], &out_len, &in[0], static_cast<unsigned int>(in.size()), 1, 0, 30) ==
            BZ_OK);
    out.resize(out_len);
    return out;
  }
  if (compression == "lz4") {
    std::string out(LZ4F_compressFrameBound(raw.size(), nullptr), '\0');
    const std::size_t n = LZ4F_compressFrame(&out[0], out.size(), raw.data(), raw.size(), nullptr);
    REQUIRE(!LZ4F_isError(n));
    out.resize(n);
    return out;
  }
  return raw;
}

std::string ChunkRecord(const std::string& compression, const std::string& data, std::uint32_t size) {
  return Record(OpField(0x05) + Field("compression", compression) + Field("size", U32(size)), data);
}

std::string BagHeaderRecord(std::uint64_t index_pos, std::uint32_t conn_count, std::uint32_t chunk_count) {
  const std::string header = OpField(0x03) + Field("index_pos", U64(index_pos)) +
                             Field("conn_count", U32(conn_count)) + Field("chunk_count", U32(chunk_count));
  return Record(header, std::string(4096 - 8 - header.size(), ' '));
}

/// What the reader should report, in order.
struct Event {
  bool connection = false;
  std::uint32_t conn = 0;
  std::int64_t time_ns = 0;
  std::string payload;
  std::uint64_t chunk_offset = 0;
  bool operator==(const Event& o) const {
    return connection == o.connection && conn == o.conn && time_ns == o.time_ns && payload == o.payload &&
           chunk_offset == o.chunk_offset;
  }
};

/// Writes records the way rosbag does: chunks of connection and message records, each followed by its index data
/// records; then the index section (every connection, one chunk info per chunk); the bag header first.
class BagBuilder {
 public:
  explicit BagBuilder(std::string compression = "none") : compression_(std::move(compression)) {}

  /// A connection record in the current chunk (again if `id` was already declared).
  void Connection(const TestConnection& c) {
    chunk_ += ConnectionRecord(c);
    for (const TestConnection& known : connections_) {
      if (known.id == c.id) return;
    }
    connections_.push_back(c);
    expected_.push_back(Event{true, c.id, 0, {}, 0});
  }
  void Message(std::uint32_t conn, std::uint32_t sec, std::uint32_t nsec, const std::string& payload) {
    index_[conn].push_back(TimeBytes(sec, nsec) + U32(static_cast<std::uint32_t>(chunk_.size())));
    chunk_ += MessageRecord(conn, sec, nsec, payload);
    expected_.push_back(Event{false, conn, std::int64_t{sec} * 1000000000 + nsec, payload, ChunkOffset()});
  }
  void RawInChunk(const std::string& record) { chunk_ += record; }
  void RawOutside(const std::string& record) {
    EndChunk();
    body_ += record;
  }
  void EndChunk() {
    if (chunk_.empty()) return;
    chunk_offsets_.push_back(ChunkOffset());
    std::string data = Compress(chunk_, compression_);
    auto size = static_cast<std::uint32_t>(chunk_.size());
    if (mutate_chunk) mutate_chunk(&data, &size);
    body_ += ChunkRecord(compression_, data, size);
    std::string info_data;
    for (const auto& [conn, entries] : index_) {
      const std::string header = OpField(0x04) + Field("ver", U32(1)) + Field("conn", U32(conn)) +
                                 Field("count", U32(static_cast<std::uint32_t>(entries.size())));
      std::string index_data;
      for (const std::string& e : entries) index_data += e;
      body_ += Record(header, index_data);
      info_data += U32(conn) + U32(static_cast<std::uint32_t>(entries.size()));
    }
    const std::string info_header =
        OpField(0x06) + Field("ver", U32(1)) + Field("chunk_pos", U64(chunk_offsets_.back())) +
        Field("start_time", TimeBytes(0, 0)) + Field("end_time", TimeBytes(0, 0)) +
        Field("count", U32(static_cast<std::uint32_t>(index_.size())));
    chunk_infos_.push_back(Record(info_header, info_data));
    chunk_.clear();
    index_.clear();
  }
  /// The whole bag; `indexed` = false writes index_pos 0 and no index section (a bag its writer did not close).
  std::string Finish(bool indexed = true) {
    EndChunk();
    index_pos_ = kBodyStart + body_.size();
    std::string index;
    index_record_offsets_.clear();
    for (const TestConnection& c : connections_) {
      index_record_offsets_.push_back(index_pos_ + index.size());
      index += ConnectionRecord(c);
    }
    for (const std::string& info : chunk_infos_) {
      index_record_offsets_.push_back(index_pos_ + index.size());
      index += info;
    }
    const auto conns = static_cast<std::uint32_t>(indexed ? connections_.size() : 0);
    const auto chunks = static_cast<std::uint32_t>(indexed ? chunk_infos_.size() : 0);
    return "#ROSBAG V2.0\n" + BagHeaderRecord(indexed ? index_pos_ : 0, conns, chunks) + body_ +
           (indexed ? index : std::string());
  }

  const std::vector<Event>& expected() const { return expected_; }
  const std::vector<std::uint64_t>& chunk_offsets() const { return chunk_offsets_; }
  std::uint64_t index_pos() const { return index_pos_; }
  /// Offsets of the index section's records (connections, then chunk infos), after Finish().
  const std::vector<std::uint64_t>& index_record_offsets() const { return index_record_offsets_; }

  /// Applied to each chunk's compressed data and size field before it is written.
  std::function<void(std::string* data, std::uint32_t* size)> mutate_chunk;

 private:
  std::uint64_t ChunkOffset() const { return kBodyStart + body_.size(); }

  std::string compression_;
  std::string body_;
  std::string chunk_;
  std::map<std::uint32_t, std::vector<std::string>> index_;
  std::vector<std::string> chunk_infos_;
  std::vector<TestConnection> connections_;
  std::vector<Event> expected_;
  std::vector<std::uint64_t> chunk_offsets_;
  std::vector<std::uint64_t> index_record_offsets_;
  std::uint64_t index_pos_ = 0;
};

const TestConnection kPoints{0, "/points", "sensor_msgs/PointCloud2", "1158d486dd51d683ce2f1be655c3c181",
                             "Header header\nuint32 height\n", "/lidar_driver", false};
const TestConnection kOdom{7, "/odom", "nav_msgs/Odometry", "cd5e73d190d741a2f92e81eda573aca7",
                           "Header header\nstring child_frame_id\n", "", true};

/// Two chunks, two connections (one declared again in the second chunk), payloads with NUL, '=' and high bytes.
BagBuilder SmallBag(const std::string& compression) {
  BagBuilder b(compression);
  b.Connection(kPoints);
  b.Message(0, 1700000000, 5, std::string("a\0=b\xff", 5));
  b.Connection(kOdom);
  b.Message(7, 1700000000, 999999999, std::string(300, 'o'));
  b.Message(0, 1700000001, 0, "");
  b.EndChunk();
  b.Connection(kPoints);
  b.Message(0, 4294967295u, 999999999, std::string(1000, '\x5a'));
  b.Message(7, 0, 0, "=");
  return b;
}

// ---- Reading -----------------------------------------------------------------------------------------------------

Span<const std::uint8_t> AsBytes(const std::string& s) {
  return Span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(s.data()), s.size());
}

struct Outcome {
  std::vector<Event> events;
  std::vector<Ros1Connection> connections;  // as reported by connection()
  Status error;                             // OK when the walk reached kEnd
  Ros1BagStats stats;
  bool opened = false;
};

/// Opens and walks a bag to kEnd or its first error; checks that the error repeats and that kEnd repeats.
Outcome ReadBag(const std::string& bytes, const std::string& name = "test.bag", const Ros1BagLimits& limits = {}) {
  Outcome out;
  MemoryByteSource source(AsBytes(bytes), name);
  auto reader = Ros1BagReader::Open(&source, limits);
  if (!reader.ok()) {
    out.error = reader.status();
    return out;
  }
  out.opened = true;
  for (int steps = 0; steps < 100000; ++steps) {
    auto item = reader->Next();
    if (!item.ok()) {
      out.error = item.status();
      auto again = reader->Next();
      REQUIRE(!again.ok());
      CHECK(again.status().message() == out.error.message());
      break;
    }
    if (*item == Ros1BagReader::Item::kEnd) {
      auto again = reader->Next();
      REQUIRE(again.ok());
      CHECK(*again == Ros1BagReader::Item::kEnd);
      CHECK(reader->position() == reader->size());
      break;
    }
    if (*item == Ros1BagReader::Item::kConnection) {
      out.connections.push_back(reader->connection());
      out.events.push_back(Event{true, reader->connection().id, 0, {}, 0});
    } else {
      const Ros1Message& m = reader->message();
      CHECK(m.record_index == reader->stats().messages - 1);
      out.events.push_back(Event{false, m.connection_id, m.time_ns,
                                 std::string(reinterpret_cast<const char*>(m.data.data()), m.data.size()),
                                 m.record_offset});
    }
  }
  out.stats = reader->stats();
  return out;
}

bool Contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// Limits for the sweeps over damaged bags: a size field that a flipped byte makes large is refused, not allocated.
Ros1BagLimits SweepLimits() {
  Ros1BagLimits limits;
  limits.max_chunk_bytes = 1u << 16;
  limits.max_header_bytes = 1u << 12;
  return limits;
}

/// The walk failed with DataLoss and a message holding every part.
void CheckDataLoss(const Outcome& out, const std::vector<std::string>& parts) {
  CAPTURE(out.error.message());
  REQUIRE(!out.error.ok());
  CHECK(out.error.code() == StatusCode::kDataLoss);
  for (const std::string& part : parts) CHECK(Contains(out.error.message(), part));
}

void CheckSameConnection(const Ros1Connection& got, const TestConnection& want) {
  CHECK(got.id == want.id);
  CHECK(got.topic == want.topic);
  CHECK(got.type == want.type);
  CHECK(got.md5sum == want.md5sum);
  CHECK(got.message_definition == want.definition);
  CHECK(got.callerid == want.callerid);
  CHECK(got.latching == want.latching);
}

// ---- Whole bags --------------------------------------------------------------------------------------------------

TEST_CASE("ros1 bag: connections and messages come back in file order from none, bz2 and lz4 chunks") {
  for (const char* compression : {"none", "bz2", "lz4"}) {
    CAPTURE(compression);
    BagBuilder b = SmallBag(compression);
    const std::string bag = b.Finish();
    const Outcome out = ReadBag(bag);
    CAPTURE(out.error.message());
    REQUIRE(out.error.ok());
    CHECK(out.events == b.expected());
    REQUIRE(out.connections.size() == 2);
    CheckSameConnection(out.connections[0], kPoints);
    CheckSameConnection(out.connections[1], kOdom);
    CHECK(out.events[0].connection);
    CHECK(out.events[1].chunk_offset == b.chunk_offsets()[0]);
    CHECK(out.events.back().chunk_offset == b.chunk_offsets()[1]);
    CHECK(out.stats.chunks == 2);
    CHECK(out.stats.chunks_bz2 == (std::string(compression) == "bz2" ? 2 : 0));
    CHECK(out.stats.chunks_lz4 == (std::string(compression) == "lz4" ? 2 : 0));
    CHECK(out.stats.messages == 5);
    CHECK(out.stats.connection_records == 5);      // 2 + 1 again in the chunks, 2 in the index section
    CHECK(out.stats.index_records_skipped == 6);   // 2 + 2 index data, 2 chunk info
    CHECK(out.stats.unknown_records_skipped == 0);
  }
}

TEST_CASE("ros1 bag: a bag file is read through FileByteSource, and lookups find its connections") {
  BagBuilder b = SmallBag("lz4");
  const std::string bag = b.Finish();
  const std::string path = test::ScratchFile("small.bag");
  std::FILE* f = std::fopen(path.c_str(), "wb");
  REQUIRE(f != nullptr);
  REQUIRE(std::fwrite(bag.data(), 1, bag.size(), f) == bag.size());
  REQUIRE(std::fclose(f) == 0);

  auto source = FileByteSource::Open(path);
  REQUIRE(source.ok());
  CHECK((*source)->size() == bag.size());
  CHECK((*source)->name() == path);
  auto reader = Ros1BagReader::Open(source->get());
  REQUIRE(reader.ok());
  std::vector<Event> events;
  for (;;) {
    auto item = reader->Next();
    REQUIRE(item.ok());
    if (*item == Ros1BagReader::Item::kEnd) break;
    if (*item == Ros1BagReader::Item::kMessage) {
      const Ros1Message& m = reader->message();
      events.push_back(Event{false, m.connection_id, m.time_ns,
                             std::string(reinterpret_cast<const char*>(m.data.data()), m.data.size()),
                             m.record_offset});
    } else {
      events.push_back(Event{true, reader->connection().id, 0, {}, 0});
    }
  }
  CHECK(events == b.expected());
  CHECK(reader->position() == bag.size());
  CHECK(reader->size() == bag.size());
  REQUIRE(reader->FindConnection(7) != nullptr);
  CHECK(reader->FindConnection(7)->topic == "/odom");
  CHECK(reader->FindConnection(1) == nullptr);
  CHECK(reader->connections().size() == 2);
}

TEST_CASE("ros1 bag: an empty bag and an unindexed bag read to the end") {
  const Outcome empty = ReadBag(BagBuilder("lz4").Finish());
  CHECK(empty.error.ok());
  CHECK(empty.events.empty());

  BagBuilder b = SmallBag("bz2");
  const Outcome unindexed = ReadBag(b.Finish(/*indexed=*/false));
  CAPTURE(unindexed.error.message());
  CHECK(unindexed.error.ok());
  CHECK(unindexed.events == b.expected());
}

TEST_CASE("ros1 bag: a connection repeated in the chunks and the index section is reported once") {
  BagBuilder b("none");
  for (int chunk = 0; chunk < 3; ++chunk) {
    b.Connection(kOdom);
    b.Message(7, static_cast<std::uint32_t>(chunk), 0, "x");
    b.EndChunk();
  }
  const Outcome out = ReadBag(b.Finish());
  REQUIRE(out.error.ok());
  CHECK(out.connections.size() == 1);
  CHECK(out.events.size() == 4);
  CHECK(out.stats.connection_records == 4);
}

TEST_CASE("ros1 bag: a connection declared again with another topic or type is DataLoss") {
  for (const bool other_topic : {true, false}) {
    TestConnection changed = kOdom;
    (other_topic ? changed.topic : changed.type) = "/elsewhere";
    BagBuilder b("lz4");
    b.Connection(kOdom);
    b.Message(7, 1, 2, "x");
    b.EndChunk();
    b.RawInChunk(ConnectionRecord(changed));
    const Outcome out = ReadBag(b.Finish(), "conflict.bag");
    CheckDataLoss(out, {"conflict.bag", "chunk at offset", "connection 7 declared again", "/elsewhere"});
    CHECK(out.events.size() == 2);
  }
}

// ---- Truncated and damaged files ---------------------------------------------------------------------------------

TEST_CASE("ros1 bag: every cut of a small bag is a clean error, only the whole bag reads to the end") {
  for (const char* compression : {"none", "bz2", "lz4"}) {
    CAPTURE(compression);
    const std::string bag = SmallBag(compression).Finish();
    for (std::size_t cut = 0; cut <= bag.size(); ++cut) {
      CAPTURE(cut);
      const Outcome out = ReadBag(bag.substr(0, cut), "cut.bag", SweepLimits());
      if (cut == bag.size()) {
        CHECK(out.error.ok());
        continue;
      }
      CAPTURE(out.error.message());
      REQUIRE(!out.error.ok());
      REQUIRE(out.error.code() == StatusCode::kDataLoss);
      REQUIRE(Contains(out.error.message(), "cut.bag"));
      REQUIRE(Contains(out.error.message(), "offset"));
    }
  }
}

TEST_CASE("ros1 bag: a file cut between two records of the index section is an error") {
  BagBuilder b = SmallBag("none");
  const std::string bag = b.Finish();
  REQUIRE(b.index_record_offsets().size() == 4);
  for (const std::uint64_t cut : b.index_record_offsets()) {
    const Outcome out = ReadBag(bag.substr(0, cut), "cut.bag");
    CHECK(out.events == b.expected());  // everything before the index section was read
    CheckDataLoss(out, {"cut.bag", "truncated or corrupt at offset " + std::to_string(cut), "index section"});
  }
  // Cut at the index position itself: the chunks are all there, the index section is missing.
  CheckDataLoss(ReadBag(bag.substr(0, b.index_pos()), "cut.bag"), {"0 connection and 0 chunk info records"});
}

TEST_CASE("ros1 bag: a bag with any one byte changed is read or refused cleanly, never a crash") {
  for (const char* compression : {"none", "bz2", "lz4"}) {
    CAPTURE(compression);
    const std::string bag = SmallBag(compression).Finish();
    for (std::size_t at = 0; at < bag.size(); ++at) {
      if (at >= 13 + 100 && at < kBodyStart) continue;  // the bag header's padding
      for (const unsigned char flip : {0x01, 0x80, 0xFF}) {
        std::string damaged = bag;
        damaged[at] = static_cast<char>(damaged[at] ^ flip);
        const Outcome out = ReadBag(damaged, "flip.bag", SweepLimits());
        if (out.error.ok()) continue;
        CAPTURE(at);
        CAPTURE(out.error.message());
        REQUIRE(Contains(out.error.message(), "flip.bag"));
        REQUIRE(Contains(out.error.message(), "offset"));
      }
    }
  }
}

TEST_CASE("ros1 bag: a corrupt lz4 or bz2 payload is DataLoss naming the chunk") {
  for (const char* compression : {"bz2", "lz4"}) {
    for (const bool at_start : {true, false}) {
      CAPTURE(compression);
      CAPTURE(at_start);
      BagBuilder b = SmallBag(compression);
      b.mutate_chunk = [at_start](std::string* data, std::uint32_t*) {
        if (at_start) {
          (*data)[0] = 'X';  // the stream's magic number
        } else {
          data->resize(data->size() - 5);  // the end of the stream is missing
        }
      };
      const std::string bag = b.Finish();  // the second chunk is damaged
      const Outcome out = ReadBag(bag, "corrupt.bag");
      CheckDataLoss(out, {"corrupt.bag: chunk at offset " + std::to_string(b.chunk_offsets()[1]) + " (" +
                              compression + "): " + compression + ": "});
      CHECK(out.events.size() == 5);
    }
  }
  // A flipped bit inside the bzip2 block fails its CRC.
  BagBuilder b = SmallBag("bz2");
  b.mutate_chunk = [](std::string* data, std::uint32_t*) { (*data)[data->size() / 2] ^= 0x10; };
  CheckDataLoss(ReadBag(b.Finish(), "crc.bag"), {"crc.bag: chunk at offset", "bz2"});
}

TEST_CASE("ros1 bag: a chunk size field above max_chunk_bytes is refused before anything is allocated") {
  for (const char* compression : {"none", "bz2", "lz4"}) {
    CAPTURE(compression);
    BagBuilder b = SmallBag(compression);
    b.mutate_chunk = [](std::string*, std::uint32_t* size) { *size = 0xFFFFFFF0u; };
    CheckDataLoss(ReadBag(b.Finish()), {"chunk at offset", "4294967280", "max_chunk_bytes"});

    // A legal chunk above a small limit.
    Ros1BagLimits limits;
    limits.max_chunk_bytes = 200;
    CheckDataLoss(ReadBag(SmallBag(compression).Finish(), "test.bag", limits),
                  {"chunk at offset", "max_chunk_bytes"});
  }
}

TEST_CASE("ros1 bag: a chunk size field that differs from the decompressed size is DataLoss") {
  for (const char* compression : {"none", "bz2", "lz4"}) {
    for (const int delta : {-1, 1, 1000}) {
      CAPTURE(compression);
      CAPTURE(delta);
      BagBuilder b = SmallBag(compression);
      b.mutate_chunk = [delta](std::string*, std::uint32_t* size) {
        *size = static_cast<std::uint32_t>(*size + delta);
      };
      CheckDataLoss(ReadBag(b.Finish(), "size.bag"), {"size.bag: chunk at offset", "says"});
    }
  }
}

TEST_CASE("ros1 bag: a header length of 0x7fffffff is refused by the limit, not allocated") {
  const std::string huge = U32(0x7fffffffu) + std::string(12, '\0');
  // Where the bag header should be.
  CheckDataLoss(ReadBag("#ROSBAG V2.0\n" + huge, "huge.bag"), {"huge.bag", "offset 13", "max_header_bytes"});
  // Between chunks.
  BagBuilder between = SmallBag("none");
  between.RawOutside(huge);
  CheckDataLoss(ReadBag(between.Finish(), "huge.bag"), {"huge.bag", "record at offset", "max_header_bytes"});
  // Inside a chunk.
  BagBuilder inside = SmallBag("lz4");
  inside.RawInChunk(huge);
  CheckDataLoss(ReadBag(inside.Finish(), "huge.bag"), {"huge.bag: chunk at offset", "max_header_bytes"});
  // A data length past the end of the file.
  BagBuilder data_len = SmallBag("none");
  data_len.RawOutside(U32(static_cast<std::uint32_t>(OpField(0x09).size())) + OpField(0x09) + U32(0x7fffffffu));
  CheckDataLoss(ReadBag(data_len.Finish(), "huge.bag"), {"huge.bag: truncated at offset", "past the end of the file"});
}

TEST_CASE("ros1 bag: records of an unknown op are skipped and counted, in and outside chunks") {
  BagBuilder b = SmallBag("bz2");
  b.RawInChunk(Record(OpField(0x42) + Field("anything", "goes"), "some data"));
  b.Message(0, 3, 4, "after");
  b.RawOutside(Record(OpField(0x00), std::string(100, '\0')));
  const Outcome out = ReadBag(b.Finish());
  CAPTURE(out.error.message());
  REQUIRE(out.error.ok());
  CHECK(out.events == b.expected());
  CHECK(out.stats.unknown_records_skipped == 2);
}

TEST_CASE("ros1 bag: a message on a connection never declared is DataLoss") {
  BagBuilder b("lz4");
  b.Connection(kPoints);
  b.RawInChunk(MessageRecord(3, 1, 1, "orphan"));
  CheckDataLoss(ReadBag(b.Finish(), "orphan.bag"),
                {"orphan.bag: chunk at offset", "message data record 1", "connection 3 was never declared"});
}

TEST_CASE("ros1 bag: a message record outside a chunk is read, its data capped by max_chunk_bytes") {
  BagBuilder b("none");
  b.Connection(kOdom);
  b.EndChunk();
  b.RawOutside(MessageRecord(7, 9, 8, std::string(500, 'm')));
  const std::string bag = b.Finish();
  const Outcome out = ReadBag(bag);
  REQUIRE(out.error.ok());
  REQUIRE(out.events.size() == 2);
  CHECK(out.events[1].payload == std::string(500, 'm'));
  CHECK(out.events[1].time_ns == 9000000008);

  Ros1BagLimits limits;
  limits.max_chunk_bytes = 499;
  CheckDataLoss(ReadBag(bag, "test.bag", limits), {"message data record at offset", "max_chunk_bytes"});
}

TEST_CASE("ros1 bag: more distinct connections than max_connections is DataLoss") {
  BagBuilder b("none");
  for (std::uint32_t id = 0; id < 5; ++id) {
    TestConnection c = kOdom;
    c.id = id;
    b.Connection(c);
  }
  Ros1BagLimits limits;
  limits.max_connections = 4;
  CheckDataLoss(ReadBag(b.Finish(), "test.bag", limits), {"connection record 4", "max_connections"});
}

// ---- Headers -------------------------------------------------------------------------------------------------------

TEST_CASE("ros1 bag: a file that is not a version 2.0 bag is InvalidArgument") {
  for (const std::string& start : {std::string("PK\x03\x04 not a bag at all"), std::string("#ROSBAG V1.2\n...."),
                                   std::string("#ROSBAG V2.1\n"), std::string("\x7f" "ELF")}) {
    CAPTURE(start);
    const Outcome out = ReadBag(start, "x.bag");
    CAPTURE(out.error.message());
    CHECK(out.error.code() == StatusCode::kInvalidArgument);
    CHECK(Contains(out.error.message(), "x.bag"));
    CHECK(Contains(out.error.message(), "offset 0"));
  }
  CheckDataLoss(ReadBag("", "empty.bag"), {"empty.bag", "truncated at offset 0"});
}

TEST_CASE("ros1 bag: missing or malformed header fields are DataLoss naming the field") {
  struct Case {
    std::string record;
    const char* expected;
  };
  const std::vector<Case> cases = {
      {Record(OpField(0x02) + Field("conn", U32(0)), "x"), "no 'time' field"},
      {Record(OpField(0x02) + Field("time", TimeBytes(1, 2)), "x"), "no 'conn' field"},
      {Record(OpField(0x02) + Field("conn", U32(0)) + Field("time", "1234567"), "x"), "field 'time' has 7 bytes"},
      {Record(OpField(0x02) + Field("conn", U32(0)) + Field("time", TimeBytes(1, 1000000000)), "x"), "nsec"},
      {Record(Field("conn", U32(0)), "x"), "no 'op' field"},
      {Record(OpField(0x02) + U32(4) + "conn", "x"), "has no '='"},
      {Record(OpField(0x02) + U32(40) + "conn=", "x"), "ends past the end of the header"},
      {Record(OpField(0x02) + U32(0x7fffff00u) + "xx", "x"), "field of 2147483392 bytes at byte 8"},
      {Record(OpField(0x07) + Field("conn", U32(1)) + Field("topic", "/t"), Field("md5sum", "0") +
              Field("message_definition", "")), "no 'type' field"},
      {Record(OpField(0x07) + Field("conn", U32(1)), Field("type", "a/B") + Field("md5sum", "0") +
              Field("message_definition", "")), "no 'topic' field"},
      {Record(OpField(0x05) + Field("size", U32(0)), ""), "no 'compression' field"},
      {Record(OpField(0x05) + Field("compression", "zstd") + Field("size", U32(0)), ""), "unknown compression"},
      {Record(OpField(0x06) + Field("ver", U32(1)) + Field("count", U32(3)), "12345678"), "entries of 8 bytes"},
      {Record(OpField(0x03) + Field("index_pos", U64(0)), ""), "second bag header"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.expected);
    BagBuilder b("none");
    b.Connection(kPoints);
    b.Message(0, 1, 1, "first");
    b.RawOutside(c.record);
    const Outcome out = ReadBag(b.Finish(), "fields.bag");
    CheckDataLoss(out, {"fields.bag", "offset", c.expected});
    CHECK(out.events.size() == 2);
  }
  // The bag header's own fields.
  const std::string no_index = "#ROSBAG V2.0\n" + Record(OpField(0x03) + Field("conn_count", U32(0)) +
                                                         Field("chunk_count", U32(0)), "");
  CheckDataLoss(ReadBag(no_index, "fields.bag"), {"fields.bag: bag header record at offset 13", "'index_pos'"});
  const std::string not_header = "#ROSBAG V2.0\n" + MessageRecord(0, 0, 0, "");
  CheckDataLoss(ReadBag(not_header, "fields.bag"), {"offset 13", "not the bag header"});
}

TEST_CASE("ros1 bag: a header field that repeats takes its last value") {
  BagBuilder b("lz4");
  b.Connection(kPoints);
  b.RawInChunk(Record(OpField(0x02) + Field("conn", U32(5)) + Field("time", TimeBytes(1, 2)) + Field("conn", U32(0)),
                      "dup"));
  const Outcome out = ReadBag(b.Finish());
  REQUIRE(out.error.ok());
  REQUIRE(out.events.size() == 2);
  CHECK(out.events[1].conn == 0);
  CHECK(out.events[1].payload == "dup");
}

// ---- Byte sources --------------------------------------------------------------------------------------------------

TEST_CASE("byte source: memory and file sources read ranges and refuse reads past the end") {
  const std::string bytes = "0123456789ab";
  MemoryByteSource memory(AsBytes(bytes));
  CHECK(memory.name() == "<memory>");
  CHECK(memory.size() == 12);
  std::uint8_t out[8] = {};
  REQUIRE(memory.ReadAt(10, 2, out).ok());
  CHECK(out[0] == 'a');
  CHECK(memory.ReadAt(12, 0, out).ok());
  Status past = memory.ReadAt(10, 4, out);
  CHECK(past.code() == StatusCode::kDataLoss);
  CHECK(past.message() == "<memory>: truncated: wanted 4 bytes at offset 10, the source has 12");
  CHECK(memory.ReadAt(~std::uint64_t{0}, 2, out).code() == StatusCode::kDataLoss);

  const std::string path = test::ScratchFile("bytes.bin");
  std::FILE* f = std::fopen(path.c_str(), "wb");
  REQUIRE(f != nullptr);
  REQUIRE(std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size());
  REQUIRE(std::fclose(f) == 0);
  auto file = FileByteSource::Open(path);
  REQUIRE(file.ok());
  CHECK((*file)->size() == 12);
  REQUIRE((*file)->ReadAt(3, 4, out).ok());
  CHECK(std::string(reinterpret_cast<const char*>(out), 4) == "3456");
  REQUIRE((*file)->ReadAt(0, 2, out).ok());
  CHECK(out[1] == '1');
  past = (*file)->ReadAt(9, 4, out);
  CHECK(past.code() == StatusCode::kDataLoss);
  CHECK(past.message() == path + ": truncated: wanted 4 bytes at offset 9, the source has 12");

  auto missing = FileByteSource::Open(path + ".missing");
  REQUIRE(!missing.ok());
  CHECK(missing.status().code() == StatusCode::kNotFound);
  CHECK(Contains(missing.status().message(), path + ".missing"));
}

}  // namespace commerge::platform::ros1_bag_test
