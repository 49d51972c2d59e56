// Direct reader of ROS bag format 2.0 files for the IMU series: chunk by chunk, without rosbag's per-message index.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <ros/time.h>

#include "gyro_allan/io/bag_input.hpp"

namespace gyro_allan {
namespace bag_detail {

/// Stamps as ns since (first non-zero IMU stamp - 1 s), in integers: epoch seconds in a double carry only ~0.2 us
/// of precision, which would blur the sample period. A zero stamp stays exactly 0 (invalid).
inline int64_t relativeStampNs(const ros::Time& stamp, ros::Time* origin) {
  if (stamp.isZero()) return 0;
  if (origin->isZero()) *origin = stamp - ros::Duration(1.0);
  return (stamp - *origin).toNSec();
}

/// The same in seconds, as CompactStamps::toSeconds gives it back (ros::Duration::toSec).
inline double relativeStamp(const ros::Time& stamp, ros::Time* origin) {
  if (stamp.isZero()) return 0.0;
  if (origin->isZero()) *origin = stamp - ros::Duration(1.0);
  return (stamp - *origin).toSec();
}

/// Temperature stamps are kept absolute while reading and made relative at the end, so the origin is the IMU's
/// whatever order the two topics are read in.
inline void finishTemperature(const std::vector<ros::Time>& abs, ros::Time* origin, std::vector<double>* rel) {
  rel->clear();
  rel->reserve(abs.size());
  for (const auto& t : abs) rel->push_back(relativeStamp(t, origin));
}

}  // namespace bag_detail

/// Reads the bags like readImuBags does with rosbag::View, but straight from the file: the bag header, the
/// connection and chunk-info records at the end of the file, then each chunk that holds a wanted topic, decompressed
/// (none, bz2, lz4) and scanned record by record; messages are deserialized with roscpp's serializers into one reused
/// message. Memory is one chunk instead of an index entry per message, and chunks without a wanted message are not
/// even decompressed.
/// Returns false, leaving *out untouched, whenever the bags are not plain indexed v2.0 bags this reader is sure to
/// read exactly as rosbag::View would (unindexed or truncated bags, unknown compression, a message-definition
/// mismatch, records whose times are not in order, a topic choice that would be an error, any parse failure):
/// the caller then uses rosbag, which also gives the user-facing error messages.
bool readImuBagsDirect(const std::vector<std::string>& paths, const BagReadOptions& options, ImuSeries* out);

}  // namespace gyro_allan
