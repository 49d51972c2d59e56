// rosbag2 sqlite3 storage reader (.db3; rosbag2_storage_sqlite3's tables), via Debian's libsqlite3.
//
// Every db schema version (1-4) has topics(id, name, type, serialization_format, ...) and
// messages(id, topic_id, timestamp, data); version 2 adds topics.offered_qos_profiles, 3 the schema and metadata
// tables, 4 topics.type_description_hash and message_definitions. Only the columns all versions share are read.
// Messages come in (timestamp, id) order, as rosbag2's own reader gives them.
#include <sys/stat.h>

#include <sqlite3.h>

#include <cstring>

#include "gyro_allan/rosbag2/storage.hpp"

namespace gyro_allan {
namespace rosbag2 {
namespace {

class Statement {
 public:
  Statement(sqlite3* db, const std::string& sql, const std::string& path) : path_(path) {
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &st_, nullptr) != SQLITE_OK)
      throw FormatError(path + ": not a rosbag2 sqlite3 file (" + sqlite3_errmsg(db) + ")");
  }
  ~Statement() { sqlite3_finalize(st_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  /// The next row: true; false after the last. Throws FormatError on a damaged file.
  bool step() {
    const int rc = sqlite3_step(st_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw FormatError(path_ + ": damaged sqlite3 file (" + sqlite3_errstr(rc) + ")");
  }
  sqlite3_stmt* get() { return st_; }
  std::string text(int col) {
    const unsigned char* t = sqlite3_column_text(st_, col);
    return t ? reinterpret_cast<const char*>(t) : "";
  }

 private:
  sqlite3_stmt* st_ = nullptr;
  std::string path_;
};

class Sqlite3Storage : public Storage {
 public:
  explicit Sqlite3Storage(const std::string& path) {
    path_ = path;
    struct stat st {};
    if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) throw FormatError("cannot open '" + path + "'");
    // Read-only and immutable: no lock, journal or -shm file is made (a finished bag in a read-only folder opens).
    std::string uri = "file:";
    for (char c : path) {  // URI escaping of the characters that have a meaning there
      if (c == '?' || c == '#' || c == '%') {
        char b[4];
        std::snprintf(b, sizeof b, "%%%02X", static_cast<unsigned char>(c));
        uri += b;
      } else {
        uri += c;
      }
    }
    uri += "?immutable=1";
    if (sqlite3_open_v2(uri.c_str(), &db_, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr) != SQLITE_OK) {
      const std::string e = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      throw FormatError("cannot open '" + path + "' as sqlite3: " + e);
    }
    try {
      if (!hasTable("topics") || !hasTable("messages"))
        throw FormatError(path + ": not a rosbag2 sqlite3 file (no topics and messages tables)");
      schema_version_ = hasTable("schema") ? schemaVersion() : hasColumn("topics", "offered_qos_profiles") ? 2 : 1;
      Statement s(db_, "SELECT id, name, type, serialization_format FROM topics ORDER BY id", path_);
      while (s.step()) {
        ids_.push_back(sqlite3_column_int64(s.get(), 0));
        topics_.push_back({s.text(1), s.text(2), s.text(3)});
      }
    } catch (...) {
      sqlite3_close(db_);
      throw;
    }
  }
  ~Sqlite3Storage() override { sqlite3_close(db_); }

  std::string kind() const override { return "sqlite3"; }
  std::string describe() const override { return "sqlite3, db schema " + std::to_string(schema_version_); }

  void read(const std::vector<bool>& wanted, const std::function<void(const StoredMessage&)>& f) override {
    std::string in;
    std::map<int64_t, size_t> index;
    for (size_t i = 0; i < ids_.size(); ++i) {
      index[ids_[i]] = i;
      if (i < wanted.size() && wanted[i]) in += (in.empty() ? "" : ",") + std::to_string(ids_[i]);
    }
    if (in.empty()) return;
    Statement s(db_,
                "SELECT topic_id, timestamp, data FROM messages WHERE topic_id IN (" + in +
                    ") ORDER BY timestamp, id",
                path_);
    while (s.step()) {
      StoredMessage m;
      const auto it = index.find(sqlite3_column_int64(s.get(), 0));
      if (it == index.end()) continue;
      m.topic = it->second;
      m.recv_ns = sqlite3_column_int64(s.get(), 1);
      m.data = static_cast<const uint8_t*>(sqlite3_column_blob(s.get(), 2));
      m.size = static_cast<size_t>(sqlite3_column_bytes(s.get(), 2));
      f(m);
    }
  }

  std::vector<int64_t> messageCounts() override {
    std::vector<int64_t> counts(topics_.size(), 0);
    Statement s(db_, "SELECT topic_id, COUNT(*) FROM messages GROUP BY topic_id", path_);
    while (s.step()) {
      const int64_t id = sqlite3_column_int64(s.get(), 0);
      for (size_t i = 0; i < ids_.size(); ++i)
        if (ids_[i] == id) counts[i] = sqlite3_column_int64(s.get(), 1);
    }
    return counts;
  }

  int64_t startNs() override {
    Statement s(db_, "SELECT MIN(timestamp) FROM messages", path_);
    return s.step() ? sqlite3_column_int64(s.get(), 0) : 0;
  }

 private:
  bool hasTable(const char* name) {
    Statement s(db_, std::string("SELECT 1 FROM sqlite_master WHERE type='table' AND name='") + name + "'", path_);
    return s.step();
  }
  bool hasColumn(const char* table, const char* column) {
    Statement s(db_, std::string("PRAGMA table_info(") + table + ")", path_);
    while (s.step())
      if (s.text(1) == column) return true;
    return false;
  }
  int schemaVersion() {
    Statement s(db_, "SELECT schema_version FROM schema", path_);
    return s.step() ? sqlite3_column_int(s.get(), 0) : 0;
  }

  sqlite3* db_ = nullptr;
  std::vector<int64_t> ids_;  // topics.id of topics_[i]
  int schema_version_ = 0;
};

}  // namespace

std::unique_ptr<Storage> openSqlite3(const std::string& path) { return std::make_unique<Sqlite3Storage>(path); }

}  // namespace rosbag2
}  // namespace gyro_allan
