// Unit tests of the shared order statistics (stats.hpp): median and upper median, odd/even/empty, reordering only.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "gyro_allan/stats.hpp"

using namespace gyro_allan;

TEST(Stats, MedianOddIsTheMiddleValue) {
  EXPECT_EQ(median({3.0}), 3.0);
  EXPECT_EQ(median({5.0, -1.0, 2.0}), 2.0);
  EXPECT_EQ(upperMedian({5.0, -1.0, 2.0}), 2.0);
  EXPECT_EQ(median({9.0, 1.0, 7.0, 3.0, 5.0}), 5.0);
}

TEST(Stats, EvenCountConventions) {
  EXPECT_EQ(median({4.0, 1.0}), 2.5);
  EXPECT_EQ(upperMedian({4.0, 1.0}), 4.0);
  EXPECT_EQ(median({10.0, 2.0, 8.0, 4.0}), 6.0);  // (4 + 8) / 2
  EXPECT_EQ(upperMedian({10.0, 2.0, 8.0, 4.0}), 8.0);
  EXPECT_EQ(median({1.0, 1.0, 1.0, 3.0}), 1.0);    // ties
}

TEST(Stats, EmptyIsNan) {
  EXPECT_TRUE(std::isnan(median({})));
  EXPECT_TRUE(std::isnan(upperMedian({})));
  std::vector<double> e;
  EXPECT_TRUE(std::isnan(medianInPlace(e)));
  EXPECT_TRUE(std::isnan(upperMedianInPlace(e)));
}

TEST(Stats, InPlaceOnlyReordersAndAgreesWithSorting) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g;
  for (size_t n : {1u, 2u, 3u, 10u, 11u, 1000u, 1001u}) {
    std::vector<double> v(n);
    for (double& x : v) x = g(rng);
    std::vector<double> s = v;
    std::sort(s.begin(), s.end());
    const double want = n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
    EXPECT_EQ(median(v), want) << n;  // the copy leaves v as it was
    EXPECT_EQ(upperMedian(v), s[n / 2]) << n;
    std::vector<double> w = v;
    EXPECT_EQ(medianInPlace(w), want) << n;
    std::sort(w.begin(), w.end());
    EXPECT_EQ(w, s) << n;  // a permutation of the input
    w = v;
    EXPECT_EQ(upperMedianInPlace(w), s[n / 2]) << n;
  }
}

// The selection (stats.cpp selectRank) on the inputs that break quickselects: runs of equal values (quantized samples
// and their differences), sorted, reversed, organ-pipe and all-equal data, and a median-of-3 killer sequence. Each
// must give the sorted array's value and leave v partitioned around it as std::nth_element would.
TEST(Stats, SelectionOnHardInputsMatchesSortingAndPartitions) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g;
  auto inputs = [&](size_t n) {
    std::vector<std::vector<double>> out;
    std::vector<double> v(n);
    for (double& x : v) x = g(rng);
    out.push_back(v);                                             // noise
    for (double& x : v) x = std::round(2 * g(rng));               // few levels, long runs of ties
    out.push_back(v);
    for (size_t i = 0; i < n; ++i) v[i] = static_cast<double>(i);  // sorted
    out.push_back(v);
    std::reverse(v.begin(), v.end());                             // reversed
    out.push_back(v);
    for (size_t i = 0; i < n; ++i) v[i] = static_cast<double>(std::min(i, n - 1 - i));  // organ pipe
    out.push_back(v);
    std::fill(v.begin(), v.end(), 3.5);                           // all equal
    out.push_back(v);
    // Median-of-3 killer (Musser 1997): first, middle and last of every range are the smallest values.
    for (size_t i = 0; i < n; ++i) v[i] = static_cast<double>(i % 2 ? n / 2 + i : i);
    out.push_back(v);
    return out;
  };
  for (size_t n : {33u, 400u, 401u, 4096u, 100001u}) {
    int kind = 0;
    for (const auto& v : inputs(n)) {
      std::vector<double> s = v;
      std::sort(s.begin(), s.end());
      std::vector<double> w = v;
      const double m = upperMedianInPlace(w);
      EXPECT_EQ(m, s[n / 2]) << "n " << n << " kind " << kind;
      EXPECT_TRUE(std::all_of(w.begin(), w.begin() + static_cast<std::ptrdiff_t>(n / 2), [&](double x) { return x <= m; }))
          << "n " << n << " kind " << kind;
      EXPECT_TRUE(std::all_of(w.begin() + static_cast<std::ptrdiff_t>(n / 2), w.end(), [&](double x) { return x >= m; }))
          << "n " << n << " kind " << kind;
      EXPECT_EQ(w[n / 2], m);
      std::vector<double> x = v;
      EXPECT_EQ(medianInPlace(x), n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2])) << "n " << n << " kind " << kind;
      ++kind;
    }
  }
}
