// ROS 2 bag storage read without ROS 2: one storage file (MCAP or rosbag2's sqlite3 .db3), and a whole bag — a
// rosbag2 folder with metadata.yaml, or storage files given alone — read file after file in receive-time order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace gyro_allan {
namespace rosbag2 {

/// A bag that cannot be read as it claims to be (not MCAP/sqlite3, truncated, CRC mismatch, unknown compression,
/// unsupported metadata...): what() is one line naming the file and the problem.
struct FormatError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct TopicInfo {
  std::string name;
  std::string type;                  ///< ROS 2 spelling, e.g. sensor_msgs/msg/Imu
  std::string serialization_format;  ///< "cdr" for ROS 2 messages
};

/// One stored message, valid during the callback only.
struct StoredMessage {
  size_t topic = 0;          ///< index into Storage::topics()
  int64_t recv_ns = 0;       ///< the storage's time stamp: sqlite3 messages.timestamp, MCAP log_time [ns]
  const uint8_t* data = nullptr;
  size_t size = 0;
};

/// One storage file.
class Storage {
 public:
  virtual ~Storage() = default;
  /// "mcap" or "sqlite3".
  virtual std::string kind() const = 0;
  const std::string& path() const { return path_; }
  const std::vector<TopicInfo>& topics() const { return topics_; }
  /// Every message of the topics with wanted[topic] true, in receive-time order (equal times in storage order).
  /// Throws FormatError when the file proves damaged while reading.
  virtual void read(const std::vector<bool>& wanted, const std::function<void(const StoredMessage&)>& f) = 0;
  /// Messages per topic (index into topics()); may read the whole file.
  virtual std::vector<int64_t> messageCounts() = 0;
  /// Earliest receive time [ns] (0 when the file holds no message).
  virtual int64_t startNs() = 0;
  /// One line on the storage's layout for reports (e.g. "mcap, 12 zstd chunks, indexed" or "sqlite3, schema 3").
  virtual std::string describe() const = 0;

 protected:
  std::string path_;
  std::vector<TopicInfo> topics_;
};

/// Opens a storage file by its content (MCAP or SQLite magic), whatever its name. Throws FormatError.
std::unique_ptr<Storage> openStorage(const std::string& path);
std::unique_ptr<Storage> openMcap(const std::string& path);
std::unique_ptr<Storage> openSqlite3(const std::string& path);

/// Whether a path is a ROS 2 bag input: a folder holding metadata.yaml or .mcap/.db3 files, or a file starting with
/// the MCAP or SQLite magic (or named .mcap, .db3, .mcap.zstd, .db3.zstd).
bool isRos2Input(const std::string& path);

/// A ROS 2 recording: its storage files, opened, in reading order.
/// - a rosbag2 folder: metadata.yaml (versions 1-9) gives the files (relative_file_paths, in order), the storage and
///   the compression (compression_format zstd; compression_mode FILE: each file is a .zstd of the storage file,
///   decompressed to a temporary file; MESSAGE: each message's data is a zstd frame);
/// - a folder without metadata.yaml: its .mcap / .db3 files;
/// - storage files given alone (several: one recording split, e.g. bag_0.mcap bag_1.mcap ...).
/// Files without metadata are ordered by their first receive time.
class Bag {
 public:
  explicit Bag(const std::vector<std::string>& paths);
  ~Bag();
  Bag(const Bag&) = delete;
  Bag& operator=(const Bag&) = delete;
  /// Every topic's ROS 2 type over all files (a topic whose type differs between files: FormatError).
  const std::map<std::string, std::string>& topicTypes() const { return types_; }
  /// Every topic's serialization format ("cdr" for ROS 2 messages).
  const std::map<std::string, std::string>& serializationFormats() const { return formats_; }
  /// The storage files in reading order (as given, not the temporary decompressed copies).
  const std::vector<std::string>& files() const { return files_; }
  /// Messages per topic over all files (reads every file's counts).
  std::map<std::string, int64_t> messageCounts();
  /// One line per file on its layout (Storage::describe), plus the metadata's version and compression.
  std::vector<std::string> describe() const;
  /// Every message of the given topics, file after file, in receive-time order within each file; data already
  /// decompressed when the bag uses MESSAGE compression. Throws FormatError.
  void read(const std::set<std::string>& topics,
            const std::function<void(const std::string& topic, int64_t recv_ns, const uint8_t* data, size_t size)>& f);

 private:
  std::vector<std::string> files_;
  std::vector<std::unique_ptr<Storage>> storages_;
  std::vector<std::string> temporaries_;  // FILE-compressed files' decompressed copies, removed by the destructor
  std::map<std::string, std::string> types_, formats_;
  std::string compression_format_, compression_mode_;
  int metadata_version_ = 0;
};

}  // namespace rosbag2
}  // namespace gyro_allan
