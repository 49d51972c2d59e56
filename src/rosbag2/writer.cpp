// ROS 2 bag writers without ROS 2 (MCAP, rosbag2 sqlite3 .db3, metadata.yaml, zstd): see writer.hpp.
//
// MCAP: written from the MCAP format specification (mcap.dev/spec), laid out as rosbag2's MCAP storage plugin does
// (profile "ros2", one Schema per type with encoding "ros2msg", one Channel per topic with message encoding "cdr" and
// metadata offered_qos_profiles / topic_type_hash; chunked: Schema and Channel records inside the chunks, a Message
// Index per channel after each chunk; Summary: Schemas, Channels, Statistics, Chunk Indexes, grouped by opcode, as
// libmcap and the Go writer order them). sqlite3: the tables rosbag2_storage_sqlite3 creates at each db schema version.
#include "gyro_allan/rosbag2/writer.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <set>
#include <utility>

#include <lz4frame.h>
#include <sqlite3.h>
#include "crc32.hpp"
#include <zstd.h>

namespace gyro_allan {
namespace rosbag2 {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& problem) { throw WriteError(path + ": " + problem); }

std::string errnoText() { return std::strerror(errno); }

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

/// Closes an output file, reporting buffered-write and close errors.
void closeOutput(FilePtr& f, const std::string& path) {
  if (!f) return;
  const bool bad = std::fflush(f.get()) != 0 || std::ferror(f.get());
  const int err = errno;
  const int rc = std::fclose(f.release());
  if (bad || rc != 0) {
    errno = bad ? err : errno;
    fail(path, "write failed: " + errnoText());
  }
}

// ---- little-endian serialization (MCAP spec "Serialization") ---------------------------------------------------

inline void put8(std::string& b, uint8_t v) { b.push_back(static_cast<char>(v)); }
inline void put16(std::string& b, uint16_t v) {
  char c[2] = {static_cast<char>(v), static_cast<char>(v >> 8)};
  b.append(c, 2);
}
inline void put32(std::string& b, uint32_t v) {
  char c[4];
  for (int i = 0; i < 4; ++i) c[i] = static_cast<char>(v >> (8 * i));
  b.append(c, 4);
}
inline void put64(std::string& b, uint64_t v) {
  char c[8];
  for (int i = 0; i < 8; ++i) c[i] = static_cast<char>(v >> (8 * i));
  b.append(c, 8);
}
inline void store16(char* p, uint16_t v) {
  for (int i = 0; i < 2; ++i) p[i] = static_cast<char>(v >> (8 * i));
}
inline void store32(char* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<char>(v >> (8 * i));
}
inline void store64(char* p, uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<char>(v >> (8 * i));
}
uint32_t len32(const std::string& path, size_t n, const char* what) {
  if (n > std::numeric_limits<uint32_t>::max()) fail(path, std::string(what) + " longer than 4 GiB");
  return static_cast<uint32_t>(n);
}
/// String: uint32 byte length + bytes.
void putStr(std::string& b, const std::string& s, const std::string& path) {
  put32(b, len32(path, s.size(), "string"));
  b += s;
}
/// A whole record: opcode, uint64 content length, content.
std::string record(uint8_t op, const std::string& content) {
  std::string r;
  r.reserve(9 + content.size());
  put8(r, op);
  put64(r, content.size());
  r += content;
  return r;
}

enum Op : uint8_t {
  kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05, kChunk = 0x06,
  kMessageIndex = 0x07, kChunkIndex = 0x08, kStatistics = 0x0B, kSummaryOffset = 0x0E, kDataEnd = 0x0F
};
const char kMagic[8] = {'\x89', 'M', 'C', 'A', 'P', '0', '\r', '\n'};

uint32_t crc32Of(uint32_t crc, const void* p, size_t n) {
  return crc32Update(crc, static_cast<const uint8_t*>(p), n);
}

}  // namespace

// ==== MCAP ========================================================================================================

struct McapWriter::Impl {
  std::string path;
  McapWriteOptions opt;
  FilePtr file;
  uint64_t pos = 0;       // bytes written so far = offset of the next byte
  bool crc_on = false;    // running CRC over what is written (data section, then summary)
  uint32_t crc = 0;
  bool closed = false, failed = false;

  struct Channel {
    uint16_t schema_id;
    std::string topic, type;
    std::string record;   // the whole Channel record, repeated in the summary
    uint64_t count = 0;
  };
  std::map<std::string, uint16_t> schema_ids;  // type -> schema id
  std::vector<std::string> schema_records;     // [id - 1]: the whole Schema record
  std::vector<Channel> channels;               // [id - 1]
  uint64_t message_count = 0, start = 0, end = 0;

  // the open chunk (uncompressed records) and its message index entries per channel id - 1
  std::string chunk;
  uint64_t chunk_start = 0, chunk_end = 0;
  bool chunk_has_messages = false;
  std::vector<std::vector<std::pair<uint64_t, uint64_t>>> chunk_entries;
  std::vector<uint8_t> packed;                 // compressed chunk
  std::unique_ptr<ZSTD_CCtx, size_t (*)(ZSTD_CCtx*)> zstd{nullptr, ZSTD_freeCCtx};
  uint32_t chunk_count = 0;
  std::vector<std::string> chunk_indexes;      // Chunk Index records for the summary

  std::string obuf;       // output buffer (the FILE is unbuffered: glibc ignores setvbuf sizes without a buffer)
  static constexpr size_t kOutBuffer = 1 << 20;

  void put(const void* p, size_t n) {
    if (n && std::fwrite(p, 1, n, file.get()) != n) fail(path, "write failed: " + errnoText());
  }
  void flushOut() {
    put(obuf.data(), obuf.size());
    obuf.clear();
  }
  void out(const void* p, size_t n) {
    if (n == 0) return;
    if (crc_on) crc = crc32Of(crc, p, n);
    pos += n;
    if (obuf.size() + n > kOutBuffer) flushOut();
    if (n >= kOutBuffer)
      put(p, n);
    else
      obuf.append(static_cast<const char*>(p), n);
  }
  void out(const std::string& s) { out(s.data(), s.size()); }

  /// Records for the data section: into the open chunk (chunked) or straight into the file.
  void data(const std::string& rec) {
    if (opt.chunked)
      chunk += rec;
    else
      out(rec);
  }

  // Chunk (op=0x06), then Message Index (op=0x07) per channel; remembers its Chunk Index (op=0x08).
  void flushChunk() {
    if (chunk.empty()) return;
    const uint64_t usize = chunk.size();
    const uint32_t ucrc = opt.crc ? crc32Of(0, chunk.data(), chunk.size()) : 0;
    const void* body = chunk.data();
    size_t csize = chunk.size();
    if (opt.compression == "zstd") {
      if (!zstd) {
        zstd.reset(ZSTD_createCCtx());
        if (!zstd) fail(path, "zstd: out of memory");
      }
      packed.resize(ZSTD_compressBound(chunk.size()));
      // one frame, content size in its header; level 1 = libmcap's default zstd level
      const size_t r = ZSTD_compressCCtx(zstd.get(), packed.data(), packed.size(), chunk.data(), chunk.size(), 1);
      if (ZSTD_isError(r)) fail(path, std::string("zstd: ") + ZSTD_getErrorName(r));
      body = packed.data();
      csize = r;
    } else if (opt.compression == "lz4") {
      LZ4F_preferences_t prefs;
      std::memset(&prefs, 0, sizeof prefs);
      prefs.frameInfo.contentSize = chunk.size();
      packed.resize(LZ4F_compressFrameBound(chunk.size(), &prefs));
      const size_t r = LZ4F_compressFrame(packed.data(), packed.size(), chunk.data(), chunk.size(), &prefs);
      if (LZ4F_isError(r)) fail(path, std::string("lz4: ") + LZ4F_getErrorName(r));
      body = packed.data();
      csize = r;
    }
    const uint64_t cstart = chunk_has_messages ? chunk_start : 0, cend = chunk_has_messages ? chunk_end : 0;
    std::string head;
    put64(head, cstart);                           // message_start_time
    put64(head, cend);                             // message_end_time
    put64(head, usize);                            // uncompressed_size
    put32(head, ucrc);                             // uncompressed_crc
    putStr(head, opt.compression, path);           // compression
    put64(head, csize);                            // records: uint64 length + bytes
    const uint64_t chunk_offset = pos;
    std::string op;
    put8(op, kChunk);
    put64(op, head.size() + csize);
    out(op);
    out(head);
    out(body, csize);
    const uint64_t chunk_length = pos - chunk_offset;
    ++chunk_count;

    // Message Index (op=0x07): channel_id, Array<Tuple<Timestamp, uint64 offset into the uncompressed records>>
    std::string mi_offsets;  // Map<uint16, uint64> entries for the Chunk Index
    const uint64_t mi_start = pos;
    for (size_t c = 0; c < chunk_entries.size(); ++c) {  // entries are only kept when message_indexes is on
      auto& e = chunk_entries[c];
      if (e.empty()) continue;
      {
        std::string r;
        r.reserve(9 + 2 + 4 + 16 * e.size());
        put8(r, kMessageIndex);
        put64(r, 2 + 4 + 16 * uint64_t(e.size()));
        put16(r, static_cast<uint16_t>(c + 1));
        put32(r, len32(path, 16 * e.size(), "message index"));
        for (const auto& te : e) {
          put64(r, te.first);
          put64(r, te.second);
        }
        put16(mi_offsets, static_cast<uint16_t>(c + 1));
        put64(mi_offsets, pos);
        out(r);
      }
      e.clear();
    }
    if (opt.summary && opt.chunk_indexes) {
      // Chunk Index (op=0x08)
      std::string ci;
      put64(ci, cstart);                            // message_start_time
      put64(ci, cend);                              // message_end_time
      put64(ci, chunk_offset);                      // chunk_start_offset
      put64(ci, chunk_length);                      // chunk_length (whole record)
      put32(ci, len32(path, mi_offsets.size(), "chunk index"));  // message_index_offsets
      ci += mi_offsets;
      put64(ci, pos - mi_start);                    // message_index_length
      putStr(ci, opt.compression, path);            // compression
      put64(ci, csize);                             // compressed_size
      put64(ci, usize);                             // uncompressed_size
      chunk_indexes.push_back(record(kChunkIndex, ci));
    }
    chunk.clear();
    chunk_has_messages = false;
  }

  void finish() {
    if (opt.chunked) flushChunk();
    // Data End (op=0x0F): CRC32 of every byte before this record
    const uint32_t data_crc = opt.crc ? crc : 0;
    std::string de;
    put32(de, data_crc);
    crc_on = false;
    out(record(kDataEnd, de));

    uint64_t summary_start = 0, summary_offset_start = 0;
    crc = 0;
    crc_on = opt.crc && opt.summary;
    if (opt.summary) {
      summary_start = pos;
      std::vector<std::pair<uint8_t, std::pair<uint64_t, uint64_t>>> groups;  // opcode, start, length
      auto group = [&](uint8_t op, const std::vector<std::string>& recs) {
        if (recs.empty()) return;
        const uint64_t g = pos;
        for (const auto& r : recs) out(r);
        groups.push_back({op, {g, pos - g}});
      };
      group(kSchema, schema_records);  // Schema (op=0x03) copies
      std::vector<std::string> chans;
      for (const auto& c : channels) chans.push_back(c.record);
      group(kChannel, chans);          // Channel (op=0x04) copies
      // Statistics (op=0x0B)
      std::string st;
      put64(st, message_count);                                   // message_count
      put16(st, static_cast<uint16_t>(schema_records.size()));   // schema_count
      put32(st, static_cast<uint32_t>(channels.size()));         // channel_count
      put32(st, 0);                                               // attachment_count
      put32(st, 0);                                               // metadata_count
      put32(st, chunk_count);                                     // chunk_count
      put64(st, message_count ? start : 0);                       // message_start_time
      put64(st, message_count ? end : 0);                         // message_end_time
      std::string counts;                                         // channel_message_counts (channels with messages)
      for (size_t c = 0; c < channels.size(); ++c)
        if (channels[c].count) {
          put16(counts, static_cast<uint16_t>(c + 1));
          put64(counts, channels[c].count);
        }
      put32(st, len32(path, counts.size(), "statistics"));
      st += counts;
      group(kStatistics, {record(kStatistics, st)});
      group(kChunkIndex, chunk_indexes);  // Chunk Index (op=0x08) records
      if (opt.summary_offsets && !groups.empty()) {
        // Summary Offset (op=0x0E): group_opcode, group_start, group_length
        summary_offset_start = pos;
        for (const auto& g : groups) {
          std::string so;
          put8(so, g.first);
          put64(so, g.second.first);
          put64(so, g.second.second);
          out(record(kSummaryOffset, so));
        }
      }
    }
    // Footer (op=0x02): summary_start, summary_offset_start, summary_crc (CRC32 from the summary start through
    // summary_offset_start, this record's opcode and length included)
    std::string ft;
    put8(ft, kFooter);
    put64(ft, 8 + 8 + 4);
    put64(ft, summary_start);
    put64(ft, summary_offset_start);
    out(ft);
    std::string tail;
    put32(tail, crc_on ? crc : 0);
    crc_on = false;
    tail.append(kMagic, 8);
    out(tail);
    flushOut();
    closeOutput(file, path);
  }
};

McapWriter::McapWriter(const std::string& path, const McapWriteOptions& options) : impl_(new Impl) {
  Impl& m = *impl_;
  m.path = path;
  m.opt = options;
  if (m.opt.compression != "zstd" && m.opt.compression != "lz4" && !m.opt.compression.empty())
    fail(path, "unknown MCAP chunk compression \"" + m.opt.compression + "\" (zstd, lz4 or none)");
  if (!m.opt.chunked) m.opt.compression.clear();
  m.file.reset(std::fopen(path.c_str(), "wb"));
  if (!m.file) fail(path, "cannot create: " + errnoText());
  std::setvbuf(m.file.get(), nullptr, _IONBF, 0);
  m.obuf.reserve(Impl::kOutBuffer);
  if (m.opt.chunked) m.chunk.reserve(std::min<size_t>(m.opt.chunk_size, 64 << 20) + 64 * 1024);
  m.crc_on = m.opt.crc;
  m.out(kMagic, 8);
  // Header (op=0x01): profile, library
  std::string h;
  putStr(h, m.opt.profile, path);
  putStr(h, m.opt.library, path);
  m.out(record(kHeader, h));
}

McapWriter::~McapWriter() {
  if (impl_ && !impl_->closed && !impl_->failed) {
    try {
      close();
    } catch (...) {
    }
  }
}

int McapWriter::addTopic(const WriterTopic& t) {
  Impl& m = *impl_;
  if (m.closed || m.failed) fail(m.path, "addTopic after close or a write error");
  for (size_t c = 0; c < m.channels.size(); ++c)
    if (m.channels[c].topic == t.name) {
      if (m.channels[c].type != t.type)
        fail(m.path, "topic " + t.name + " declared again with another type (" + t.type + ")");
      return static_cast<int>(c + 1);
    }
  if (m.channels.size() >= 65535) fail(m.path, "more than 65535 topics");
  try {
    auto it = m.schema_ids.find(t.type);
    if (it == m.schema_ids.end()) {
      // Schema (op=0x03): id, name, encoding, data (uint32-length bytes); no definition: encoding "" like rosbag2
      const uint16_t id = static_cast<uint16_t>(m.schema_records.size() + 1);
      std::string s;
      put16(s, id);
      putStr(s, t.type, m.path);
      putStr(s, t.definition.empty() ? std::string() : std::string("ros2msg"), m.path);
      putStr(s, t.definition, m.path);
      m.schema_records.push_back(record(kSchema, s));
      it = m.schema_ids.emplace(t.type, id).first;
      m.data(m.schema_records.back());
    }
    // Channel (op=0x04): id, schema_id, topic, message_encoding, metadata Map<string, string>
    const uint16_t id = static_cast<uint16_t>(m.channels.size() + 1);
    std::string c, meta;
    put16(c, id);
    put16(c, it->second);
    putStr(c, t.name, m.path);
    putStr(c, t.serialization_format, m.path);
    putStr(meta, "offered_qos_profiles", m.path);
    putStr(meta, "", m.path);
    putStr(meta, "topic_type_hash", m.path);
    putStr(meta, "", m.path);
    put32(c, static_cast<uint32_t>(meta.size()));
    c += meta;
    m.channels.push_back({it->second, t.name, t.type, record(kChannel, c)});
    m.chunk_entries.emplace_back();
    m.data(m.channels.back().record);
    return id;
  } catch (...) {
    m.failed = true;
    throw;
  }
}

void McapWriter::write(int topic, int64_t log_ns, int64_t publish_ns, const void* data, size_t size) {
  Impl& m = *impl_;
  if (m.closed || m.failed) fail(m.path, "write after close or a write error");
  if (topic < 1 || static_cast<size_t>(topic) > m.channels.size())
    fail(m.path, "write to undeclared topic id " + std::to_string(topic));
  if (log_ns < 0 || publish_ns < 0)
    fail(m.path, "negative message time " + std::to_string(std::min(log_ns, publish_ns)));
  try {
    // Message (op=0x05): channel_id, sequence (0, as rosbag2), log_time, publish_time, data to the end
    char h[9 + 2 + 4 + 8 + 8];
    h[0] = static_cast<char>(kMessage);
    store64(h + 1, uint64_t(2 + 4 + 8 + 8) + size);
    store16(h + 9, static_cast<uint16_t>(topic));
    store32(h + 11, 0);
    store64(h + 15, static_cast<uint64_t>(log_ns));
    store64(h + 23, static_cast<uint64_t>(publish_ns));
    const uint64_t t = static_cast<uint64_t>(log_ns);
    if (m.opt.chunked) {
      if (!m.chunk_has_messages) {
        m.chunk_start = m.chunk_end = t;
        m.chunk_has_messages = true;
      }
      m.chunk_start = std::min(m.chunk_start, t);
      m.chunk_end = std::max(m.chunk_end, t);
      if (m.opt.message_indexes) m.chunk_entries[topic - 1].emplace_back(t, m.chunk.size());
      m.chunk.append(h, sizeof h);
      if (size) m.chunk.append(static_cast<const char*>(data), size);
    } else {
      m.out(h, sizeof h);
      m.out(data, size);
    }
    if (m.message_count == 0) m.start = m.end = t;
    m.start = std::min(m.start, t);
    m.end = std::max(m.end, t);
    ++m.message_count;
    ++m.channels[topic - 1].count;
    if (m.opt.chunked && m.chunk.size() >= m.opt.chunk_size) m.flushChunk();
  } catch (...) {
    m.failed = true;
    throw;
  }
}

void McapWriter::close() {
  Impl& m = *impl_;
  if (m.closed) return;
  if (m.failed) fail(m.path, "close after a write error");
  try {
    m.finish();
    m.closed = true;
  } catch (...) {
    m.failed = true;
    throw;
  }
}

// ==== rosbag2 sqlite3 =============================================================================================

struct SqliteWriter::Impl {
  std::string path;
  int version = 4;
  sqlite3* db = nullptr;
  sqlite3_stmt* insert_message = nullptr;
  std::map<std::string, std::pair<int, std::string>> topic_ids;  // name -> topics.id, type
  std::set<std::string> definitions;           // types in message_definitions
  bool closed = false, failed = false;

  ~Impl() {
    sqlite3_finalize(insert_message);
    if (db) sqlite3_close(db);
  }
  [[noreturn]] void sqlFail(const std::string& what) {
    failed = true;
    fail(path, what + ": " + (db ? sqlite3_errmsg(db) : "sqlite3 error"));
  }
  void exec(const std::string& sql) {
    if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr) != SQLITE_OK) sqlFail(sql.substr(0, 40));
  }
  struct Stmt {
    sqlite3_stmt* s = nullptr;
    ~Stmt() { sqlite3_finalize(s); }
  };
  void prepare(Stmt& st, const char* sql) {
    if (sqlite3_prepare_v2(db, sql, -1, &st.s, nullptr) != SQLITE_OK) sqlFail("prepare");
  }
  void text(sqlite3_stmt* s, int i, const std::string& v) {
    if (sqlite3_bind_text64(s, i, v.data(), v.size(), SQLITE_TRANSIENT, SQLITE_UTF8) != SQLITE_OK) sqlFail("bind");
  }
  void step(sqlite3_stmt* s, const char* what) {
    if (sqlite3_step(s) != SQLITE_DONE) sqlFail(what);
    sqlite3_reset(s);
  }
};

SqliteWriter::SqliteWriter(const std::string& path, int schema_version, const std::string& ros_distro)
    : impl_(new Impl) {
  Impl& s = *impl_;
  s.path = path;
  s.version = schema_version;
  if (schema_version < 1 || schema_version > 4)
    fail(path, "unsupported rosbag2 sqlite3 schema version " + std::to_string(schema_version) + " (1-4)");
  struct stat st;
  if (::stat(path.c_str(), &st) == 0) {  // a new file, as rosbag2 writes (no appending)
    if (!S_ISREG(st.st_mode)) fail(path, "exists and is not a regular file");
    if (std::remove(path.c_str()) != 0) fail(path, "cannot replace: " + errnoText());
  }
  std::remove((path + "-journal").c_str());
  // a private connection, used by one thread at a time: no sqlite mutexes
  if (sqlite3_open_v2(path.c_str(), &s.db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX,
                      nullptr) != SQLITE_OK)
    s.sqlFail("cannot create");
  // speed only (none is stored in the file: once closed it is journal_mode=delete, page size 4096, as rosbag2's)
  s.exec("PRAGMA journal_mode=MEMORY;");
  s.exec("PRAGMA synchronous=OFF;");
  s.exec("PRAGMA cache_size=-65536;");
  s.exec("BEGIN TRANSACTION;");
  // the tables as rosbag2_storage_sqlite3 creates them (same SQL text)
  if (schema_version >= 3) {
    s.exec("CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL);");
    s.exec("CREATE TABLE metadata(id INTEGER PRIMARY KEY,metadata_version INTEGER NOT NULL,metadata TEXT NOT NULL);");
  }
  std::string topics = "CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
                       "serialization_format TEXT NOT NULL";
  if (schema_version >= 2) topics += ",offered_qos_profiles TEXT NOT NULL";
  if (schema_version >= 4) topics += ",type_description_hash TEXT NOT NULL";
  s.exec(topics + ");");
  if (schema_version >= 4)
    s.exec("CREATE TABLE message_definitions(id INTEGER PRIMARY KEY,topic_type TEXT NOT NULL,encoding TEXT NOT NULL,"
           "encoded_message_definition TEXT NOT NULL,type_description_hash TEXT NOT NULL);");
  s.exec("CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,timestamp INTEGER NOT NULL, "
         "data BLOB NOT NULL);");
  // timestamp_idx is created in close(): one sort instead of a B-tree update per message, and still the last entry
  // of sqlite_master as in rosbag2's files
  if (schema_version >= 3) {
    Impl::Stmt ins;
    s.prepare(ins, "INSERT INTO schema (schema_version, ros_distro) VALUES (?, ?)");
    sqlite3_bind_int(ins.s, 1, schema_version);
    s.text(ins.s, 2, ros_distro);
    s.step(ins.s, "insert schema");
  }
  if (sqlite3_prepare_v2(s.db, "INSERT INTO messages (timestamp, topic_id, data) VALUES (?, ?, ?);", -1,
                         &s.insert_message, nullptr) != SQLITE_OK)
    s.sqlFail("prepare");
}

SqliteWriter::~SqliteWriter() {
  if (impl_ && !impl_->closed && !impl_->failed) {
    try {
      close();
    } catch (...) {
    }
  }
}

int SqliteWriter::addTopic(const WriterTopic& t) {
  Impl& s = *impl_;
  if (s.closed || s.failed) fail(s.path, "addTopic after close or a write error");
  auto it = s.topic_ids.find(t.name);
  if (it != s.topic_ids.end()) {
    if (it->second.second != t.type)
      fail(s.path, "topic " + t.name + " declared again with another type (" + t.type + ")");
    return it->second.first;
  }
  Impl::Stmt ins;
  if (s.version >= 4)
    s.prepare(ins, "INSERT INTO topics(name, type, serialization_format, offered_qos_profiles, type_description_hash) "
                   "VALUES (?, ?, ?, ?, ?)");
  else if (s.version >= 2)
    s.prepare(ins, "INSERT INTO topics(name, type, serialization_format, offered_qos_profiles) VALUES (?, ?, ?, ?)");
  else
    s.prepare(ins, "INSERT INTO topics(name, type, serialization_format) VALUES (?, ?, ?)");
  s.text(ins.s, 1, t.name);
  s.text(ins.s, 2, t.type);
  s.text(ins.s, 3, t.serialization_format);
  if (s.version >= 2) s.text(ins.s, 4, "");
  if (s.version >= 4) s.text(ins.s, 5, "");
  s.step(ins.s, "insert topic");
  const int id = static_cast<int>(sqlite3_last_insert_rowid(s.db));
  s.topic_ids.emplace(t.name, std::make_pair(id, t.type));
  if (s.version >= 4 && !t.type.empty() && !s.definitions.count(t.type)) {
    Impl::Stmt def;
    s.prepare(def, "INSERT INTO message_definitions (topic_type, encoding, encoded_message_definition, "
                   "type_description_hash) VALUES (?, ?, ?, ?)");
    s.text(def.s, 1, t.type);
    s.text(def.s, 2, t.definition.empty() ? "" : "ros2msg");  // no definition: encoding "" as rosbag2
    s.text(def.s, 3, t.definition);
    s.text(def.s, 4, "");
    s.step(def.s, "insert message definition");
    s.definitions.insert(t.type);
  }
  return id;
}

void SqliteWriter::write(int topic, int64_t recv_ns, const void* data, size_t size) {
  Impl& s = *impl_;
  if (s.closed || s.failed) fail(s.path, "write after close or a write error");
  if (topic < 1 || static_cast<size_t>(topic) > s.topic_ids.size())
    fail(s.path, "write to undeclared topic id " + std::to_string(topic));
  sqlite3_stmt* st = s.insert_message;
  static const char empty = 0;  // a zero-length blob, not NULL
  sqlite3_bind_int64(st, 1, recv_ns);
  sqlite3_bind_int(st, 2, topic);
  if (sqlite3_bind_blob64(st, 3, size ? data : &empty, size, SQLITE_STATIC) != SQLITE_OK) s.sqlFail("bind");
  if (sqlite3_step(st) != SQLITE_DONE) {
    sqlite3_reset(st);
    s.sqlFail("insert message");
  }
  sqlite3_reset(st);
}

void SqliteWriter::close(const std::string& metadata_yaml) {
  Impl& s = *impl_;
  if (s.closed) return;
  if (s.failed) fail(s.path, "close after a write error");
  if (s.version >= 3 && !metadata_yaml.empty()) {
    // the metadata table holds BagMetadata itself (no rosbag2_bagfile_information key): strip it when given
    std::string text = metadata_yaml;
    const std::string top = "rosbag2_bagfile_information:\n";
    if (text.compare(0, top.size(), top) == 0) {
      std::string body;
      size_t i = top.size();
      while (i < text.size()) {
        size_t e = text.find('\n', i);
        if (e == std::string::npos) e = text.size();
        std::string line = text.substr(i, e - i);
        body += line.compare(0, 2, "  ") == 0 ? line.substr(2) : line;
        body += '\n';
        i = e + 1;
      }
      text = body;
    }
    int mversion = -1;
    for (size_t i = 0; i < text.size();) {
      size_t e = text.find('\n', i);
      if (e == std::string::npos) e = text.size();
      if (text.compare(i, 8, "version:") == 0) mversion = std::atoi(text.c_str() + i + 8);
      i = e + 1;
    }
    if (mversion < 0) {
      s.failed = true;
      fail(s.path, "metadata text has no top-level version");
    }
    Impl::Stmt ins;
    s.prepare(ins, "INSERT INTO metadata (metadata_version, metadata) VALUES (?, ?)");
    sqlite3_bind_int(ins.s, 1, mversion);
    s.text(ins.s, 2, text);
    s.step(ins.s, "insert metadata");
  }
  s.exec("CREATE INDEX timestamp_idx ON messages (timestamp ASC);");
  s.exec("COMMIT;");
  sqlite3_finalize(s.insert_message);
  s.insert_message = nullptr;
  const int rc = sqlite3_close(s.db);
  if (rc != SQLITE_OK) s.sqlFail("close");
  s.db = nullptr;
  s.closed = true;
}

// ==== metadata.yaml ===============================================================================================

namespace {

/// A YAML scalar: plain when unambiguous (e.g. /imu/data, sensor_msgs/msg/Imu), else double-quoted.
std::string yamlStr(const std::string& s) {
  bool plain = !s.empty() && (std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '/' || s[0] == '_');
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/' || c == '.' || c == '-')) plain = false;
  if (plain) {
    std::string l;
    for (char c : s) l += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    for (const char* k : {"y", "n", "yes", "no", "true", "false", "on", "off", "null"})
      if (l == k) plain = false;
  }
  if (plain) return s;
  std::string q = "\"";
  for (unsigned char c : s) {
    if (c == '"' || c == '\\') {
      q += '\\';
      q += static_cast<char>(c);
    } else if (c == '\n') {
      q += "\\n";
    } else if (c == '\t') {
      q += "\\t";
    } else if (c < 0x20 || c == 0x7f) {
      char b[8];
      std::snprintf(b, sizeof b, "\\x%02x", c);
      q += b;
    } else {
      q += static_cast<char>(c);
    }
  }
  return q + "\"";
}

}  // namespace

std::string metadataYaml(const BagMetadata& m) {
  const int v = m.version;
  if (v < 3 || v > 9) fail("metadata.yaml", "unsupported metadata version " + std::to_string(v) + " (3-9)");
  std::string y = "rosbag2_bagfile_information:\n";
  auto line = [&](int indent, const std::string& text) {
    y.append(indent, ' ');
    y += text;
    y += '\n';
  };
  line(2, "version: " + std::to_string(v));
  line(2, "storage_identifier: " + yamlStr(m.storage_identifier));
  line(2, "duration:");
  line(4, "nanoseconds: " + std::to_string(m.duration_ns));
  line(2, "starting_time:");
  line(4, "nanoseconds_since_epoch: " + std::to_string(m.starting_time_ns));
  line(2, "message_count: " + std::to_string(m.message_count));
  if (m.topics.empty()) {
    line(2, "topics_with_message_count: []");
  } else {
    line(2, "topics_with_message_count:");
    for (const auto& t : m.topics) {
      line(4, "- topic_metadata:");
      line(8, "name: " + yamlStr(t.topic.name));
      line(8, "type: " + yamlStr(t.topic.type));
      line(8, "serialization_format: " + yamlStr(t.topic.serialization_format));
      if (v >= 9)
        line(8, "offered_qos_profiles: []");
      else if (v >= 4)
        line(8, "offered_qos_profiles: \"\"");
      if (v >= 7) line(8, "type_description_hash: \"\"");
      line(6, "message_count: " + std::to_string(t.message_count));
    }
  }
  line(2, "compression_format: " + yamlStr(m.compression_format));
  line(2, "compression_mode: " + yamlStr(m.compression_mode));
  if (m.relative_file_paths.empty()) {
    line(2, "relative_file_paths: []");
  } else {
    line(2, "relative_file_paths:");
    for (const auto& p : m.relative_file_paths) line(4, "- " + yamlStr(p));
  }
  if (v >= 5) {
    if (m.files.empty()) {
      line(2, "files: []");
    } else {
      line(2, "files:");
      for (const auto& f : m.files) {
        line(4, "- path: " + yamlStr(f.path));
        line(6, "starting_time:");
        line(8, "nanoseconds_since_epoch: " + std::to_string(f.starting_time_ns));
        line(6, "duration:");
        line(8, "nanoseconds: " + std::to_string(f.duration_ns));
        line(6, "message_count: " + std::to_string(f.message_count));
      }
    }
  }
  if (v >= 6) line(2, "custom_data: {}");
  if (v >= 8) line(2, "ros_distro: " + yamlStr(m.ros_distro));
  return y;
}

// ==== zstd ========================================================================================================

std::string zstdCompress(const void* data, size_t size, int level) {
  std::string out(ZSTD_compressBound(size), '\0');
  const size_t r = ZSTD_compress(&out[0], out.size(), data, size, level);  // one frame, content size in its header
  if (ZSTD_isError(r)) throw WriteError(std::string("zstdCompress: ") + ZSTD_getErrorName(r));
  out.resize(r);
  return out;
}

void zstdCompressFile(const std::string& from, const std::string& to) {
  FilePtr in(std::fopen(from.c_str(), "rb"));
  if (!in) fail(from, "cannot open: " + errnoText());
  struct stat st;
  const bool sized = ::fstat(fileno(in.get()), &st) == 0 && S_ISREG(st.st_mode);
  FilePtr out(std::fopen(to.c_str(), "wb"));
  if (!out) fail(to, "cannot create: " + errnoText());
  struct stat ost;
  bool ok = false;
  const bool regular = ::fstat(fileno(out.get()), &ost) == 0 && S_ISREG(ost.st_mode);
  struct Cleanup {  // a failed compression leaves no partial output file (never removes a device such as /dev/full)
    const std::string& path;
    FilePtr& f;
    const bool& ok;
    bool regular;
    ~Cleanup() {
      if (!ok) {
        f.reset();
        if (regular) std::remove(path.c_str());
      }
    }
  } cleanup{to, out, ok, regular};
  std::unique_ptr<ZSTD_CCtx, size_t (*)(ZSTD_CCtx*)> cctx(ZSTD_createCCtx(), ZSTD_freeCCtx);
  if (!cctx) fail(to, "zstd: out of memory");
  ZSTD_CCtx_setParameter(cctx.get(), ZSTD_c_compressionLevel, 1);  // rosbag2_compression_zstd's level
  if (sized) ZSTD_CCtx_setPledgedSrcSize(cctx.get(), static_cast<unsigned long long>(st.st_size));
  std::vector<char> ibuf(ZSTD_CStreamInSize()), obuf(ZSTD_CStreamOutSize());
  for (;;) {
    const size_t n = std::fread(ibuf.data(), 1, ibuf.size(), in.get());
    if (n < ibuf.size() && std::ferror(in.get())) fail(from, "read failed: " + errnoText());
    const bool last = n < ibuf.size();
    ZSTD_inBuffer ib{ibuf.data(), n, 0};
    for (;;) {
      ZSTD_outBuffer ob{obuf.data(), obuf.size(), 0};
      const size_t r = ZSTD_compressStream2(cctx.get(), &ob, &ib, last ? ZSTD_e_end : ZSTD_e_continue);
      if (ZSTD_isError(r))
        fail(to, std::string("zstd: ") + ZSTD_getErrorName(r) + (sized ? " (did " + from + " change size?)" : ""));
      if (ob.pos && std::fwrite(obuf.data(), 1, ob.pos, out.get()) != ob.pos) fail(to, "write failed: " + errnoText());
      if (last ? r == 0 : ib.pos == ib.size) break;
    }
    if (last) break;
  }
  closeOutput(out, to);
  ok = true;
}

}  // namespace rosbag2
}  // namespace gyro_allan
