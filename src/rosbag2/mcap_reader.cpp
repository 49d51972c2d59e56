// MCAP storage reader (mcap.dev specification, major version 0): topics and messages in log-time order, chunk by
// chunk, via the summary's chunk indexes where present and by a scan of the data section where not.
//
// A file is <magic><Header><data section>[<summary>][<summary offsets>]<Footer><magic>, every record being
// <opcode u8><length u64 LE><content>. Messages are in Chunk records (compressed "zstd", "lz4" frame, or "")
// or, without chunking (rosbag2's "fastwrite" preset), straight in the data section. What is read here:
//   - the Footer: summary_start (0 = no summary) and the summary CRC, checked when not 0;
//   - the summary's Schema, Channel, Chunk Index and Statistics records; with Chunk Index records the file is
//     "indexed": each chunk is located, and skipped when its message-index map shows no wanted channel;
//   - without them, the data section record by record: Schema/Channel records (inside chunks too when the file
//     has no summary), Chunk headers, and runs of Message records outside chunks.
// Chunks (and runs) are read in order of their earliest log time; the messages of those whose time ranges overlap
// are merged, so the output is in log-time order with ties in file order, while memory holds only the chunks
// being merged (usually one), decompressed and CRC-checked a few chunks ahead on a second thread. Each chunk's
// uncompressed_crc is checked when not 0.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include <lz4frame.h>
#include <zstd.h>

#include "crc32.hpp"
#include "gyro_allan/rosbag2/storage.hpp"

namespace gyro_allan {
namespace rosbag2 {
namespace {

const uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};
enum Op : uint8_t {
  kHeader = 0x01, kFooter = 0x02, kSchema = 0x03, kChannel = 0x04, kMessage = 0x05, kChunk = 0x06,
  kChunkIndex = 0x08, kStatistics = 0x0b, kDataEnd = 0x0f
};
constexpr uint64_t kMaxChunk = 256ull << 20;  // a corrupt size must not allocate gigabytes
constexpr size_t kRunBytes = 4u << 20;         // messages outside chunks are read in runs of about this size

/// Little-endian fields of one record's content, every read bounds-checked.
class Cursor {
 public:
  Cursor(const uint8_t* p, size_t n, const std::string* file) : p_(p), n_(n), file_(file) {}
  uint8_t u8() { return static_cast<uint8_t>(take(1)[0]); }
  uint16_t u16() { return static_cast<uint16_t>(le(take(2), 2)); }
  uint32_t u32() { return static_cast<uint32_t>(le(take(4), 4)); }
  uint64_t u64() { return le(take(8), 8); }
  std::string str() {
    const uint32_t len = u32();
    const uint8_t* s = take(len);
    return std::string(reinterpret_cast<const char*>(s), len);
  }
  /// A u32-length-prefixed block (bytes, map, array) as its own cursor.
  Cursor block32() {
    const uint32_t len = u32();
    return Cursor(take(len), len, file_);
  }
  void skip(size_t k) { take(k); }
  bool done() const { return pos_ >= n_; }
  const uint8_t* here() const { return p_ + pos_; }
  const uint8_t* end() const { return p_ + n_; }
  static uint64_t le(const uint8_t* b, int k) {
    uint64_t v = 0;
    for (int i = k - 1; i >= 0; --i) v = (v << 8) | b[i];
    return v;
  }

 private:
  const uint8_t* take(size_t k) {
    if (k > n_ - pos_) throw FormatError(*file_ + ": damaged MCAP file (a record's field runs past its end)");
    const uint8_t* at = p_ + pos_;
    pos_ += k;
    return at;
  }
  const uint8_t* p_;
  size_t n_;
  size_t pos_ = 0;
  const std::string* file_;
};

class FileReader {
 public:
  explicit FileReader(const std::string& path) : path_(path) {
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) throw FormatError("cannot open '" + path + "': " + std::strerror(errno));
    struct stat st {};
    if (fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
      ::close(fd_);
      throw FormatError("'" + path + "' is not a regular file");
    }
    size_ = static_cast<uint64_t>(st.st_size);
  }
  ~FileReader() { ::close(fd_); }
  FileReader(const FileReader&) = delete;
  FileReader& operator=(const FileReader&) = delete;
  uint64_t size() const { return size_; }
  void read(uint64_t at, size_t n, uint8_t* out) const {
    if (at > size_ || n > size_ - at) truncated();
    size_t done = 0;
    while (done < n) {
      const ssize_t k = ::pread(fd_, out + done, n - done, static_cast<off_t>(at + done));
      if (k <= 0) throw FormatError("cannot read '" + path_ + "'" + (k < 0 ? std::string(": ") + std::strerror(errno) : ""));
      done += static_cast<size_t>(k);
    }
  }
  [[noreturn]] void truncated() const {
    throw FormatError(path_ + ": truncated MCAP file (a record runs past the end of the file)");
  }

 private:
  std::string path_;
  int fd_ = -1;
  uint64_t size_ = 0;
};

/// Sequential reads of a file through a window (the scan of the data section reads many small record headers).
class Window {
 public:
  explicit Window(const FileReader& f) : f_(f) {}
  /// The bytes [at, at + n) of the file.
  const uint8_t* get(uint64_t at, size_t n) {
    if (at < begin_ || at + n > begin_ + buf_.size()) {
      if (at > f_.size() || n > f_.size() - at) f_.truncated();
      const size_t want = static_cast<size_t>(std::min<uint64_t>(f_.size() - at, std::max<size_t>(n, 1u << 20)));
      buf_.resize(want);
      f_.read(at, want, buf_.data());
      begin_ = at;
    }
    return buf_.data() + (at - begin_);
  }

 private:
  const FileReader& f_;
  std::vector<uint8_t> buf_;
  uint64_t begin_ = 0;
};

/// A stretch of the data section read as one: a Chunk, or a run of Message records outside chunks.
struct Unit {
  bool chunk = false;
  uint64_t offset = 0;           // chunk: its records field; run: its first record
  uint64_t length = 0;           // bytes at offset (chunk: compressed)
  uint64_t uncompressed = 0;
  uint32_t crc = 0;
  std::string compression;
  int64_t start = 0, end = 0;    // earliest and latest log time
  std::vector<uint16_t> channels;  // channels with messages in it; empty = not known
  bool channels_known = false;
};

struct Channel {
  std::string topic;
  uint16_t schema = 0;
  std::string encoding;
  size_t topic_index = 0;
};

/// One message of a loaded unit waiting to be passed on.
struct Pending {
  int64_t t;
  uint32_t at, size;  // data offset and size in the unit's buffer
  uint16_t channel;
};

struct Loaded {
  std::vector<uint8_t> buf;
  std::vector<Pending> msgs;  // wanted messages in log-time order (ties in record order)
  size_t next = 0;
};

/// Loads units 0, 1, ... (decompresses, CRC-checks and indexes them) on a thread of its own, at most kAhead ahead of
/// the caller's take(k), handed over in order: the two halves of reading a chunk, about equal in cost, overlap. A
/// load's exception is rethrown by the take of that unit; the destructor stops and joins.
class Prefetch {
 public:
  using LoadFn = std::function<void(size_t, Loaded*)>;
  Prefetch(size_t n, LoadFn load) : n_(n), load_(std::move(load)) {
    try {
      if (n > 0) threads_.emplace_back([this] { run(); });
    } catch (...) {  // no thread to be had: the caller loads each unit itself
      stopAndJoin();
      threads_.clear();
    }
  }
  ~Prefetch() { stopAndJoin(); }
  Prefetch(const Prefetch&) = delete;
  Prefetch& operator=(const Prefetch&) = delete;
  /// A buffer the caller is done with, for a later unit (a reused buffer is not zeroed and faulted in again).
  void recycle(std::vector<uint8_t>&& buf) {
    std::lock_guard<std::mutex> lock(m_);
    if (spare_.size() < kAhead + 2) spare_.push_back(std::move(buf));
  }
  std::unique_ptr<Loaded> take(size_t k) {
    if (threads_.empty()) {
      auto l = std::make_unique<Loaded>();
      load_(k, l.get());
      return l;
    }
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [&] { return ready_.count(k) > 0; });
    Slot s = std::move(ready_[k]);
    ready_.erase(k);
    taken_ = k + 1;
    cv_.notify_all();
    if (s.error) std::rethrow_exception(s.error);
    return std::move(s.unit);
  }

 private:
  static constexpr size_t kAhead = 4;
  struct Slot {
    std::unique_ptr<Loaded> unit;
    std::exception_ptr error;
  };
  void stopAndJoin() {
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    cv_.notify_all();
    for (auto& t : threads_)
      if (t.joinable()) t.join();
  }
  void run() {
    for (;;) {
      Slot s;
      size_t k;
      {
        std::unique_lock<std::mutex> lock(m_);
        cv_.wait(lock, [&] { return stop_ || failed_ || next_ >= n_ || next_ < taken_ + kAhead; });
        if (stop_ || failed_ || next_ >= n_) return;
        k = next_++;
        s.unit = std::make_unique<Loaded>();
        if (!spare_.empty()) {
          s.unit->buf.swap(spare_.back());
          spare_.pop_back();
        }
      }
      try {
        load_(k, s.unit.get());
      } catch (...) {
        s.error = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(m_);
      if (s.error) failed_ = true;  // nothing after a failed unit is wanted
      ready_[k] = std::move(s);
      cv_.notify_all();
    }
  }
  size_t n_;
  LoadFn load_;
  std::mutex m_;
  std::condition_variable cv_;
  std::map<size_t, Slot> ready_;
  std::vector<std::vector<uint8_t>> spare_;
  size_t next_ = 0, taken_ = 0;
  bool stop_ = false, failed_ = false;
  std::vector<std::thread> threads_;  // last: started once every other member exists
};

class McapStorage : public Storage {
 public:
  explicit McapStorage(const std::string& path) : file_(path) {
    path_ = path;
    uint8_t magic[8];
    if (file_.size() < 8) throw FormatError(path + ": not an MCAP file (" + std::to_string(file_.size()) + " bytes)");
    file_.read(0, 8, magic);
    if (std::memcmp(magic, kMagic, 8) != 0) throw FormatError(path + ": not an MCAP file (no MCAP magic at its start)");
    readHeader();
    readFooter();
    if (!indexed_) scan();
    buildTopics();
  }

  std::string kind() const override { return "mcap"; }

  std::string describe() const override {
    size_t chunks = 0;
    std::map<std::string, size_t> comp;
    for (const auto& u : units_)
      if (u.chunk) ++chunks, ++comp[u.compression.empty() ? "uncompressed" : u.compression];
    std::string s = "mcap (profile '" + profile_ + "'), ";
    if (chunks == 0) {
      s += "no chunks";
    } else {
      s += std::to_string(chunks) + " chunks (";
      bool first = true;
      for (const auto& kv : comp) s += (first ? "" : ", ") + kv.first, first = false;
      s += ")";
    }
    s += indexed_ ? ", indexed" : have_summary_ ? ", summary without chunk index" : ", no summary";
    return s;
  }

  int64_t startNs() override {
    if (have_stats_ && stats_messages_ > 0) return stats_start_;
    int64_t t = 0;
    bool any = false;
    for (const auto& u : units_)
      if (!any || u.start < t) t = u.start, any = true;
    return any ? t : 0;
  }

  std::vector<int64_t> messageCounts() override {
    std::vector<int64_t> counts(topics_.size(), 0);
    if (have_stats_ && !stats_counts_.empty()) {
      for (const auto& kv : stats_counts_) {
        const auto c = channels_.find(kv.first);
        if (c != channels_.end()) counts[c->second.topic_index] += static_cast<int64_t>(kv.second);
      }
      return counts;
    }
    read(std::vector<bool>(topics_.size(), true), [&](const StoredMessage& m) { ++counts[m.topic]; });
    return counts;
  }

  void read(const std::vector<bool>& wanted, const std::function<void(const StoredMessage&)>& f) override {
    std::vector<bool> want_channel(65536, false);
    for (const auto& kv : channels_)
      if (kv.second.topic_index < wanted.size() && wanted[kv.second.topic_index]) want_channel[kv.first] = true;
    std::vector<const Unit*> order;
    for (const auto& u : units_) {
      if (u.channels_known) {
        bool any = false;
        for (uint16_t c : u.channels) any = any || want_channel[c];
        if (!any) continue;  // nothing wanted in it: not even read
      }
      order.push_back(&u);
    }
    std::stable_sort(order.begin(), order.end(), [](const Unit* a, const Unit* b) { return a->start < b->start; });
    std::vector<std::unique_ptr<Loaded>> open;
    std::function<void(std::vector<uint8_t>&&)> recycle;  // set once the prefetcher exists
    std::vector<size_t> topic_of(65536, 0);
    for (const auto& kv : channels_) topic_of[kv.first] = kv.second.topic_index;
    std::vector<uint64_t> delivered(65536, 0);
    auto emit = [&](const Loaded& l, const Pending& p) {
      StoredMessage m;
      m.topic = topic_of[p.channel];
      m.recv_ns = p.t;
      m.data = l.buf.data() + p.at;
      m.size = p.size;
      ++delivered[p.channel];
      f(m);
    };
    // Passes on, in log-time order, every message of the open units earlier than `limit` (all of them: `all`).
    auto emitBefore = [&](int64_t limit, bool all) {
      if (open.size() == 1) {  // the usual case: chunks that do not overlap
        Loaded& l = *open.front();
        while (l.next < l.msgs.size() && (all || l.msgs[l.next].t < limit)) emit(l, l.msgs[l.next++]);
      } else {
        for (;;) {
          Loaded* best = nullptr;
          for (auto& l : open) {
            if (l->next >= l->msgs.size()) continue;
            const Pending& p = l->msgs[l->next];
            if (!all && p.t >= limit) continue;
            if (!best || p.t < best->msgs[best->next].t) best = l.get();  // ties: the earlier unit (open is in rank order)
          }
          if (!best) break;
          emit(*best, best->msgs[best->next++]);
        }
      }
      for (auto& l : open)
        if (l->next >= l->msgs.size() && recycle) recycle(std::move(l->buf));
      open.erase(std::remove_if(open.begin(), open.end(),
                                [](const std::unique_ptr<Loaded>& l) { return l->next >= l->msgs.size(); }),
                 open.end());
    };
    // The units are decompressed, CRC-checked and indexed on a second thread, a few ahead of the merge here.
    Prefetch ahead(order.size(), [&](size_t k, Loaded* l) { load(*order[k], want_channel, l); });
    recycle = [&](std::vector<uint8_t>&& b) { ahead.recycle(std::move(b)); };
    for (size_t k = 0; k < order.size(); ++k) {
      emitBefore(order[k]->start, false);
      std::unique_ptr<Loaded> l = ahead.take(k);
      if (!l->msgs.empty()) open.push_back(std::move(l));
      else ahead.recycle(std::move(l->buf));
    }
    emitBefore(0, true);
    if (have_stats_ && !stats_counts_.empty())
      for (const auto& kv : channels_) {
        if (!want_channel[kv.first]) continue;
        const auto s = stats_counts_.find(kv.first);
        const uint64_t expect = s == stats_counts_.end() ? 0 : s->second;
        if (delivered[kv.first] != expect)
          throw FormatError(path_ + ": damaged MCAP file (its statistics count " + std::to_string(expect) +
                            " messages on " + kv.second.topic + ", its chunks hold " +
                            std::to_string(delivered[kv.first]) + ")");
      }
  }

 private:
  [[noreturn]] void damaged(const std::string& what) const {
    throw FormatError(path_ + ": damaged MCAP file (" + what + ")");
  }

  /// Opcode and content length of the record at `at`, checked against the file size.
  std::pair<uint8_t, uint64_t> recordAt(uint64_t at, Window* w = nullptr) const {
    uint8_t h[9];
    if (w)
      std::memcpy(h, w->get(at, 9), 9);
    else
      file_.read(at, 9, h);
    const uint64_t len = Cursor::le(h + 1, 8);
    if (len > file_.size() - at - 9) file_.truncated();
    return {h[0], len};
  }

  std::vector<uint8_t> content(uint64_t at, uint64_t len) const {
    if (len > kMaxChunk) damaged("a record of " + std::to_string(len) + " bytes");
    std::vector<uint8_t> b(static_cast<size_t>(len));
    file_.read(at, b.size(), b.data());
    return b;
  }

  void readHeader() {
    if (file_.size() < 8 + 9) file_.truncated();
    const auto rec = recordAt(8);
    if (rec.first != kHeader) damaged("the first record is not a Header");
    const auto b = content(8 + 9, rec.second);
    Cursor c(b.data(), b.size(), &path_);
    profile_ = c.str();
    data_start_ = 8 + 9 + rec.second;
  }

  void readFooter() {
    // Footer: opcode, length 20, summary_start u64, summary_offset_start u64, summary_crc u32; then the magic.
    const uint64_t kFooterSize = 1 + 8 + 20;
    if (file_.size() < data_start_ + kFooterSize + 8) {
      throw FormatError(path_ + ": truncated MCAP file (no footer: the recording did not finish; `ros2 bag reindex` "
                        "or `mcap recover` repairs it)");
    }
    uint8_t tail[kFooterSize + 8];
    const uint64_t footer_at = file_.size() - sizeof tail;
    file_.read(footer_at, sizeof tail, tail);
    if (std::memcmp(tail + kFooterSize, kMagic, 8) != 0 || tail[0] != kFooter || Cursor::le(tail + 1, 8) != 20)
      throw FormatError(path_ + ": truncated MCAP file (no footer: the recording did not finish; `ros2 bag reindex` "
                        "or `mcap recover` repairs it)");
    const uint64_t summary_start = Cursor::le(tail + 9, 8);
    const uint64_t summary_offset_start = Cursor::le(tail + 17, 8);
    const uint32_t summary_crc = static_cast<uint32_t>(Cursor::le(tail + 25, 4));
    data_end_ = footer_at;
    if (summary_start == 0) return;
    if (summary_start < data_start_ || summary_start > footer_at) damaged("summary offset outside the file");
    if (summary_offset_start != 0 && (summary_offset_start < summary_start || summary_offset_start > footer_at))
      damaged("summary-offset section outside the file");
    data_end_ = summary_start;
    const uint64_t summary_end = summary_offset_start ? summary_offset_start : footer_at;
    std::vector<uint8_t> s = content(summary_start, footer_at - summary_start);
    if (summary_crc != 0) {
      uint32_t crc = crc32Update(0, s.data(), s.size());
      crc = crc32Update(crc, tail, 1 + 8 + 8 + 8);  // the footer up to and including summary_offset_start
      if (crc != summary_crc) damaged("summary CRC mismatch");
    }
    have_summary_ = true;
    size_t chunk_indexes = 0;
    for (uint64_t at = 0; at < summary_end - summary_start;) {
      if (summary_end - summary_start - at < 9) damaged("a summary record runs past the summary");
      const uint8_t op = s[at];
      const uint64_t len = Cursor::le(&s[at + 1], 8);
      if (len > summary_end - summary_start - at - 9) damaged("a summary record runs past the summary");
      Cursor c(&s[at + 9], static_cast<size_t>(len), &path_);
      if (op == kSchema) {
        schema(&c);
      } else if (op == kChannel) {
        channel(&c);
      } else if (op == kChunkIndex) {
        Unit u;
        u.chunk = true;
        u.start = static_cast<int64_t>(c.u64());
        u.end = static_cast<int64_t>(c.u64());
        const uint64_t chunk_at = c.u64(), chunk_len = c.u64();
        Cursor idx = c.block32();
        while (!idx.done()) {
          u.channels.push_back(idx.u16());
          idx.u64();
        }
        u.channels_known = !u.channels.empty();
        c.u64();  // message_index_length
        u.compression = c.str();
        u.length = c.u64();
        u.uncompressed = c.u64();
        locateChunk(chunk_at, chunk_len, &u);
        units_.push_back(std::move(u));
        ++chunk_indexes;
      } else if (op == kStatistics) {
        have_stats_ = true;
        stats_messages_ = c.u64();
        c.u16();  // schema_count
        c.u32();  // channel_count
        c.u32();  // attachment_count
        c.u32();  // metadata_count
        c.u32();  // chunk_count
        stats_start_ = static_cast<int64_t>(c.u64());
        c.u64();  // message_end_time
        Cursor m = c.block32();
        while (!m.done()) {
          const uint16_t ch = m.u16();
          stats_counts_[ch] = m.u64();
        }
      }
      at += 9 + len;
    }
    indexed_ = chunk_indexes > 0;
  }

  /// A chunk index's chunk: its record header checked, and the records field located.
  void locateChunk(uint64_t at, uint64_t len, Unit* u) const {
    if (at < data_start_ || at >= data_end_ || len > data_end_ - at || len < 9) damaged("chunk index outside the data");
    const auto rec = recordAt(at);
    if (rec.first != kChunk || rec.second + 9 != len) damaged("a chunk index points to no chunk");
    uint8_t h[8 + 8 + 8 + 4 + 4];
    if (rec.second < sizeof h) damaged("chunk record too short");
    file_.read(at + 9, sizeof h, h);
    u->uncompressed = Cursor::le(h + 16, 8);
    u->crc = static_cast<uint32_t>(Cursor::le(h + 24, 4));
    const uint64_t comp_len = Cursor::le(h + 28, 4);
    const uint64_t records_len_at = at + 9 + sizeof h + comp_len;
    if (comp_len > rec.second - sizeof h || rec.second - sizeof h - comp_len < 8) damaged("chunk record too short");
    uint8_t l[8];
    file_.read(records_len_at, 8, l);
    const uint64_t records_len = Cursor::le(l, 8);
    if (records_len != at + 9 + rec.second - records_len_at - 8) damaged("chunk records length mismatch");
    u->offset = records_len_at + 8;
    u->length = records_len;
  }

  void schema(Cursor* c) {
    const uint16_t id = c->u16();
    schemas_[id] = c->str();  // name (the ROS 2 type for profile ros2)
  }

  void channel(Cursor* c) {
    Channel ch;
    const uint16_t id = c->u16();
    ch.schema = c->u16();
    ch.topic = c->str();
    ch.encoding = c->str();
    channels_[id] = ch;
  }

  /// The data section record by record (no chunk index): schemas and channels (also inside chunks when the file
  /// has no summary to list them), chunk headers, and runs of messages outside chunks.
  void scan() {
    Window w(file_);
    Unit run;
    bool in_run = false;
    auto closeRun = [&] {
      if (in_run) units_.push_back(std::move(run));
      run = Unit();
      in_run = false;
    };
    for (uint64_t at = data_start_; at < data_end_;) {
      if (data_end_ - at < 9) file_.truncated();
      const auto rec = recordAt(at, &w);
      const uint64_t body = at + 9;
      if (rec.first == kMessage) {
        if (rec.second < 22) damaged("message record too short");
        const uint8_t* m = w.get(body, 22);
        const uint16_t ch = static_cast<uint16_t>(Cursor::le(m, 2));
        const int64_t t = static_cast<int64_t>(Cursor::le(m + 6, 8));
        if (in_run && (at != run.offset + run.length || run.length >= kRunBytes)) closeRun();
        if (!in_run) {
          in_run = true;
          run.offset = at;
          run.start = run.end = t;
          run.channels_known = true;
        }
        run.length += 9 + rec.second;
        run.uncompressed = run.length;
        run.start = std::min(run.start, t);
        run.end = std::max(run.end, t);
        if (std::find(run.channels.begin(), run.channels.end(), ch) == run.channels.end()) run.channels.push_back(ch);
      } else {
        closeRun();
        if (rec.first == kDataEnd || rec.first == kFooter) break;
        if (!have_summary_ && (rec.first == kSchema || rec.first == kChannel)) {
          const auto b = content(body, rec.second);
          Cursor c(b.data(), b.size(), &path_);
          rec.first == kSchema ? schema(&c) : channel(&c);
        } else if (rec.first == kChunk) {
          Unit u;
          u.chunk = true;
          if (rec.second < 8 + 8 + 8 + 4 + 4) damaged("chunk record too short");
          const uint8_t* h = w.get(body, 32);
          u.start = static_cast<int64_t>(Cursor::le(h, 8));
          u.end = static_cast<int64_t>(Cursor::le(h + 8, 8));
          const uint64_t comp_len = Cursor::le(h + 28, 4);
          if (comp_len > rec.second - 32 || rec.second - 32 - comp_len < 8) damaged("chunk record too short");
          u.compression.assign(reinterpret_cast<const char*>(w.get(body + 32, static_cast<size_t>(comp_len))),
                               static_cast<size_t>(comp_len));
          locateChunk(at, 9 + rec.second, &u);
          if (!have_summary_) {
            // Without a summary the channels are only known from the records themselves, inside chunks too.
            std::vector<uint8_t> records;
            decompress(u, &records);
            forRecords(records, [&](uint8_t op, Cursor* c) {
              if (op == kSchema) schema(c);
              if (op == kChannel) channel(c);
              if (op == kMessage) {
                const uint16_t ch = c->u16();
                if (std::find(u.channels.begin(), u.channels.end(), ch) == u.channels.end()) u.channels.push_back(ch);
              }
            });
            u.channels_known = true;
          }
          units_.push_back(std::move(u));
        }
      }
      at = body + rec.second;
    }
    closeRun();
  }

  /// Calls f(opcode, content) for each record of a chunk's (or run's) records.
  template <class F>
  void forRecords(const std::vector<uint8_t>& b, F&& f) const {
    for (size_t at = 0; at < b.size();) {
      if (b.size() - at < 9) damaged("a record in a chunk runs past the chunk");
      const uint64_t len = Cursor::le(&b[at + 1], 8);
      if (len > b.size() - at - 9) damaged("a record in a chunk runs past the chunk");
      Cursor c(&b[at + 9], static_cast<size_t>(len), &path_);
      f(b[at], &c);
      at += 9 + static_cast<size_t>(len);
    }
  }

  /// A unit's records, decompressed and CRC-checked.
  void decompress(const Unit& u, std::vector<uint8_t>* out) const {
    if (u.uncompressed > kMaxChunk) damaged("a chunk of " + std::to_string(u.uncompressed) + " bytes");
    if (u.length > kMaxChunk) damaged("a record of " + std::to_string(u.length) + " bytes");
    // The compressed bytes in a buffer kept per thread: resized, not zeroed and page-faulted afresh per chunk.
    thread_local std::vector<uint8_t> in;
    in.resize(static_cast<size_t>(u.length));
    file_.read(u.offset, in.size(), in.data());
    if (!u.chunk || u.compression.empty()) {
      if (u.chunk && in.size() != u.uncompressed) damaged("uncompressed chunk size mismatch");
      out->swap(in);
    } else if (u.compression == "zstd") {
      out->resize(static_cast<size_t>(u.uncompressed));
      thread_local std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> ctx(ZSTD_createDCtx(), ZSTD_freeDCtx);
      const size_t got = ctx ? ZSTD_decompressDCtx(ctx.get(), out->data(), out->size(), in.data(), in.size())
                             : ZSTD_decompress(out->data(), out->size(), in.data(), in.size());
      if (ZSTD_isError(got) || got != u.uncompressed)
        damaged(std::string("zstd chunk does not decompress") +
                (ZSTD_isError(got) ? std::string(": ") + ZSTD_getErrorName(got) : std::string(" to its size")));
    } else if (u.compression == "lz4") {
      out->resize(static_cast<size_t>(u.uncompressed));
      LZ4F_dctx* ctx = nullptr;
      if (LZ4F_isError(LZ4F_createDecompressionContext(&ctx, LZ4F_VERSION))) damaged("lz4 context");
      size_t src_at = 0, dst_at = 0, hint = 1;
      while (hint != 0 && src_at < in.size()) {
        size_t dst_n = out->size() - dst_at, src_n = in.size() - src_at;
        hint = LZ4F_decompress(ctx, out->data() + dst_at, &dst_n, in.data() + src_at, &src_n, nullptr);
        if (LZ4F_isError(hint)) {
          LZ4F_freeDecompressionContext(ctx);
          damaged(std::string("lz4 chunk does not decompress: ") + LZ4F_getErrorName(hint));
        }
        src_at += src_n;
        dst_at += dst_n;
        if (src_n == 0 && dst_n == 0) break;
      }
      LZ4F_freeDecompressionContext(ctx);
      if (hint != 0 || dst_at != u.uncompressed) damaged("lz4 chunk does not decompress to its size");
    } else {
      throw FormatError(path_ + ": MCAP chunk compression '" + u.compression +
                        "' is not supported (zstd, lz4 or none)");
    }
    if (u.chunk && u.crc != 0 && crc32Update(0, out->data(), out->size()) != u.crc) damaged("chunk CRC mismatch");
  }

  /// A unit decompressed, its wanted messages listed in log-time order.
  void load(const Unit& u, const std::vector<bool>& want_channel, Loaded* l) const {
    decompress(u, &l->buf);
    bool sorted = true;
    forRecords(l->buf, [&](uint8_t op, Cursor* c) {
      if (op != kMessage) return;
      const uint16_t ch = c->u16();
      if (!want_channel[ch]) return;
      c->skip(4);  // sequence
      Pending p;
      p.t = static_cast<int64_t>(c->u64());
      c->skip(8);  // publish_time
      if (p.t < u.start || p.t > u.end) damaged("a message's log time is outside its chunk's time range");
      p.channel = ch;
      p.at = static_cast<uint32_t>(c->here() - l->buf.data());  // the data: the rest of the record
      p.size = static_cast<uint32_t>(c->end() - c->here());
      if (!l->msgs.empty() && p.t < l->msgs.back().t) sorted = false;
      l->msgs.push_back(p);
    });
    if (!sorted)
      std::stable_sort(l->msgs.begin(), l->msgs.end(), [](const Pending& a, const Pending& b) { return a.t < b.t; });
  }

  void buildTopics() {
    std::map<std::string, size_t> by_name;
    for (auto& kv : channels_) {
      Channel& ch = kv.second;
      const auto s = schemas_.find(ch.schema);
      const std::string type = s == schemas_.end() ? "" : s->second;
      const auto it = by_name.find(ch.topic);
      if (it == by_name.end()) {
        by_name[ch.topic] = topics_.size();
        ch.topic_index = topics_.size();
        topics_.push_back({ch.topic, type, ch.encoding});
      } else {
        ch.topic_index = it->second;
        if (topics_[it->second].type != type)
          throw FormatError(path_ + ": topic " + ch.topic + " has two types (" + topics_[it->second].type + ", " +
                            type + ")");
      }
    }
    for (const auto& u : units_)
      for (uint16_t c : u.channels)
        if (!channels_.count(c)) damaged("a message on channel " + std::to_string(c) + ", which no Channel record defines");
  }

  FileReader file_;
  std::string profile_;
  uint64_t data_start_ = 0, data_end_ = 0;
  bool have_summary_ = false, indexed_ = false;
  std::map<uint16_t, std::string> schemas_;
  std::map<uint16_t, Channel> channels_;
  std::vector<Unit> units_;
  bool have_stats_ = false;
  uint64_t stats_messages_ = 0;
  int64_t stats_start_ = 0;
  std::map<uint16_t, uint64_t> stats_counts_;
};

}  // namespace

std::unique_ptr<Storage> openMcap(const std::string& path) { return std::make_unique<McapStorage>(path); }

}  // namespace rosbag2
}  // namespace gyro_allan
