// ROS 2 bag writers without ROS 2 — MCAP files (chunked with zstd / lz4 / no compression, with or without message
// and chunk indexes and summary, or unchunked), rosbag2 sqlite3 .db3 files (db schema versions 1-4) and rosbag2's
// metadata.yaml (versions 3-9) — for `simulate`, the tests and the benchmarks: the same samples as a ROS 1 bag in
// every storage variant a reader meets.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace gyro_allan {
namespace rosbag2 {

struct WriteError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A topic as a writer declares it.
struct WriterTopic {
  std::string name;                    ///< e.g. /imu/data
  std::string type;                    ///< ROS 2 spelling, e.g. sensor_msgs/msg/Imu
  std::string definition;              ///< ros2msg text (cdr::definition(type)); may be empty
  std::string serialization_format = "cdr";
};

struct McapWriteOptions {
  std::string compression = "zstd";    ///< chunk compression: "zstd", "lz4" (LZ4 frame) or "" (none)
  bool chunked = true;                 ///< false: schema, channel and message records straight in the data section
  bool message_indexes = true;         ///< chunked: a Message Index record per channel after each chunk
  bool summary = true;                 ///< Summary section: schemas, channels, statistics, chunk indexes (chunked)
  bool chunk_indexes = true;           ///< chunked + summary: Chunk Index records in the summary
  bool summary_offsets = true;         ///< Summary Offset records
  bool crc = true;                     ///< chunk, data-section and summary CRC32 (false: written as 0)
  size_t chunk_size = 768 * 1024;      ///< uncompressed records per chunk before it is closed [bytes]
  std::string profile = "ros2";
  std::string library = "gyro_allan";
};

/// Writes one .mcap file as rosbag2's MCAP storage plugin lays it out (profile "ros2", schema encoding "ros2msg",
/// message encoding "cdr", one schema per type, one channel per topic with offered_qos_profiles metadata).
class McapWriter {
 public:
  McapWriter(const std::string& path, const McapWriteOptions& options = {});
  ~McapWriter();  ///< closes if close() was not called (errors then lost: call close())
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;
  /// Declares a topic; returns its id for write().
  int addTopic(const WriterTopic& topic);
  /// One message: receive (log) time and publish time [ns], serialized bytes (with the CDR encapsulation header).
  void write(int topic, int64_t log_ns, int64_t publish_ns, const void* data, size_t size);
  void write(int topic, int64_t log_ns, const std::string& data) { write(topic, log_ns, log_ns, data.data(), data.size()); }
  /// Flushes the last chunk, writes Data End, summary, summary offsets and footer. Throws WriteError.
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Writes one rosbag2 sqlite3 file at the given db schema version:
///   1: topics(id, name, type, serialization_format), messages(id, topic_id, timestamp, data), no schema table
///   2: topics + offered_qos_profiles
///   3: + schema(schema_version, ros_distro) and metadata(id, metadata_version, metadata) tables
///   4: + topics.type_description_hash and the message_definitions table
/// with the timestamp index rosbag2 creates.
class SqliteWriter {
 public:
  SqliteWriter(const std::string& path, int schema_version = 4, const std::string& ros_distro = "jazzy");
  ~SqliteWriter();
  SqliteWriter(const SqliteWriter&) = delete;
  SqliteWriter& operator=(const SqliteWriter&) = delete;
  int addTopic(const WriterTopic& topic);
  void write(int topic, int64_t recv_ns, const void* data, size_t size);
  void write(int topic, int64_t recv_ns, const std::string& data) { write(topic, recv_ns, data.data(), data.size()); }
  /// Commits; writes the metadata table's text (schema >= 3) when given. Throws WriteError.
  void close(const std::string& metadata_yaml = "");

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// What metadata.yaml describes.
struct BagMetadata {
  int version = 9;                         ///< 3..9: the fields each version has (rosbag2_storage yaml.hpp)
  std::string storage_identifier;          ///< "mcap" or "sqlite3"
  std::vector<std::string> relative_file_paths;
  struct File {
    std::string path;
    int64_t starting_time_ns = 0, duration_ns = 0, message_count = 0;
  };
  std::vector<File> files;                 ///< version >= 5
  struct Topic {
    WriterTopic topic;
    int64_t message_count = 0;
  };
  std::vector<Topic> topics;
  int64_t starting_time_ns = 0, duration_ns = 0, message_count = 0;
  std::string compression_format;          ///< "" or "zstd"
  std::string compression_mode;            ///< "", "FILE" or "MESSAGE"
  std::string ros_distro = "jazzy";        ///< version >= 8
};

/// metadata.yaml text for `m` at m.version.
std::string metadataYaml(const BagMetadata& m);

/// zstd frame of `size` bytes (rosbag2's MESSAGE compression of one message; FILE compression of a whole file).
std::string zstdCompress(const void* data, size_t size, int level = 3);
/// Compresses file `from` into `to` as one zstd stream (rosbag2's FILE compression mode: bag_0.mcap -> bag_0.mcap.zstd).
void zstdCompressFile(const std::string& from, const std::string& to);

}  // namespace rosbag2
}  // namespace gyro_allan
