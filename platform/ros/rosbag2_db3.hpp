// SPDX-License-Identifier: BSD-3-Clause
// rosbag2's sqlite3 storage (one .db3 file of a ROS 2 bag) as a RosMessageSource, on libsqlite3. Tables read:
//   topics(id, name, type, serialization_format, ...)   -- every version; offered_qos_profiles (Foxy and later)
//                                                           and type_description_hash (schema 4, Iron and later)
//                                                           are not read, so every version is accepted
//   messages(id, topic_id, timestamp, data)
// The schema, metadata and message_definitions tables of newer versions are not needed; schema_version() reports
// the schema table's version when there is one (3: Humble, 4: Iron and later), else 0.
//
// The file is opened read-only and immutable (SQLITE_OPEN_READONLY, URI "file:...?immutable=1": no lock, no
// journal or -wal file looked at or created; a -wal file left by a writer that crashed is not applied). Every
// topic is announced as a channel first (in id order), then the messages are stepped row by row from
//   SELECT topic_id, timestamp, id, typeof(data), rowid FROM messages ORDER BY timestamp, id
// (rosbag2's own read order; the timestamp_idx index that rosbag2 creates serves it; without it SQLite sorts these
// small columns, never the data). Each row's data is read through SQLite's incremental blob API into one buffer
// of the reader, after its length is checked against the file's size and Rosbag2Db3Limits::max_message_bytes, so
// memory is bounded by the largest message, not by the file. RosChannel: id = topics.id, type = topics.type
// ("sensor_msgs/msg/PointCloud2"), encoding kCdr for serialization_format "cdr"; another format is announced with
// it appended to the type in parentheses ("... (json)"), which RosMessageKindOf() does not know, so
// `commerge import` lists it as unsupported. RosRecord: log_time_ns = messages.timestamp, offset = messages.id
// (the row id: a db3 has no message offsets).
//
// SQLite's own allocations are capped at kSqliteLargestBlockBytes per block (InstallSqliteBlockCap): a corrupt
// file can declare a record of gigabytes, from which SQLite sizes internal arrays before it finds the damage; the
// cap turns that into an error (DataLoss, "SQLite asked for a block above ...") instead of the allocation.
//
// position() and size(): the file size, and file size x rows read / rows of the messages table (counted at Open),
// rounded down; position() == size() at kEnd. Monotonic, and proportional to the messages walked.
//
// Errors name the file: not an sqlite3 database, a missing table or column ("not a rosbag2 sqlite3 database: ...:
// no such table: topics"), a corrupt database (the sqlite error text and the message row), a message whose
// topic_id is not in the topics table, data that is not a BLOB or longer than the file or the limit. After an
// error Next() returns it again.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/common/status.hpp"
#include "platform/ros/message_source.hpp"

struct sqlite3;
struct sqlite3_stmt;
struct sqlite3_blob;

namespace commerge::platform {

struct Rosbag2Db3Limits {
  std::uint32_t max_topics = 65536;                ///< rows of the topics table
  std::uint64_t max_message_bytes = 512ull << 20;  ///< one message's data [bytes]
};

/// The largest block SQLite may allocate in this process once InstallSqliteBlockCap() has run [bytes]. SQLite's
/// own blocks for reading a rosbag2 file are far smaller (page-cache bulk ~1.3 MiB at 64 KiB pages, sorter 2 MB at
/// the cache size the reader sets, the overflow-page list of a message: 8 bytes per page of it).
constexpr std::size_t kSqliteLargestBlockBytes = std::size_t{4} << 20;

/// Routes SQLite's allocations through a check that refuses (SQLITE_NOMEM) any block above
/// kSqliteLargestBlockBytes. Process-wide (SQLITE_CONFIG_MALLOC), so it must run before SQLite initialises:
/// Rosbag2Db3Reader::Open calls it, and a process that uses SQLite before its first Open (a test writing
/// databases) calls it first. Idempotent; returns whether the cap is in place (false: SQLite was initialised
/// before, and the reader runs without the cap).
bool InstallSqliteBlockCap();

class Rosbag2Db3Reader final : public RosMessageSource {
 public:
  /// Opens `path`, reads the topics and counts the messages. Errors: IoError (cannot open), InvalidArgument (not
  /// an sqlite3 database, not a rosbag2 one: a table or column missing), DataLoss (corrupt); all name the file.
  static Result<std::unique_ptr<Rosbag2Db3Reader>> Open(const std::string& path, const Rosbag2Db3Limits& limits = {});
  ~Rosbag2Db3Reader() override;
  Rosbag2Db3Reader(const Rosbag2Db3Reader&) = delete;
  Rosbag2Db3Reader& operator=(const Rosbag2Db3Reader&) = delete;

  Result<Item> Next() override;
  const RosChannel& channel() const noexcept override { return channels_[announced_ - 1]; }
  const RosRecord& message() const noexcept override { return message_; }
  const RosChannel* FindChannel(std::uint32_t id) const noexcept override;
  std::uint64_t position() const noexcept override;
  std::uint64_t size() const noexcept override { return file_size_; }
  const char* format() const noexcept override { return "rosbag2 sqlite3"; }

  /// The schema table's schema_version (3: Humble, 4: Iron and later), 0 without one (Foxy, Galactic).
  int schema_version() const noexcept { return schema_version_; }
  std::uint64_t message_rows() const noexcept { return row_count_; }

 private:
  struct DbClose {
    void operator()(sqlite3* db) const noexcept;
  };
  struct StmtFinalize {
    void operator()(sqlite3_stmt* stmt) const noexcept;
  };
  struct BlobClose {
    void operator()(sqlite3_blob* blob) const noexcept;
  };
  using Statement = std::unique_ptr<sqlite3_stmt, StmtFinalize>;

  Rosbag2Db3Reader(std::string path, const Rosbag2Db3Limits& limits) : path_(std::move(path)), limits_(limits) {}
  Status OpenDatabase();
  Result<Statement> Prepare(const char* sql, const char* what);
  Status ReadSchemaVersion();
  Status ReadTopics(const Rosbag2Db3Limits& limits);
  Status CountMessages();
  Result<Item> StepMessage();
  /// Reads the data of messages row `rowid` into data_; `row` names it in errors.
  Status ReadData(std::int64_t rowid, const std::string& row);
  /// "<path>: <what>: sqlite: <error text>"
  Status SqliteError(StatusCode code, const std::string& what) const;

  std::string path_;
  Rosbag2Db3Limits limits_;
  std::unique_ptr<sqlite3, DbClose> db_;
  Statement messages_;
  std::unique_ptr<sqlite3_blob, BlobClose> blob_;  ///< open on the last row read, moved with sqlite3_blob_reopen
  std::vector<std::uint8_t> data_;                 ///< the last message's data
  std::vector<RosChannel> channels_;
  std::unordered_map<std::uint32_t, std::size_t> channel_index_;
  std::size_t announced_ = 0;
  RosRecord message_;
  std::uint64_t rows_read_ = 0;
  std::uint64_t row_count_ = 0;
  std::uint64_t file_size_ = 0;
  int schema_version_ = 0;
  bool ended_ = false;
  Status error_;
};

}  // namespace commerge::platform
