// SPDX-License-Identifier: BSD-3-Clause
// Rosbag2Db3Reader on rosbag2 sqlite3 files built here with libsqlite3 in the table layouts of rosbag2's schema
// versions (4: Iron and later, with type_description_hash and message_definitions; 3: Humble; Foxy's, without a
// schema table), and on files that are not rosbag2 databases, or not databases at all, or corrupt. Files by an
// independent writer (better-sqlite3 under Node) are read in the end-to-end test tests/apps/ros2_import_test.sh.
#include <doctest/doctest.h>
#include <sqlite3.h>

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

void AddMessage(sqlite3* db, int topic_id, std::int64_t timestamp, const std::string& data) {
  sqlite3_stmt* stmt = nullptr;
  REQUIRE(sqlite3_prepare_v2(db, "INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)", -1, &stmt,
                             nullptr) == SQLITE_OK);
  sqlite3_bind_int(stmt, 1, topic_id);
  sqlite3_bind_int64(stmt, 2, timestamp);
  sqlite3_bind_blob(stmt, 3, data.data(), static_cast<int>(data.size()), SQLITE_TRANSIENT);
  CHECK(sqlite3_step(stmt) == SQLITE_DONE);
  sqlite3_finalize(stmt);
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

}  // namespace commerge::platform::rosbag2_db3_test
