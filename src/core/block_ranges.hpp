// Per-block minimum and maximum of a series: the screening step shared by the outlier search (spectral.cpp) and the
// spike detector (spikes.cpp), which skip every block whose neighbourhood range cannot hold a candidate.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

namespace gyro_allan {
namespace detail {

/// bmin[b], bmax[b] = min and max of x[b*B, min(n, (b+1)*B)) for every block b of B samples (the last may be short).
inline void blockMinMax(const std::vector<double>& x, int64_t B, std::vector<double>* bmin, std::vector<double>* bmax) {
  const int64_t n = static_cast<int64_t>(x.size());
  const int64_t nb = (n + B - 1) / B;
  bmin->assign(static_cast<size_t>(nb), 0.0);
  bmax->assign(static_cast<size_t>(nb), 0.0);
  for (int64_t b = 0; b < nb; ++b) {
    const int64_t lo = b * B, hi = std::min(n, lo + B);
    double mn = x[static_cast<size_t>(lo)], mx = mn;
    for (int64_t i = lo + 1; i < hi; ++i) {
      mn = std::min(mn, x[static_cast<size_t>(i)]);
      mx = std::max(mx, x[static_cast<size_t>(i)]);
    }
    (*bmin)[static_cast<size_t>(b)] = mn;
    (*bmax)[static_cast<size_t>(b)] = mx;
  }
}

}  // namespace detail
}  // namespace gyro_allan
