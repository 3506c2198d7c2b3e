// SPDX-License-Identifier: BSD-3-Clause
#include "platform/ros/rosbag2_db3.hpp"

#include <sqlite3.h>

#include <algorithm>
#include <cstdio>
#include <utility>

#include "platform/io/file_util.hpp"

namespace commerge::platform {

// The helpers live in their own namespace: in a unity build other files of the library share this translation unit.
namespace db3fmt {
namespace {

/// "file:<path, percent-encoded>?immutable=1" (sqlite's URI filenames: '?', '#' and '%' must not appear raw).
std::string ImmutableUri(const std::string& path) {
  static const char kHex[] = "0123456789ABCDEF";
  std::string uri = "file:";
  for (const char ch : path) {
    const auto c = static_cast<unsigned char>(ch);
    const bool plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '/' ||
                       c == '.' || c == '-' || c == '_' || c == '~';
    if (plain) {
      uri += ch;
    } else {
      uri += '%';
      uri += kHex[c >> 4];
      uri += kHex[c & 0xF];
    }
  }
  return uri + "?immutable=1";
}

std::string ColumnText(sqlite3_stmt* stmt, int column) {
  const unsigned char* text = sqlite3_column_text(stmt, column);
  const int n = sqlite3_column_bytes(stmt, column);
  return text == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(text), static_cast<size_t>(n));
}

// SQLite's default allocator, wrapped by the cap (written once, before SQLite initialises; read-only after).
sqlite3_mem_methods g_sqlite_default_allocator;

bool AboveCap(int bytes) { return bytes < 0 || static_cast<std::size_t>(bytes) > kSqliteLargestBlockBytes; }

void* CappedMalloc(int bytes) { return AboveCap(bytes) ? nullptr : g_sqlite_default_allocator.xMalloc(bytes); }

void* CappedRealloc(void* block, int bytes) {
  return AboveCap(bytes) ? nullptr : g_sqlite_default_allocator.xRealloc(block, bytes);
}

}  // namespace
}  // namespace db3fmt

bool InstallSqliteBlockCap() {
  static const bool installed = [] {
    if (sqlite3_config(SQLITE_CONFIG_GETMALLOC, &db3fmt::g_sqlite_default_allocator) != SQLITE_OK) return false;
    sqlite3_mem_methods capped = db3fmt::g_sqlite_default_allocator;
    capped.xMalloc = db3fmt::CappedMalloc;
    capped.xRealloc = db3fmt::CappedRealloc;
    return sqlite3_config(SQLITE_CONFIG_MALLOC, &capped) == SQLITE_OK;
  }();
  return installed;
}

void Rosbag2Db3Reader::DbClose::operator()(sqlite3* db) const noexcept { sqlite3_close_v2(db); }
void Rosbag2Db3Reader::StmtFinalize::operator()(sqlite3_stmt* stmt) const noexcept { sqlite3_finalize(stmt); }
void Rosbag2Db3Reader::BlobClose::operator()(sqlite3_blob* blob) const noexcept { sqlite3_blob_close(blob); }

Rosbag2Db3Reader::~Rosbag2Db3Reader() {
  blob_.reset();  // before the database they belong to
  messages_.reset();
}

Result<std::unique_ptr<Rosbag2Db3Reader>> Rosbag2Db3Reader::Open(const std::string& path,
                                                                 const Rosbag2Db3Limits& limits) {
  InstallSqliteBlockCap();
  std::unique_ptr<Rosbag2Db3Reader> reader(new Rosbag2Db3Reader(path, limits));
  Status st = reader->OpenDatabase();
  if (st.ok()) st = reader->ReadSchemaVersion();
  if (st.ok()) st = reader->ReadTopics(limits);
  if (st.ok()) st = reader->CountMessages();
  if (!st.ok()) return st;
  auto messages = reader->Prepare("SELECT topic_id, timestamp, id, typeof(data), rowid FROM messages "
                                  "ORDER BY timestamp, id",
                                  "not a rosbag2 sqlite3 database: reading the messages table");
  if (!messages.ok()) return messages.status();
  reader->messages_ = std::move(*messages);
  return reader;
}

Status Rosbag2Db3Reader::OpenDatabase() {
  auto file = OpenForRead(path_);  // a clear error for a missing or unreadable file, before sqlite's
  if (!file.ok()) return file.status();
  auto size = FileSize(file->get(), path_);
  if (!size.ok()) return size.status();
  file_size_ = *size;
  sqlite3* raw = nullptr;
  const int rc = sqlite3_open_v2(db3fmt::ImmutableUri(path_).c_str(), &raw, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI,
                                 nullptr);
  db_.reset(raw);  // closed even when the open failed
  if (rc != SQLITE_OK) return SqliteError(StatusCode::kIoError, "cannot open it");
  // SQLite's default cache size, not the one a (corrupt) file header suggests: it sizes the sorter's buffer.
  if (sqlite3_exec(db_.get(), "PRAGMA cache_size = -2000", nullptr, nullptr, nullptr) != SQLITE_OK) {
    return SqliteError(StatusCode::kInvalidArgument, "not an sqlite3 database");
  }
  return Status::Ok();
}

Result<Rosbag2Db3Reader::Statement> Rosbag2Db3Reader::Prepare(const char* sql, const char* what) {
  sqlite3_stmt* raw = nullptr;
  const int rc = sqlite3_prepare_v2(db_.get(), sql, -1, &raw, nullptr);
  Statement stmt(raw);
  if (rc != SQLITE_OK) {
    const int primary = rc & 0xFF;
    const StatusCode code = primary == SQLITE_CORRUPT ? StatusCode::kDataLoss
                            : primary == SQLITE_IOERR ? StatusCode::kIoError : StatusCode::kInvalidArgument;
    return SqliteError(code, what);
  }
  return stmt;
}

Status Rosbag2Db3Reader::ReadSchemaVersion() {
  auto has_schema = Prepare("SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'schema'",
                            "not an sqlite3 database");
  if (!has_schema.ok()) return has_schema.status();
  int rc = sqlite3_step(has_schema->get());
  if (rc != SQLITE_ROW) return SqliteError(StatusCode::kInvalidArgument, "not an sqlite3 database");
  if (sqlite3_column_int64(has_schema->get(), 0) == 0) return Status::Ok();
  auto version = Prepare("SELECT max(schema_version) FROM schema", "reading the schema table");
  if (!version.ok()) return version.status();
  rc = sqlite3_step(version->get());
  if (rc != SQLITE_ROW) return SqliteError(StatusCode::kDataLoss, "reading the schema table");
  schema_version_ = sqlite3_column_int(version->get(), 0);
  return Status::Ok();
}

Status Rosbag2Db3Reader::ReadTopics(const Rosbag2Db3Limits& limits) {
  const char* const what = "not a rosbag2 sqlite3 database: reading the topics table";
  auto topics = Prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id", what);
  if (!topics.ok()) return topics.status();
  sqlite3_stmt* const stmt = topics->get();
  int rc = SQLITE_ROW;
  while ((rc = sqlite3_step(stmt)) == SQLITE_ROW) {
    const sqlite3_int64 id = sqlite3_column_int64(stmt, 0);
    if (id < 0 || id > 0xFFFFFFFFll) {
      return DataLoss(path_ + ": topics table: topic id " + std::to_string(id) + " is not a uint32");
    }
    if (channels_.size() >= limits.max_topics) {
      return DataLoss(path_ + ": topics table: more than " + std::to_string(limits.max_topics) +
                      " topics (Rosbag2Db3Limits::max_topics)");
    }
    RosChannel c;
    c.id = static_cast<std::uint32_t>(id);
    c.topic = db3fmt::ColumnText(stmt, 1);
    c.type = db3fmt::ColumnText(stmt, 2);
    const std::string format = db3fmt::ColumnText(stmt, 3);
    c.encoding = RosEncoding::kCdr;
    if (format != "cdr") c.type += " (" + (format.empty() ? std::string("no serialization format") : format) + ")";
    if (!channel_index_.emplace(c.id, channels_.size()).second) {
      return DataLoss(path_ + ": topics table: topic id " + std::to_string(id) + " appears twice");
    }
    channels_.push_back(std::move(c));
  }
  if (rc != SQLITE_DONE) return SqliteError(StatusCode::kDataLoss, "reading the topics table");
  return Status::Ok();
}

Status Rosbag2Db3Reader::CountMessages() {
  const char* const what = "not a rosbag2 sqlite3 database: counting the messages";
  auto count = Prepare("SELECT count(*) FROM messages", what);
  if (!count.ok()) return count.status();
  if (sqlite3_step(count->get()) != SQLITE_ROW) return SqliteError(StatusCode::kDataLoss, "counting the messages");
  row_count_ = static_cast<std::uint64_t>(sqlite3_column_int64(count->get(), 0));
  return Status::Ok();
}

// ---- The walk ----------------------------------------------------------------------------------------------------

Result<RosMessageSource::Item> Rosbag2Db3Reader::Next() {
  if (!error_.ok()) return error_;
  if (announced_ < channels_.size()) {
    ++announced_;
    return Item::kChannel;
  }
  if (ended_) return Item::kEnd;
  Result<Item> item = StepMessage();
  if (!item.ok()) error_ = item.status();
  return item;
}

Result<RosMessageSource::Item> Rosbag2Db3Reader::StepMessage() {
  sqlite3_stmt* const stmt = messages_.get();
  const int rc = sqlite3_step(stmt);
  const std::string row = "message row " + std::to_string(rows_read_);
  if (rc == SQLITE_DONE) {
    ended_ = true;
    rows_read_ = row_count_;
    return Item::kEnd;
  }
  if (rc != SQLITE_ROW) return SqliteError(StatusCode::kDataLoss, row + " (in timestamp order)");
  const sqlite3_int64 topic_id = sqlite3_column_int64(stmt, 0);
  const sqlite3_int64 id = sqlite3_column_int64(stmt, 2);
  const std::string where = row + " (messages.id " + std::to_string(id) + ")";
  if (topic_id < 0 || topic_id > 0xFFFFFFFFll || FindChannel(static_cast<std::uint32_t>(topic_id)) == nullptr) {
    return DataLoss(path_ + ": " + where + ": topic_id " + std::to_string(topic_id) + " is not in the topics table");
  }
  const std::string type = db3fmt::ColumnText(stmt, 3);
  if (type == "blob") {
    const Status st = ReadData(sqlite3_column_int64(stmt, 4), where);
    if (!st.ok()) return st;
  } else if (type == "null") {
    data_.clear();
  } else {
    return DataLoss(path_ + ": " + where + ": data is not a BLOB (sqlite type " + type + ")");
  }
  message_.channel_id = static_cast<std::uint32_t>(topic_id);
  message_.log_time_ns = sqlite3_column_int64(stmt, 1);
  message_.data = Span<const std::uint8_t>(data_.data(), data_.size());
  message_.offset = static_cast<std::uint64_t>(id);
  message_.index = rows_read_++;
  if (rows_read_ > row_count_) row_count_ = rows_read_;  // never past size()
  return Item::kMessage;
}

Status Rosbag2Db3Reader::ReadData(std::int64_t rowid, const std::string& row) {
  int rc = SQLITE_OK;
  if (blob_) {
    rc = sqlite3_blob_reopen(blob_.get(), rowid);
  } else {
    sqlite3_blob* raw = nullptr;
    rc = sqlite3_blob_open(db_.get(), "main", "messages", "data", rowid, 0, &raw);
    blob_.reset(raw);
  }
  if (rc != SQLITE_OK) {
    Status error = SqliteError(StatusCode::kDataLoss, row + ": opening its data");
    blob_.reset();  // a handle whose reopen failed is unusable
    return error;
  }
  const int bytes = sqlite3_blob_bytes(blob_.get());
  if (bytes < 0 || static_cast<std::uint64_t>(bytes) > file_size_) {
    return DataLoss(path_ + ": " + row + ": its data declares " + std::to_string(bytes) + " bytes, more than the " +
                    std::to_string(file_size_) + "-byte file");
  }
  if (static_cast<std::uint64_t>(bytes) > limits_.max_message_bytes) {
    return DataLoss(path_ + ": " + row + ": its data is " + std::to_string(bytes) + " bytes, above " +
                    std::to_string(limits_.max_message_bytes) + " (Rosbag2Db3Limits::max_message_bytes)");
  }
  data_.resize(static_cast<std::size_t>(bytes));
  if (bytes > 0 && sqlite3_blob_read(blob_.get(), data_.data(), bytes, 0) != SQLITE_OK) {
    return SqliteError(StatusCode::kDataLoss, row + ": reading its data");
  }
  return Status::Ok();
}

const RosChannel* Rosbag2Db3Reader::FindChannel(std::uint32_t id) const noexcept {
  const auto it = channel_index_.find(id);
  return it == channel_index_.end() ? nullptr : &channels_[it->second];
}

std::uint64_t Rosbag2Db3Reader::position() const noexcept {
  if (ended_ || row_count_ == 0) return ended_ ? file_size_ : 0;
  // file_size_ * rows_read_ / row_count_ without overflow (rows_read_ <= row_count_: monotonic, at most the size).
  const long double scaled = static_cast<long double>(file_size_) * rows_read_ / row_count_;
  return std::min(file_size_, static_cast<std::uint64_t>(scaled));
}

Status Rosbag2Db3Reader::SqliteError(StatusCode code, const std::string& what) const {
  if (!db_ || (sqlite3_errcode(db_.get()) & 0xFF) == SQLITE_NOMEM) {
    // With the cap, SQLite asking for a block above it is what a corrupt record's declared size looks like.
    return Status(StatusCode::kDataLoss, path_ + ": " + what + ": sqlite: out of memory (SQLite asked for a block " +
                                             "above " + std::to_string(kSqliteLargestBlockBytes >> 20) +
                                             " MiB, or the process has no memory left): a corrupt file?");
  }
  return Status(code, path_ + ": " + what + ": sqlite: " + sqlite3_errmsg(db_.get()));
}

}  // namespace commerge::platform
