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
