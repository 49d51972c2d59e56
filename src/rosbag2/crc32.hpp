// CRC-32 as MCAP and zlib define it (IEEE 802.3), fast: crc32.cpp.
#pragma once

#include <cstddef>
#include <cstdint>

namespace gyro_allan {
namespace rosbag2 {

/// zlib's crc32(crc, p, n): the CRC-32 of the bytes so far (start with 0) extended by p[0..n).
uint32_t crc32Update(uint32_t crc, const uint8_t* p, size_t n);

}  // namespace rosbag2
}  // namespace gyro_allan
