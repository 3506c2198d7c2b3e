// SPDX-License-Identifier: BSD-3-Clause
// Rosbag2Db3Reader on rosbag2 sqlite3 files built here with libsqlite3 in the table layouts of rosbag2's schema
// versions (4: Iron and later, with type_description_hash and message_definitions; 3: Humble; Foxy's, without a
// schema table), and on files that are not rosbag2 databases, or not databases at all, or corrupt. Files by an
// independent writer (better-sqlite3 under Node) are read in the end-to-end test tests/apps/ros2_import_test.sh.
#include <doctest/doctest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "platform/ros/message_source.hpp"
#include "platform/ros/rosbag2_db3.hpp"
#include "tests/support/test_data.hpp"

// A named namespace: in a unity build the other test files of this binary share the translation unit.
namespace commerge::platform::rosbag2_db3_test {

enum class Layout { kIron, kHumble, kFoxy };

// Before this process's first SQLite call (the tests write databases with SQLite before the reader opens them).
const bool kSqliteCapInstalled = InstallSqliteBlockCap();

void Exec(sqlite3* db, const std::string& sql) {
  char* error = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error);
  INFO(sql);
  INFO((error ? error : ""));
  sqlite3_free(error);
  REQUIRE(rc == SQLITE_OK);
}

std::string TopicsTable(Layout layout) {
  std::string sql = "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
                    "serialization_format TEXT NOT NULL";
  if (layout != Layout::kFoxy) sql += ", offered_qos_profiles TEXT NOT NULL";
  if (layout == Layout::kIron) sql += ", type_description_hash TEXT NOT NULL";
  return sql + ");";
}

/// The tables of a rosbag2 sqlite3 file of `layout`, no rows.
void CreateTables(sqlite3* db, Layout layout) {
  if (layout != Layout::kFoxy) {
    Exec(db, "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);");
    Exec(db, "CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, metadata TEXT NOT "
             "NULL);");
    Exec(db, std::string("INSERT INTO schema VALUES(") + (layout == Layout::kIron ? "4, 'jazzy'" : "3, 'humble'") +
                 ");");
  }
  Exec(db, TopicsTable(layout));
  if (layout == Layout::kIron) {
    Exec(db, "CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL, encoding TEXT NOT "
             "NULL, encoded_message_definition TEXT NOT NULL, type_description_hash TEXT NOT NULL);");
  }
  Exec(db, "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL, "
           "data BLOB NOT NULL);");
  Exec(db, "CREATE INDEX timestamp_idx ON messages (timestamp ASC);");
}

void AddTopic(sqlite3* db, Layout layout, int id, const std::string& name, const std::string& type,
              const std::string& format = "cdr") {
  std::string sql = "INSERT INTO topics VALUES(" + std::to_string(id) + ", '" + name + "', '" + type + "', '" +
                    format + "'";
  if (layout != Layout::kFoxy) sql += ", ''";
  if (layout == Layout::kIron) sql += ", 'RIHS01_00'";
  Exec(db, sql + ");");
}

/// Inserts a zero-filled blob and writes `data` into it piece by piece (sqlite3_blob_write): no block of SQLite's
/// as large as the message, which its allocation cap (InstallSqliteBlockCap) would refuse.
void AddMessage(sqlite3* db, int topic_id, std::int64_t timestamp, const std::string& data) {
  sqlite3_stmt* stmt = nullptr;
  REQUIRE(sqlite3_prepare_v2(db, "INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)", -1, &stmt,
                             nullptr) == SQLITE_OK);
  sqlite3_bind_int(stmt, 1, topic_id);
  sqlite3_bind_int64(stmt, 2, timestamp);
  sqlite3_bind_zeroblob(stmt, 3, static_cast<int>(data.size()));
  CHECK(sqlite3_step(stmt) == SQLITE_DONE);
  sqlite3_finalize(stmt);
  if (data.empty()) return;
  sqlite3_blob* blob = nullptr;
  REQUIRE(sqlite3_blob_open(db, "main", "messages", "data", sqlite3_last_insert_rowid(db), 1, &blob) == SQLITE_OK);
  constexpr std::size_t kPiece = std::size_t{1} << 20;
  for (std::size_t at = 0; at < data.size(); at += kPiece) {
    const std::size_t n = std::min(kPiece, data.size() - at);
    CHECK(sqlite3_blob_write(blob, data.data() + at, static_cast<int>(n), static_cast<int>(at)) == SQLITE_OK);
  }
  sqlite3_blob_close(blob);
}

sqlite3* Create(const std::string& path) {
  std::remove(path.c_str());
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) == SQLITE_OK);
  return db;
}

/// A bag of two topics whose messages were inserted out of timestamp order.
std::string SmallBag(Layout layout, const std::string& name) {
  const std::string path = test::ScratchFile(name);
  sqlite3* db = Create(path);
  CreateTables(db, layout);
  AddTopic(db, layout, 1, "/velodyne_points", "sensor_msgs/msg/PointCloud2");
  AddTopic(db, layout, 2, "/odom", "nav_msgs/msg/Odometry");
  AddMessage(db, 2, 2000, "odom-b");
  AddMessage(db, 1, 1000, "cloud-a");
  AddMessage(db, 2, 1000, "odom-a");
  AddMessage(db, 1, 2000, "cloud-b");
  sqlite3_close(db);
  return path;
}

struct Walked {
  std::vector<RosChannel> channels;
  std::vector<std::string> messages;  // "<topic id>@<timestamp>:<data>"
  Status status;
  bool ended = false;
};

Walked Walk(RosMessageSource* source) {
  Walked w;
  std::uint64_t last_position = 0;
  for (int i = 0; i < 100000; ++i) {
    auto item = source->Next();
    CHECK(source->position() >= last_position);
    CHECK(source->position() <= source->size());
    last_position = source->position();
    if (!item.ok()) {
      w.status = item.status();
      CHECK(source->Next().status().message() == item.status().message());
      break;
    }
    if (*item == RosMessageSource::Item::kEnd) {
      w.ended = true;
      CHECK(source->position() == source->size());
      break;
    }
    if (*item == RosMessageSource::Item::kChannel) {
      CHECK(w.messages.empty());  // every channel first
      w.channels.push_back(source->channel());
      continue;
    }
    const RosRecord& m = source->message();
    REQUIRE(source->FindChannel(m.channel_id) != nullptr);
    w.messages.push_back(std::to_string(m.channel_id) + "@" + std::to_string(m.log_time_ns) + ":" +
                         std::string(reinterpret_cast<const char*>(m.data.data()), m.data.size()));
  }
  return w;
}

bool Has(const Status& status, const std::string& text) {
  return status.message().find(text) != std::string::npos;
}

TEST_CASE("rosbag2 db3: the topics and then the messages in timestamp order, in each schema version") {
  const std::vector<std::string> expected = {"1@1000:cloud-a", "2@1000:odom-a", "2@2000:odom-b", "1@2000:cloud-b"};
  struct Case {
    Layout layout;
    const char* name;
    int version;
  };
  for (const Case& c : {Case{Layout::kIron, "iron.db3", 4}, Case{Layout::kHumble, "humble.db3", 3},
                        Case{Layout::kFoxy, "foxy.db3", 0}}) {
    CAPTURE(c.name);
    const std::string path = SmallBag(c.layout, c.name);
    auto reader = Rosbag2Db3Reader::Open(path);
    REQUIRE(reader.ok());
    CHECK((*reader)->schema_version() == c.version);
    CHECK((*reader)->message_rows() == 4);
    CHECK(std::string((*reader)->format()) == "rosbag2 sqlite3");
    const Walked w = Walk(reader->get());
    REQUIRE(w.status.ok());
    CHECK(w.ended);
    REQUIRE(w.channels.size() == 2);
    CHECK(w.channels[0].id == 1);
    CHECK(w.channels[0].topic == "/velodyne_points");
    CHECK(w.channels[0].type == "sensor_msgs/msg/PointCloud2");
    CHECK(w.channels[0].encoding == RosEncoding::kCdr);
    CHECK(w.channels[1].type == "nav_msgs/msg/Odometry");
    CHECK(w.messages == expected);
  }
}

TEST_CASE("rosbag2 db3: OpenRosMessageSource reads a .db3 by its magic") {
  const std::string path = SmallBag(Layout::kIron, "dispatch.db3");
  auto source = OpenRosMessageSource(path);
  REQUIRE(source.ok());
  CHECK(std::string((*source)->format()) == "rosbag2 sqlite3");
  const Walked w = Walk(source->get());
  CHECK(w.ended);
  CHECK(w.messages.size() == 4);
}

TEST_CASE("rosbag2 db3: a serialization format other than cdr is typed unsupported, an empty bag ends at once") {
  const std::string path = test::ScratchFile("json.db3");
  sqlite3* db = Create(path);
  CreateTables(db, Layout::kHumble);
  AddTopic(db, Layout::kHumble, 5, "/points", "sensor_msgs/msg/PointCloud2", "json");
  sqlite3_close(db);
  auto reader = Rosbag2Db3Reader::Open(path);
  REQUIRE(reader.ok());
  const Walked w = Walk(reader->get());
  CHECK(w.ended);
  REQUIRE(w.channels.size() == 1);
  CHECK(w.channels[0].type == "sensor_msgs/msg/PointCloud2 (json)");
  CHECK(RosMessageKindOf(w.channels[0].type) == RosMessageKind::kUnsupported);
  CHECK(w.messages.empty());
}

TEST_CASE("rosbag2 db3: a message whose topic_id is not in the topics table is DataLoss naming the row") {
  const std::string path = test::ScratchFile("orphan.db3");
  sqlite3* db = Create(path);
  CreateTables(db, Layout::kIron);
  AddTopic(db, Layout::kIron, 1, "/odom", "nav_msgs/msg/Odometry");
  AddMessage(db, 1, 5, "a");
  AddMessage(db, 7, 6, "b");
  sqlite3_close(db);
  auto reader = Rosbag2Db3Reader::Open(path);
  REQUIRE(reader.ok());
  const Walked w = Walk(reader->get());
  CHECK(w.messages.size() == 1);
  CHECK(w.status.code() == StatusCode::kDataLoss);
  CHECK(Has(w.status, path + ": message row 1 (messages.id 2): topic_id 7 is not in the topics table"));
}

TEST_CASE("rosbag2 db3: a database without the rosbag2 tables or columns is InvalidArgument naming the file") {
  const std::string no_messages = test::ScratchFile("no_messages.db3");
  sqlite3* db = Create(no_messages);
  Exec(db, TopicsTable(Layout::kIron));
  sqlite3_close(db);
  auto a = Rosbag2Db3Reader::Open(no_messages);
  REQUIRE_FALSE(a.ok());
  CHECK(a.status().code() == StatusCode::kInvalidArgument);
  CHECK(Has(a.status(), no_messages + ": not a rosbag2 sqlite3 database"));
  CHECK(Has(a.status(), "no such table: messages"));

  const std::string no_column = test::ScratchFile("no_column.db3");
  db = Create(no_column);
  Exec(db, "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT, type TEXT);");
  sqlite3_close(db);
  auto b = Rosbag2Db3Reader::Open(no_column);
  REQUIRE_FALSE(b.ok());
  CHECK(Has(b.status(), "no such column: serialization_format"));
}

TEST_CASE("rosbag2 db3: a file that is not a database, or a cut or damaged one, is an error naming it") {
  const std::string text = test::ScratchFile("text.db3");
  std::FILE* f = std::fopen(text.c_str(), "wb");
  REQUIRE(f != nullptr);
  std::fputs("SQLite format 3", f);
  std::fputc(0, f);
  for (int i = 0; i < 300; ++i) std::fputs("not a database page ", f);
  std::fclose(f);
  auto a = OpenRosMessageSource(text);
  REQUIRE_FALSE(a.ok());
  CHECK(Has(a.status(), text + ": "));
  CHECK(Has(a.status(), "sqlite: "));

  // The bag cut short and with pages overwritten: an error or a clean read, never a crash.
  const std::string good = test::ReadTextFile(SmallBag(Layout::kIron, "whole.db3"));
  int refused = 0;
  for (std::size_t cut = 0; cut < good.size(); cut += 512) {
    for (const bool damage : {false, true}) {
      std::string bad = damage ? good : good.substr(0, cut);
      if (damage) bad.replace(cut, std::min<std::size_t>(300, good.size() - cut), 300, '\xA5');
      const std::string path = test::ScratchFile("bad.db3");
      f = std::fopen(path.c_str(), "wb");
      REQUIRE(f != nullptr);
      std::fwrite(bad.data(), 1, bad.size(), f);
      std::fclose(f);
      auto reader = Rosbag2Db3Reader::Open(path);
      if (!reader.ok()) {
        ++refused;
        CHECK(Has(reader.status(), path));
        continue;
      }
      const Walked w = Walk(reader->get());
      if (!w.status.ok()) {
        ++refused;
        CHECK(Has(w.status, path));
      }
    }
  }
  CHECK(refused > 0);
  auto missing = Rosbag2Db3Reader::Open(test::ScratchFile("missing.db3"));
  CHECK_FALSE(missing.ok());
}

/// SQLite's varint (sqlite3PutVarint): 7 bits per byte, most significant first; values below 2^56.
std::string SqliteVarint(std::uint64_t v) {
  std::string out(1, static_cast<char>(v & 0x7F));
  for (v >>= 7; v != 0; v >>= 7) out.insert(out.begin(), static_cast<char>(0x80 | (v & 0x7F)));
  return out;
}

std::uint64_t ReadSqliteVarint(const std::string& bytes, std::size_t* at) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) {
    const auto b = static_cast<unsigned char>(bytes.at((*at)++));
    v = (v << 7) | (b & 0x7F);
    if ((b & 0x80) == 0) return v;
  }
  return (v << 8) | static_cast<unsigned char>(bytes.at((*at)++));
}

unsigned Be16(const std::string& bytes, std::size_t at) {
  return (static_cast<unsigned char>(bytes.at(at)) << 8) | static_cast<unsigned char>(bytes.at(at + 1));
}

void PutBe16(std::string* bytes, std::size_t at, unsigned v) {
  (*bytes)[at] = static_cast<char>(v >> 8);
  (*bytes)[at + 1] = static_cast<char>(v & 0xFF);
}

/// Database file `bytes` (page size `page_size`, no reserved bytes) with the first cell of table-leaf page `page`
/// (1-based, not page 1) rewritten so that its record declares `extra` x (page_size - 4) payload bytes more than
/// it holds and a record header of `header_bytes` (< 128), more than the cell keeps on its page: the same rowid,
/// local bytes and first overflow page (the local part's length depends on the payload size modulo page_size - 4
/// only), behind a longer size varint; the new cell goes into the page's free space. SQLite then reads the header
/// from the overflow pages, sizing its list of them from the declared payload.
std::string InflateFirstCell(std::string bytes, std::size_t page_size, std::uint64_t page, std::uint64_t extra,
                             unsigned header_bytes) {
  const std::size_t off = (page - 1) * page_size;
  REQUIRE(static_cast<unsigned char>(bytes.at(off)) == 0x0D);  // a table b-tree leaf
  const unsigned cells = Be16(bytes, off + 3);
  const unsigned content = Be16(bytes, off + 5);
  std::size_t at = off + Be16(bytes, off + 8);
  const std::uint64_t payload = ReadSqliteVarint(bytes, &at);
  const std::uint64_t rowid = ReadSqliteVarint(bytes, &at);
  // SQLite's local part of an overflowing table-leaf payload (btreeParseCellAdjustSizeForOverflow).
  const std::uint64_t usable = page_size;
  const std::uint64_t max_local = usable - 35;
  const std::uint64_t min_local = (usable - 12) * 32 / 255 - 23;
  REQUIRE(payload > max_local);  // the record overflows
  const std::uint64_t surplus = min_local + (payload - min_local) % (usable - 4);
  const std::uint64_t local = surplus <= max_local ? surplus : min_local;
  std::string body = bytes.substr(at, local + 4);  // local bytes and the first overflow page number
  REQUIRE((header_bytes > local && header_bytes < 128));
  body[0] = static_cast<char>(header_bytes);  // the record's header-size varint
  const std::string cell = SqliteVarint(payload + extra * (usable - 4)) + SqliteVarint(rowid) + body;
  const std::size_t start = content - cell.size();
  REQUIRE(start >= 8 + 2 * cells);  // above the cell pointer array
  bytes.replace(off + start, cell.size(), cell);
  PutBe16(&bytes, off + 8, static_cast<unsigned>(start));
  PutBe16(&bytes, off + 5, static_cast<unsigned>(start));
  return bytes;
}

void WriteFile(const std::string& path, const std::string& bytes) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  REQUIRE(f != nullptr);
  REQUIRE(std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size());
  std::fclose(f);
}

TEST_CASE("rosbag2 db3: a record declaring gigabytes is refused without SQLite allocating from that size") {
  REQUIRE(kSqliteCapInstalled);
  const std::string path = test::ScratchFile("inflated.db3");
  sqlite3* db = Create(path);
  Exec(db, "PRAGMA page_size = 512;");
  CreateTables(db, Layout::kIron);
  AddTopic(db, Layout::kIron, 1, "/odom", "nav_msgs/msg/Odometry");
  AddMessage(db, 1, 5, std::string(560, 'm'));  // overflows a 512-byte page, 60 bytes on it
  sqlite3_stmt* stmt = nullptr;
  REQUIRE(sqlite3_prepare_v2(db, "SELECT rootpage FROM sqlite_master WHERE name = 'messages'", -1, &stmt, nullptr) ==
          SQLITE_OK);
  REQUIRE(sqlite3_step(stmt) == SQLITE_ROW);
  const std::uint64_t root = static_cast<std::uint64_t>(sqlite3_column_int64(stmt, 0));
  sqlite3_finalize(stmt);
  sqlite3_close(db);
  {
    auto whole = Rosbag2Db3Reader::Open(path);  // the file as written reads whole
    REQUIRE(whole.ok());
    const Walked w = Walk(whole->get());
    CHECK(w.ended);
    REQUIRE(w.messages.size() == 1);
    CHECK(w.messages[0] == "1@5:" + std::string(560, 'm'));
  }
  // 2^20 more overflow pages: SQLite's list of the record's overflow pages alone would be 2^20 x 8 bytes = 8 MiB.
  WriteFile(path, InflateFirstCell(test::ReadTextFile(path), 512, root, std::uint64_t{1} << 20, 100));
  sqlite3_int64 used = 0;
  sqlite3_int64 highest = 0;
  REQUIRE(sqlite3_status64(SQLITE_STATUS_MEMORY_USED, &used, &highest, 1) == SQLITE_OK);
  auto reader = Rosbag2Db3Reader::Open(path);
  REQUIRE(reader.ok());
  const Walked w = Walk(reader->get());
  CHECK(w.messages.empty());
  CHECK(w.status.code() == StatusCode::kDataLoss);
  INFO(w.status.ToString());
  CHECK(Has(w.status, path + ": message row 0 (in timestamp order): sqlite: out of memory"));
  CHECK(Has(w.status, "SQLite asked for a block above 4 MiB"));
  REQUIRE(sqlite3_status64(SQLITE_STATUS_MEMORY_USED, &used, &highest, 0) == SQLITE_OK);
  CHECK(static_cast<std::uint64_t>(highest) < kSqliteLargestBlockBytes);
}

TEST_CASE("rosbag2 db3: a message larger than SQLite's block cap reads whole, one above max_message_bytes is "
          "refused naming the limit") {
  REQUIRE(kSqliteCapInstalled);
  const std::string path = test::ScratchFile("large.db3");
  sqlite3* db = Create(path);
  CreateTables(db, Layout::kHumble);
  AddTopic(db, Layout::kHumble, 1, "/velodyne_points", "sensor_msgs/msg/PointCloud2");
  std::string cloud(kSqliteLargestBlockBytes + 12345, '\0');
  std::uint32_t x = 12345;
  for (char& c : cloud) c = static_cast<char>((x = x * 1664525u + 1013904223u) >> 24);
  AddMessage(db, 1, 7, cloud);
  AddMessage(db, 1, 9, "small");
  sqlite3_close(db);
  auto reader = Rosbag2Db3Reader::Open(path);
  REQUIRE(reader.ok());
  const Walked w = Walk(reader->get());
  REQUIRE(w.status.ok());
  REQUIRE(w.messages.size() == 2);
  CHECK(w.messages[0] == "1@7:" + cloud);
  CHECK(w.messages[1] == "1@9:small");

  Rosbag2Db3Limits limits;
  limits.max_message_bytes = cloud.size() - 1;
  auto limited = Rosbag2Db3Reader::Open(path, limits);
  REQUIRE(limited.ok());
  const Walked refused = Walk(limited->get());
  CHECK(refused.messages.empty());
  CHECK(refused.status.code() == StatusCode::kDataLoss);
  CHECK(Has(refused.status, path + ": message row 0 (messages.id 1): its data is " + std::to_string(cloud.size()) +
                                " bytes, above " + std::to_string(cloud.size() - 1) +
                                " (Rosbag2Db3Limits::max_message_bytes)"));
}

}  // namespace commerge::platform::rosbag2_db3_test
