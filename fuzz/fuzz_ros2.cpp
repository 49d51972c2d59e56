// libFuzzer target: ROS 2 storage and messages from arbitrary bytes (the first byte picks the reader: CDR messages,
// an MCAP file, a rosbag2 sqlite3 file) must be read or refused with rosbag2::FormatError / cdr::Error, nothing else.
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "gyro_allan/rosbag2/cdr.hpp"
#include "gyro_allan/rosbag2/storage.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const uint8_t mode = data[0] % 3;
  ++data, --size;
  if (mode == 0) {
    gyro_allan::cdr::Imu imu;
    gyro_allan::cdr::Vector3Stamped v;
    gyro_allan::cdr::Temperature t;
    try { gyro_allan::cdr::decode(data, size, &imu); } catch (const gyro_allan::cdr::Error&) {}
    try { gyro_allan::cdr::decode(data, size, &v); } catch (const gyro_allan::cdr::Error&) {}
    try { gyro_allan::cdr::decode(data, size, &t); } catch (const gyro_allan::cdr::Error&) {}
    return 0;
  }
  const std::string path = "/tmp/gyro_allan_fuzz_" + std::to_string(getpid()) + (mode == 1 ? ".mcap" : ".db3");
  {
    std::ofstream f(path, std::ios::binary);
    f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    gyro_allan::rosbag2::Bag bag({path});
    std::set<std::string> all;
    for (const auto& kv : bag.topicTypes()) all.insert(kv.first);
    size_t n = 0;
    bag.read(all, [&](const std::string&, int64_t, const uint8_t* d, size_t s) {
      if (s > 0 && d == nullptr) __builtin_trap();  // data must be readable for its size
      n += s > 0 ? d[s - 1] & 1u : 0u;
    });
    (void)bag.messageCounts();
    (void)n;
  } catch (const gyro_allan::rosbag2::FormatError&) {
  }
  std::remove(path.c_str());
  return 0;
}
