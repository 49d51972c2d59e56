// Compact sample and stamp storage (float-relative-to-block-reference values, int32-delta nanosecond stamps).
#include "gyro_allan/compact_series.hpp"

#include <cmath>
#include <limits>

namespace gyro_allan {

void CompactSeries::reserve(size_t n) {
  values_.reserve(n);
  refs_.reserve(n / kBlock + 1);
}

void CompactSeries::push_back(double x) {
  const size_t i = values_.size();
  if (i % kBlock == 0) refs_.push_back(std::numeric_limits<double>::quiet_NaN());
  double& ref = refs_.back();
  if (std::isnan(ref) && std::isfinite(x)) ref = x;
  if (!std::isfinite(x)) {
    values_.push_back(static_cast<float>(x));  // NaN / +-Inf keep their meaning whatever the reference
    return;
  }
  const double d = x - ref;
  const float f = static_cast<float>(d);
  values_.push_back(f);
  if (!std::isfinite(f)) exact_[i] = x;
}

double CompactSeries::operator[](size_t i) const {
  const float f = values_[i];
  if (!std::isfinite(f)) {
    if (!exact_.empty()) {
      const auto it = exact_.find(i);
      if (it != exact_.end()) return it->second;
    }
    return static_cast<double>(f);
  }
  return refs_[i / kBlock] + static_cast<double>(f);
}

std::vector<double> CompactSeries::toVector() const {
  std::vector<double> out(values_.size());
  for (size_t i = 0; i < values_.size(); ++i) out[i] = (*this)[i];
  return out;
}

void CompactSeries::clear() {
  std::vector<float>().swap(values_);
  std::vector<double>().swap(refs_);
  exact_.clear();
}

size_t CompactSeries::bytes() const {
  return values_.capacity() * sizeof(float) + refs_.capacity() * sizeof(double) + exact_.size() * 48;
}

void CompactStamps::push_back(int64_t ns) {
  const int64_t d = ns - last_;
  if (d >= std::numeric_limits<int32_t>::min() && d <= std::numeric_limits<int32_t>::max()) {
    deltas_.push_back(static_cast<int32_t>(d));
  } else {
    exact_[deltas_.size()] = ns;
    deltas_.push_back(0);
  }
  last_ = ns;
}

template <class F>
void CompactStamps::decode(F&& f) const {
  int64_t v = 0;
  auto it = exact_.begin();
  for (size_t i = 0; i < deltas_.size(); ++i) {
    if (it != exact_.end() && it->first == i) {
      v = it->second;
      ++it;
    } else {
      v += deltas_[i];
    }
    f(i, v);
  }
}

std::vector<int64_t> CompactStamps::toNanoseconds() const {
  std::vector<int64_t> out(deltas_.size());
  decode([&out](size_t i, int64_t v) { out[i] = v; });
  return out;
}

std::vector<double> CompactStamps::toSeconds() const {
  std::vector<double> out(deltas_.size());
  decode([&out](size_t i, int64_t v) {
    // the same rounding as ros::Duration::toSec(): whole seconds plus 1e-9 * nanoseconds (sign-consistent split)
    int64_t sec = v / 1000000000, nsec = v % 1000000000;
    if (nsec < 0) {
      nsec += 1000000000;
      --sec;
    }
    out[i] = v == 0 ? 0.0 : static_cast<double>(sec) + 1e-9 * static_cast<double>(nsec);
  });
  return out;
}

void CompactStamps::clear() {
  std::vector<int32_t>().swap(deltas_);
  exact_.clear();
  last_ = 0;
}

size_t CompactStamps::bytes() const { return deltas_.capacity() * sizeof(int32_t) + exact_.size() * 48; }

}  // namespace gyro_allan
