// Plot renderers (io/plot.hpp): sizes, that a power law lands on a straight line of the log-log axes, that the
// raster and the SVG are the same drawing, and that the PNG decodes to the pixels.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <regex>
#include <stdexcept>

#include "gyro_allan/io/plot.hpp"

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

struct Dot {
  double x, y;
};

/// Centres of the SVG circles of one colour.
std::vector<Dot> svgDots(const std::string& svg, const std::string& color) {
  std::vector<Dot> d;
  const std::regex re("<circle cx=\"([0-9.]+)\" cy=\"([0-9.]+)\" r=\"[0-9.]+\" fill=\"" + color + "\"/>");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator(); ++it)
    d.push_back({std::stod((*it)[1]), std::stod((*it)[2])});
  return d;
}

Figure twoAxes(const DeviationCurve& cx, const DeviationCurve& cy) {
  std::vector<AxisAnalysis> s(2);
  s[0].axis = "x";
  s[0].oadev = cx;
  for (const auto& p : cx.points) s[0].final_model_var.push_back(p.dev * p.dev);
  s[1].axis = "y";
  s[1].oadev = cy;
  return windowFigure(s, "gyro_allan live", "", 640, 480);
}

}  // namespace

TEST(Plot, RejectsBadSize) {
  EXPECT_THROW(renderSvg(windowFigure({}, "t", "", 100, 100)), std::invalid_argument);
  EXPECT_THROW(renderSvg(windowFigure({}, "t", "", 5000, 600)), std::invalid_argument);
  Figure wide;
  wide.columns = 9;  // 9 x 500 px
  wide.panels.resize(9);
  EXPECT_THROW(renderSvg(wide), std::invalid_argument);
}

TEST(Plot, PowerLawIsAStraightLineInTheSvg) {
  const DeviationCurve cx = whiteCurve(1e-3), cy = whiteCurve(2e-3);
  const std::string svg = renderSvg(twoAxes(cx, cy));
  EXPECT_NE(svg.find("width=\"640\" height=\"480\""), std::string::npos);
  const std::vector<Dot> x = svgDots(svg, "#d62728"), y = svgDots(svg, "#2ca02c");
  ASSERT_EQ(x.size(), cx.points.size() + 1);  // + the legend's sample
  ASSERT_EQ(y.size(), cy.points.size() + 1);
  // Equal steps in log tau, slope -1/2: equal pixel steps right and down; y (twice x) lies above x by log10(2).
  const double dx = x[1].x - x[0].x, dy = x[1].y - x[0].y;
  EXPECT_GT(dx, 10);
  EXPECT_GT(dy, 3);
  for (size_t i = 1; i < cx.points.size(); ++i) {
    EXPECT_NEAR(x[i].x - x[i - 1].x, dx, 0.15) << i;
    EXPECT_NEAR(x[i].y - x[i - 1].y, dy, 0.15) << i;
    EXPECT_NEAR(y[i].x, x[i].x, 0.1);
    EXPECT_LT(y[i].y, x[i].y);
  }
  // One decade of tau moves the dot by 2 dx along x, and half a decade down: dy = dx / 2 * (x px per decade / y px
  // per decade); the y offset of the doubled curve is log10(2) decades.
  const double y_per_decade = (x[0].y - y[0].y) / std::log10(2.0);
  EXPECT_NEAR(dy, 0.25 * y_per_decade, 0.2);
  EXPECT_NE(svg.find("<polyline"), std::string::npos);  // model line
  EXPECT_NE(svg.find(">10<tspan"), std::string::npos);  // decade tick labels
}

TEST(Plot, RasterIsTheSvgDrawing) {
  if (!rasterAvailable()) GTEST_SKIP() << "built without OpenCV";
  const DeviationCurve cx = whiteCurve(1e-3), cy = whiteCurve(2e-3);
  const Figure f = twoAxes(cx, cy);
  const RgbImage im = renderRaster(f);
  ASSERT_EQ(im.width, 640);
  ASSERT_EQ(im.height, 480);
  ASSERT_EQ(im.data.size(), 640u * 480u * 3u);
  int white = 0;
  for (size_t i = 0; i + 2 < im.data.size(); i += 3) white += im.data[i] == 255 && im.data[i + 1] == 255 && im.data[i + 2] == 255;
  EXPECT_GT(white, 640 * 480 / 2);
  // Every data dot the SVG puts at (x, y) is in the raster there, in its colour (the legend, sized by each
  // backend's font, may sit elsewhere).
  const std::string svg = renderSvg(f);
  for (const auto& [color, rgb] : {std::make_pair(std::string("#d62728"), Rgb{214, 39, 40}),
                                  std::make_pair(std::string("#2ca02c"), Rgb{44, 160, 44})}) {
    std::vector<Dot> dots = svgDots(svg, color);
    ASSERT_EQ(dots.size(), cx.points.size() + 1);
    dots.pop_back();  // the legend's sample
    for (const Dot& d : dots) {
      const size_t i = (static_cast<size_t>(std::lround(d.y)) * 640 + static_cast<size_t>(std::lround(d.x))) * 3;
      EXPECT_NEAR(im.data[i], rgb.r, 40) << color << " at " << d.x << "," << d.y;
      EXPECT_NEAR(im.data[i + 1], rgb.g, 40) << color << " at " << d.x << "," << d.y;
      EXPECT_NEAR(im.data[i + 2], rgb.b, 40) << color << " at " << d.x << "," << d.y;
    }
  }
}

TEST(Plot, PngDecodesToThePixels) {
  RgbImage im;
  im.width = 7, im.height = 3;
  for (int i = 0; i < 7 * 3 * 3; ++i) im.data.push_back(static_cast<uint8_t>(i * 11));
  const std::string png = encodePng(im);
  ASSERT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  auto be32 = [&](size_t at) {
    return (static_cast<uint32_t>(static_cast<uint8_t>(png[at])) << 24) | (static_cast<uint32_t>(static_cast<uint8_t>(png[at + 1])) << 16) |
           (static_cast<uint32_t>(static_cast<uint8_t>(png[at + 2])) << 8) | static_cast<uint32_t>(static_cast<uint8_t>(png[at + 3]));
  };
  ASSERT_EQ(png.substr(12, 4), "IHDR");
  EXPECT_EQ(be32(16), 7u);
  EXPECT_EQ(be32(20), 3u);
  EXPECT_EQ(png[24], 8);  // bit depth
  EXPECT_EQ(png[25], 2);  // RGB
  // Each chunk's CRC covers its type and data.
  size_t at = 8;
  std::string idat;
  while (at < png.size()) {
    const uint32_t len = be32(at);
    const std::string type = png.substr(at + 4, 4);
    const uLong crc = crc32(0L, reinterpret_cast<const Bytef*>(png.data() + at + 4), 4 + len);
    EXPECT_EQ(be32(at + 8 + len), static_cast<uint32_t>(crc)) << type;
    if (type == "IDAT") idat += png.substr(at + 8, len);
    at += 12 + len;
  }
  EXPECT_EQ(at, png.size());
  EXPECT_EQ(png.substr(png.size() - 8, 4), "IEND");
  std::vector<uint8_t> raw(3 * (7 * 3 + 1));
  uLongf raw_len = raw.size();
  ASSERT_EQ(uncompress(raw.data(), &raw_len, reinterpret_cast<const Bytef*>(idat.data()), idat.size()), Z_OK);
  ASSERT_EQ(raw_len, raw.size());
  for (int y = 0; y < 3; ++y) {
    EXPECT_EQ(raw[static_cast<size_t>(y) * 22], 0);  // filter none
    for (int k = 0; k < 21; ++k) EXPECT_EQ(raw[static_cast<size_t>(y) * 22 + 1 + k], im.data[static_cast<size_t>(y) * 21 + k]);
  }
  EXPECT_THROW(encodePng(RgbImage{}), std::invalid_argument);
}

TEST(Plot, EmptyInputSaysWaiting) {
  const std::string svg = renderSvg(windowFigure({}, "none", "", 320, 240));
  EXPECT_NE(svg.find("waiting for data"), std::string::npos);
  if (!rasterAvailable()) return;
  const RgbImage im = renderRaster(windowFigure({}, "none", "", 320, 240));
  EXPECT_EQ(im.data.size(), 320u * 240u * 3u);
}

TEST(Plot, AnalysisFigureHasAPanelPerAxisAndTheReportedTerms) {
  AxisAnalysis a;
  a.axis = "x";
  a.method = Method::JointFit;
  a.oadev = whiteCurve(1e-3);
  a.coefficients[kAngleRandomWalk].value = 1e-3;
  a.coefficients[kAngleRandomWalk].supported = true;
  a.coefficients[kRateRandomWalk].value = 1e-6;  // not supported: no term line, but in the model
  for (const auto& p : a.oadev.points) a.final_model_var.push_back(p.dev * p.dev);
  AxisAnalysis b = a;
  b.axis = "y";
  b.quality.quality = Quality::Bad;
  const Figure f = analysisFigure({a, b}, {});
  ASSERT_EQ(f.columns, 2);
  ASSERT_EQ(f.panels.size(), 2u);
  const std::string svg = renderSvg(f);
  EXPECT_NE(svg.find("width=\"1000\" height=\"400\""), std::string::npos);
  EXPECT_NE(svg.find(">gyro x (joint_fit)<"), std::string::npos);
  EXPECT_NE(svg.find(">gyro y (joint_fit, BAD FIT)<"), std::string::npos);
  // N's line is labelled with its value in the summary's units (1e-3 rad/s/sqrt(s) = 3.44 deg/sqrt(h)); K has none.
  char label[64];
  std::snprintf(label, sizeof label, ">N %.3g %s (slope -1/2)<", 1e-3 * conventionalFactor(kAngleRandomWalk),
                conventionalUnit(kAngleRandomWalk));
  EXPECT_NE(svg.find(label), std::string::npos) << label;
  EXPECT_EQ(svg.find(">K "), std::string::npos);
  EXPECT_NE(svg.find(">reported model<"), std::string::npos);
}
