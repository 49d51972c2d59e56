// Compact in-memory sample storage for long records: 4-byte floats relative to a per-block double reference, and
// integer-nanosecond stamps as 4-byte deltas (half the memory of doubles, for the bag reader).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <vector>

namespace gyro_allan {

/// A series of doubles stored as float(x - ref) with one double reference per block of kBlock samples (the block's
/// first finite sample). Reading back gives ref + float(x - ref): the rounding is at most 2^-24 |x - ref|, i.e. about
/// 6e-8 of the sample-to-sample spread inside a block (white, so its share of any Allan variance is ~1e-14), while
/// a constant offset, bias or slow drift costs nothing. NaN and +-Inf read back as themselves; a finite sample whose
/// difference overflows a float is kept exactly aside. Uses 4 bytes per sample instead of 8.
class CompactSeries {
 public:
  static constexpr size_t kBlock = 4096;
  void reserve(size_t n);
  void push_back(double x);
  size_t size() const { return values_.size(); }
  bool empty() const { return values_.empty(); }
  double operator[](size_t i) const;
  /// All samples as doubles.
  std::vector<double> toVector() const;
  /// Frees the storage.
  void clear();
  /// Bytes held (capacity), for memory reports.
  size_t bytes() const;

 private:
  std::vector<float> values_;
  std::vector<double> refs_;           // one per block; NaN until the block has a finite sample
  std::map<size_t, double> exact_;     // finite samples whose difference overflows a float
};

/// Stamps in integer nanoseconds (relative to a caller's origin), stored as int32 differences from the previous
/// stamp; a difference outside the int32 range (a gap over 2.1 s, a jump back) is kept exactly aside. Reading back is
/// exact. Uses 4 bytes per stamp instead of 8.
class CompactStamps {
 public:
  void reserve(size_t n) { deltas_.reserve(n); }
  void push_back(int64_t ns);
  size_t size() const { return deltas_.size(); }
  bool empty() const { return deltas_.empty(); }
  /// All stamps in nanoseconds.
  std::vector<int64_t> toNanoseconds() const;
  /// All stamps in seconds, as sec + 1e-9 nsec (ros::Duration::toSec), 0 ns -> exactly 0.
  std::vector<double> toSeconds() const;
  void clear();
  size_t bytes() const;

 private:
  template <class F>
  void decode(F&& f) const;  // f(index, ns) for every stamp in order
  std::vector<int32_t> deltas_;
  std::map<size_t, int64_t> exact_;  // index -> full value where the delta does not fit
  int64_t last_ = 0;
};

}  // namespace gyro_allan
