// Direct chunk-by-chunk reader of ROS bag format 2.0 for sensor_msgs/Imu or Vector3Stamped angles (+ Temperature): no per-message index.
//
// Format (wiki.ros.org/Bags/Format/2.0): "#ROSBAG V2.0\n", then records of
//   uint32 header_len, header = fields (uint32 len, "name=value"), uint32 data_len, data.
// op 0x03 bag header (index_pos, conn_count, chunk_count), 0x05 chunk (compression, size; data = records),
// 0x02 message data (conn, time; data = serialized message), 0x07 connection (conn, topic; data = connection header
// fields type, md5sum, ...), 0x04 index data, 0x06 chunk info (ver, chunk_pos, start_time, end_time, count; data =
// count x (conn, msg_count)). The connection and chunk-info records follow the chunks at index_pos.
#include "bag_direct.hpp"

#include <unistd.h>

#include <algorithm>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include <bzlib.h>
#include <roslz4/lz4s.h>
#include <ros/serialization.h>
#include <ros/time.h>
#include <geometry_msgs/Vector3Stamped.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Temperature.h>

namespace gyro_allan {
namespace {


const char* kImuType = "sensor_msgs/Imu";
const char* kAngleType = "geometry_msgs/Vector3Stamped";
constexpr uint8_t kOpMessage = 0x02, kOpBagHeader = 0x03, kOpChunk = 0x05, kOpChunkInfo = 0x06, kOpConnection = 0x07;

/// Any reason to leave the bag to rosbag.
struct NotDirect {};

uint32_t u32(const char* p) {
  uint32_t v;
  std::memcpy(&v, p, 4);
  return v;  // bag files are little-endian, like every platform ROS 1 runs on
}
uint64_t u64(const char* p) {
  uint64_t v;
  std::memcpy(&v, p, 8);
  return v;
}

using Fields = std::map<std::string, std::string>;

Fields parseFields(const char* p, size_t len) {
  Fields f;
  size_t i = 0;
  while (i < len) {
    if (len - i < 4) throw NotDirect{};
    const uint32_t n = u32(p + i);
    i += 4;
    if (n > len - i) throw NotDirect{};
    const char* eq = static_cast<const char*>(std::memchr(p + i, '=', n));
    if (!eq) throw NotDirect{};
    f[std::string(p + i, eq)] = std::string(eq + 1, p + i + n);
    i += n;
  }
  return f;
}

const std::string& field(const Fields& f, const char* name, size_t size = 0) {
  const auto it = f.find(name);
  if (it == f.end() || (size && it->second.size() != size)) throw NotDirect{};
  return it->second;
}

ros::Time timeField(const std::string& v) { return ros::Time(u32(v.data()), u32(v.data() + 4)); }

/// Value of field `name` (of `size` bytes) in a record header, without building a map (the per-message path).
const char* findField(const char* p, size_t len, const char* name, size_t size) {
  const size_t nl = std::strlen(name);
  for (size_t i = 0; i + 4 <= len;) {
    const uint32_t n = u32(p + i);
    i += 4;
    if (n > len - i) throw NotDirect{};
    if (n == nl + 1 + size && std::memcmp(p + i, name, nl) == 0 && p[i + nl] == '=') return p + i + nl + 1;
    i += n;
  }
  throw NotDirect{};
}

class File {
 public:
  explicit File(const std::string& path) : f_(std::fopen(path.c_str(), "rb")) {
    if (!f_) throw NotDirect{};
    if (fseeko(f_, 0, SEEK_END) != 0 || (size_ = ftello(f_)) < 0 || fseeko(f_, 0, SEEK_SET) != 0) {
      std::fclose(f_);
      throw NotDirect{};
    }
  }
  ~File() { std::fclose(f_); }
  File(const File&) = delete;
  File& operator=(const File&) = delete;
  void seek(uint64_t pos) {
    if (fseeko(f_, static_cast<off_t>(pos), SEEK_SET) != 0) throw NotDirect{};
  }
  void read(void* dst, size_t n) {
    if (n && std::fread(dst, 1, n, f_) != n) throw NotDirect{};
  }
  uint32_t readU32() {
    char b[4];
    read(b, 4);
    return u32(b);
  }
  /// One record at the current position: header fields, and its data into *data (or skipped when null).
  Fields readRecord(std::string* data) {
    const uint32_t hlen = readU32();
    if (hlen > (1u << 24) || hlen > remaining()) throw NotDirect{};
    std::string h(hlen, '\0');
    read(&h[0], hlen);
    Fields f = parseFields(h.data(), h.size());
    const uint32_t dlen = readU32();
    if (dlen > remaining()) throw NotDirect{};  // a corrupt length must not allocate gigabytes
    if (data) {
      data->resize(dlen);
      read(&(*data)[0], dlen);
    } else if (fseeko(f_, dlen, SEEK_CUR) != 0) {
      throw NotDirect{};
    }
    return f;
  }

 private:
  uint64_t remaining() {
    const off_t at = ftello(f_);
    return at < 0 || at > size_ ? 0 : static_cast<uint64_t>(size_ - at);
  }
  FILE* f_;
  off_t size_ = 0;
};

struct Connection {
  std::string topic, type, md5;
};

struct ChunkInfo {
  uint64_t pos = 0;
  ros::Time start, end;
  std::map<uint32_t, uint32_t> counts;  // connection -> messages in the chunk
};

struct DirectBag {
  std::string path;
  std::map<uint32_t, Connection> connections;
  std::vector<ChunkInfo> chunks;
  ros::Time first;
};

DirectBag openBag(const std::string& path) {
  DirectBag b;
  b.path = path;
  File f(path);
  char magic[13];
  f.read(magic, 13);
  if (std::memcmp(magic, "#ROSBAG V2.0\n", 13) != 0) throw NotDirect{};
  const Fields h = f.readRecord(nullptr);
  if (field(h, "op", 1)[0] != kOpBagHeader) throw NotDirect{};
  const uint64_t index_pos = u64(field(h, "index_pos", 8).data());
  const uint32_t conn_count = u32(field(h, "conn_count", 4).data());
  const uint32_t chunk_count = u32(field(h, "chunk_count", 4).data());
  if (index_pos == 0 || chunk_count == 0) throw NotDirect{};  // unindexed (still recording) or empty
  f.seek(index_pos);
  for (uint32_t i = 0; i < conn_count; ++i) {
    std::string data;
    const Fields c = f.readRecord(&data);
    if (field(c, "op", 1)[0] != kOpConnection) throw NotDirect{};
    const Fields ch = parseFields(data.data(), data.size());
    Connection con;
    con.topic = field(c, "topic");
    con.type = field(ch, "type");
    con.md5 = field(ch, "md5sum");
    b.connections[u32(field(c, "conn", 4).data())] = con;
  }
  uint64_t total = 0;
  for (uint32_t i = 0; i < chunk_count; ++i) {
    std::string data;
    const Fields c = f.readRecord(&data);
    if (field(c, "op", 1)[0] != kOpChunkInfo || u32(field(c, "ver", 4).data()) != 1) throw NotDirect{};
    ChunkInfo ci;
    ci.pos = u64(field(c, "chunk_pos", 8).data());
    ci.start = timeField(field(c, "start_time", 8));
    ci.end = timeField(field(c, "end_time", 8));
    const uint32_t n = u32(field(c, "count", 4).data());
    if (data.size() != 8ull * n) throw NotDirect{};
    for (uint32_t k = 0; k < n; ++k) {
      ci.counts[u32(data.data() + 8 * k)] += u32(data.data() + 8 * k + 4);
      total += u32(data.data() + 8 * k + 4);
    }
    if (i == 0 || ci.start < b.first) b.first = ci.start;
    b.chunks.push_back(std::move(ci));
  }
  if (total == 0) throw NotDirect{};  // rosbag says "has no messages"
  return b;
}

/// The chunk's records, decompressed.
void readChunk(File* f, uint64_t pos, std::string* compressed, std::string* out) {
  f->seek(pos);
  const Fields c = f->readRecord(compressed);
  if (field(c, "op", 1)[0] != kOpChunk) throw NotDirect{};
  const std::string& comp = field(c, "compression");
  const uint32_t size = u32(field(c, "size", 4).data());
  if (size > (1u << 30)) throw NotDirect{};  // chunks are ~1 MB; a corrupt size must not allocate gigabytes
  if (comp == "none") {
    if (compressed->size() != size) throw NotDirect{};
    out->swap(*compressed);
    return;
  }
  out->resize(size);
  unsigned int got = size;
  if (comp == "bz2") {
    if (BZ2_bzBuffToBuffDecompress(&(*out)[0], &got, &(*compressed)[0], static_cast<unsigned int>(compressed->size()),
                                   0, 0) != BZ_OK)
      throw NotDirect{};
  } else if (comp == "lz4") {
    if (roslz4_buffToBuffDecompress(&(*compressed)[0], static_cast<unsigned int>(compressed->size()), &(*out)[0],
                                    &got) != ROSLZ4_OK)
      throw NotDirect{};
  } else {
    throw NotDirect{};
  }
  if (got != size) throw NotDirect{};
}

/// Reads and decompresses the given chunks on a second thread, a few ahead of the caller (decompression is about
/// half of the reading time; the other half, parsing, overlaps with it).
class ChunkPipeline {
 public:
  ChunkPipeline(const std::string& path, std::vector<uint64_t> positions)
      : file_(path), positions_(std::move(positions)), thread_([this] { produce(); }) {}
  ~ChunkPipeline() {
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  ChunkPipeline(const ChunkPipeline&) = delete;
  ChunkPipeline& operator=(const ChunkPipeline&) = delete;
  /// The next chunk's records; false after the last one. Throws NotDirect if a chunk could not be read.
  bool next(std::string* out) {
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [this] { return !ready_.empty() || done_ || failed_; });
    if (!ready_.empty()) {
      out->swap(ready_.front());
      // The caller's previous buffer goes back to the producer: a reused buffer is resized without zeroing (and
      // page-faulting) a fresh megabyte per chunk, which was a fifth of the reading thread's time.
      spare_.push_back(std::move(ready_.front()));
      ready_.pop_front();
      cv_.notify_all();
      return true;
    }
    if (failed_) throw NotDirect{};
    return false;
  }

 private:
  void produce() {
    std::string compressed;
    for (uint64_t pos : positions_) {
      std::string chunk;
      {
        std::lock_guard<std::mutex> lock(m_);
        if (!spare_.empty()) {
          chunk.swap(spare_.back());
          spare_.pop_back();
        }
      }
      try {
        readChunk(&file_, pos, &compressed, &chunk);
      } catch (...) {
        std::lock_guard<std::mutex> lock(m_);
        failed_ = true;
        cv_.notify_all();
        return;
      }
      std::unique_lock<std::mutex> lock(m_);
      cv_.wait(lock, [this] { return ready_.size() < kAhead || stop_; });
      if (stop_) return;
      ready_.push_back(std::move(chunk));
      cv_.notify_all();
    }
    std::lock_guard<std::mutex> lock(m_);
    done_ = true;
    cv_.notify_all();
  }

  static constexpr size_t kAhead = 4;
  File file_;
  std::vector<uint64_t> positions_;
  std::mutex m_;
  std::condition_variable cv_;
  std::deque<std::string> ready_;
  std::vector<std::string> spare_;  // buffers the caller has finished with, for the producer to reuse
  bool done_ = false, failed_ = false, stop_ = false;
  std::thread thread_;  // last: started after every other member exists
};

template <class M>
void deserialize(const char* p, size_t n, M* msg) {
  ros::serialization::IStream s(reinterpret_cast<uint8_t*>(const_cast<char*>(p)), static_cast<uint32_t>(n));
  ros::serialization::deserialize(s, *msg);
}

bool md5Matches(const std::string& md5, const char* expected) { return md5 == "*" || md5 == expected; }

}  // namespace

bool readImuBagsDirect(const std::vector<std::string>& paths, const BagReadOptions& options, ImuSeries* out) {
  try {
    if (paths.empty() || options.start_s < 0 || options.duration_s < 0) return false;
    std::vector<DirectBag> bags;
    for (const auto& p : paths) bags.push_back(openBag(p));
    std::sort(bags.begin(), bags.end(), [](const DirectBag& a, const DirectBag& b) { return a.first < b.first; });

    // Topic choice as in readImuBags; anything that would be an error there is left to it.
    std::map<std::string, std::string> topics;
    for (const auto& b : bags)
      for (const auto& kv : b.connections) topics.insert({kv.second.topic, kv.second.type});
    bag_detail::TopicChoice choice;
    try {
      choice = bag_detail::chooseTopics(topics, options);
    } catch (const InputError&) {
      return false;
    }
    const std::string& topic = choice.topic;
    const std::string& temp_topic = choice.temperature;
    const std::string& accel_topic = choice.accel_topic;
    BagReadOptions opt = options;
    opt.accel_topic = accel_topic;

    ImuSeries s;
    s.topic = topic;
    s.temperature_topic = temp_topic;
    s.accel_topic = accel_topic;
    size_t total = 0, accel_total = 0;
    for (const auto& b : bags)
      for (const auto& c : b.chunks)
        for (const auto& kv : c.counts) {
          const auto it = b.connections.find(kv.first);
          if (it == b.connections.end()) return false;
          if (it->second.topic == topic) total += kv.second;
          if (!accel_topic.empty() && it->second.topic == accel_topic) accel_total += kv.second;
        }
    const bool angle = !options.angle_topic.empty();
    for (auto& x : s.gyro) x.reserve(total);
    if (!angle)
      for (auto& x : s.accel) x.reserve(total);
    s.t.reserve(total);
    const bool show = options.progress && isatty(fileno(stderr));
    size_t next_report = total / 50 + 1;
    bag_detail::ImuAppender app(&s, opt);
    sensor_msgs::Imu imu;  // reused for every message
    geometry_msgs::Vector3Stamped vec;  // the same, for an angle topic
    sensor_msgs::Temperature tm;
    std::vector<ros::Time> temp_abs;
    std::string chunk;
    for (const auto& b : bags) {
      s.bags.push_back(b.path);
      // Wanted connections: 1 = IMU, 2 = temperature (skipped, like a failed instantiate, on a definition mismatch),
      // 3 = the separate accelerometer.
      std::map<uint32_t, int> wanted;
      for (const auto& kv : b.connections) {
        if (kv.second.topic == topic) {
          const bool ok = angle ? kv.second.type == kAngleType &&
                                      md5Matches(kv.second.md5,
                                                 ros::message_traits::MD5Sum<geometry_msgs::Vector3Stamped>::value())
                                : kv.second.type == kImuType &&
                                      md5Matches(kv.second.md5, ros::message_traits::MD5Sum<sensor_msgs::Imu>::value());
          if (!ok) return false;  // rosbag reports the mismatch
          wanted[kv.first] = 1;
        } else if (!accel_topic.empty() && kv.second.topic == accel_topic) {
          if (kv.second.type != kImuType ||
              !md5Matches(kv.second.md5, ros::message_traits::MD5Sum<sensor_msgs::Imu>::value()))
            return false;
          wanted[kv.first] = 3;
        } else if (!temp_topic.empty() && kv.second.topic == temp_topic) {
          if (md5Matches(kv.second.md5, ros::message_traits::MD5Sum<sensor_msgs::Temperature>::value()))
            wanted[kv.first] = 2;
        }
      }
      ros::Time last;  // record times must not decrease (rosbag::View returns them sorted by time)
      std::vector<uint64_t> positions;
      std::vector<ros::Time> starts;
      for (const auto& ci : b.chunks) {
        bool any = false;
        for (const auto& kv : ci.counts) any = any || wanted.count(kv.first);
        if (!any) continue;  // nothing wanted in this chunk: not even decompressed
        positions.push_back(ci.pos);
        starts.push_back(ci.start);
      }
      ChunkPipeline pipeline(b.path, positions);
      for (size_t c = 0; pipeline.next(&chunk); ++c) {
        if (starts[c] < last) return false;
        const char* p = chunk.data();
        const char* end = p + chunk.size();
        while (p < end) {
          if (end - p < 4) throw NotDirect{};
          const uint32_t hlen = u32(p);
          p += 4;
          if (static_cast<size_t>(end - p) < hlen + 4ull) throw NotDirect{};
          const char* hdr = p;
          p += hlen;
          const uint32_t dlen = u32(p);
          p += 4;
          if (static_cast<size_t>(end - p) < dlen) throw NotDirect{};
          const char* data = p;
          p += dlen;
          // Only message records of wanted connections are parsed beyond the op field.
          if (*findField(hdr, hlen, "op", 1) != kOpMessage) continue;
          const auto w = wanted.find(u32(findField(hdr, hlen, "conn", 4)));
          if (w == wanted.end()) continue;
          const char* tf = findField(hdr, hlen, "time", 8);
          const ros::Time rec_time(u32(tf), u32(tf + 4));
          if (rec_time < last) return false;
          last = rec_time;
          if (w->second == 3) {
            deserialize(data, dlen, &imu);
            app.addAccel(rec_time, imu);
            continue;
          }
          if (w->second == 2) {
            deserialize(data, dlen, &tm);
            temp_abs.push_back(options.use_bag_time ? rec_time : tm.header.stamp);
            s.temperature.push_back(tm.temperature);
            continue;
          }
          if (angle) {
            deserialize(data, dlen, &vec);
            app.add(rec_time, vec);
          } else {
            deserialize(data, dlen, &imu);
            app.add(rec_time, imu);
          }
          const size_t done = app.offered();
          if (show && done >= next_report) {
            std::fprintf(stderr, "\rreading %s: %3.0f %%", topic.c_str(), 100.0 * done / std::max<size_t>(1, total));
            next_report += total / 50 + 1;
          }
        }
      }
    }
    const size_t done = app.offered();
    if (done != total || static_cast<size_t>(s.accel_messages) != accel_total)
      return false;  // the index promised other counts: let rosbag judge
    if (show) std::fprintf(stderr, "\rreading %s: done     \n", topic.c_str());
    s.messages = static_cast<int64_t>(done);
    if (s.t.empty()) return false;  // rosbag path gives the "no messages in the range" error
    bag_detail::finishTemperature(temp_abs, app.origin(), &s.temperature_t);
    app.finish();
    s.reader = "direct";
    *out = std::move(s);
    return true;
  } catch (const NotDirect&) {
    return false;
  } catch (const ros::Exception&) {  // serialization overrun: a truncated message
    return false;
  }
}

}  // namespace gyro_allan
