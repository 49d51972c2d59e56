// Live plot image (nodelet ~plot): size, encoding layout, and that a known curve lands where log-log axes put it.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "gyro_allan/io/plot_image.hpp"

using namespace gyro_allan;

namespace {

DeviationCurve whiteCurve(double n) {  // ADEV = n / sqrt(tau), tau 0.01 .. 100 s, +-10 % intervals
  DeviationCurve c;
  c.name = "oadev";
  c.tau0 = 0.01;
  for (double tau = 0.01; tau <= 100.0 * 1.0001; tau *= std::sqrt(10.0)) {
    DeviationPoint p;
    p.tau = tau;
    p.dev = n / std::sqrt(tau);
    p.dev_lo = 0.9 * p.dev;
    p.dev_hi = 1.1 * p.dev;
    c.points.push_back(p);
  }
  return c;
}

int countColor(const RgbImage& im, int r, int g, int b, int tol) {
  int n = 0;
  for (size_t i = 0; i + 2 < im.data.size(); i += 3)
    n += std::abs(im.data[i] - r) <= tol && std::abs(im.data[i + 1] - g) <= tol && std::abs(im.data[i + 2] - b) <= tol;
  return n;
}

}  // namespace

TEST(PlotImage, RejectsBadSize) {
  EXPECT_THROW(renderAllanPlot({}, 100, 100, "t"), std::invalid_argument);
  EXPECT_THROW(renderAllanPlot({}, 5000, 600, "t"), std::invalid_argument);
}

TEST(PlotImage, DrawsCurvesInTheirColoursOnAWhiteCanvas) {
  if (!plotImageAvailable()) GTEST_SKIP() << "built without OpenCV";
  const DeviationCurve cx = whiteCurve(1e-3), cy = whiteCurve(2e-3);
  std::vector<PlotSeries> s(2);
  s[0].name = "x";
  s[0].curve = &cx;
  for (const auto& p : cx.points) s[0].model_adev.push_back(p.dev);
  s[1].name = "y";
  s[1].curve = &cy;
  const RgbImage im = renderAllanPlot(s, 640, 480, "gyro_allan live");
  ASSERT_EQ(im.width, 640);
  ASSERT_EQ(im.height, 480);
  ASSERT_EQ(im.data.size(), 640u * 480u * 3u);
  // Mostly white background, and both axis colours present (x red 214,39,40; y green 44,160,44).
  EXPECT_GT(countColor(im, 255, 255, 255, 0), 640 * 480 / 2);
  EXPECT_GT(countColor(im, 214, 39, 40, 30), 30);
  EXPECT_GT(countColor(im, 44, 160, 44, 30), 30);
  // The x curve's point at tau = 1 s (ADEV 1e-3): axes span tau 1e-2..1e2 and ADEV 1e-5..1e-1 (decades, intervals
  // included) in the box x 70..625, y 30..435: tau 1 -> x = 70 + 0.5*555 = 347, ADEV 1e-3 -> y = 435 - 0.5*405 = 232.
  int red_near = 0;
  for (int y = 228; y <= 236; ++y)
    for (int x = 343; x <= 351; ++x) {
      const size_t i = (static_cast<size_t>(y) * 640 + static_cast<size_t>(x)) * 3;
      red_near += im.data[i] > 150 && im.data[i + 1] < 120 && im.data[i + 2] < 120;
    }
  EXPECT_GT(red_near, 3);
}

TEST(PlotImage, EmptyInputSaysWaiting) {
  if (!plotImageAvailable()) GTEST_SKIP() << "built without OpenCV";
  const RgbImage im = renderAllanPlot({}, 320, 240, "none");
  EXPECT_EQ(im.data.size(), 320u * 240u * 3u);
  EXPECT_LT(countColor(im, 255, 255, 255, 0), 320 * 240);  // frame and text drawn
}
