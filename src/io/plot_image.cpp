// Renders the live log-log Allan deviation plot into an RGB8 buffer with OpenCV's cv::line / cv::putText.
#include "gyro_allan/io/plot_image.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#ifdef GYRO_ALLAN_HAVE_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#endif

namespace gyro_allan {

bool plotImageAvailable() {
#ifdef GYRO_ALLAN_HAVE_OPENCV
  return true;
#else
  return false;
#endif
}

RgbImage renderAllanPlot(const std::vector<PlotSeries>& series, int width, int height, const std::string& title) {
  if (width < 200 || height < 150 || width > 4096 || height > 4096)
    throw std::invalid_argument("plot size " + std::to_string(width) + "x" + std::to_string(height) +
                                " outside 200x150 .. 4096x4096");
#ifndef GYRO_ALLAN_HAVE_OPENCV
  (void)series;
  (void)title;
  throw std::invalid_argument("plot rendering unavailable: built without OpenCV (libopencv-imgproc-dev)");
#else
  RgbImage img;
  img.width = width;
  img.height = height;
  img.data.assign(static_cast<size_t>(width) * static_cast<size_t>(height) * 3, 255);
  cv::Mat m(height, width, CV_8UC3, img.data.data());  // wraps the buffer: drawing fills img.data (RGB order)
  // Data range over every finite positive value, widened to whole decades.
  double tmin = INFINITY, tmax = 0, ymin = INFINITY, ymax = 0;
  for (const auto& s : series) {
    if (!s.curve) continue;
    for (size_t i = 0; i < s.curve->points.size(); ++i) {
      const auto& p = s.curve->points[i];
      if (!(p.tau > 0) || !(p.dev > 0) || !std::isfinite(p.dev)) continue;
      tmin = std::min(tmin, p.tau), tmax = std::max(tmax, p.tau);
      ymin = std::min(ymin, p.dev_lo > 0 ? p.dev_lo : p.dev), ymax = std::max(ymax, std::isfinite(p.dev_hi) ? std::max(p.dev_hi, p.dev) : p.dev);
    }
  }
  const int left = 70, right = 15, top = 30, bottom = 45;
  const cv::Scalar black(0, 0, 0), grid(225, 225, 225);
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  cv::putText(m, title, cv::Point(left, 20), font, 0.5, black, 1, cv::LINE_AA);
  const cv::Rect box(left, top, width - left - right, height - top - bottom);
  if (!(tmax > 0) || !(ymax > 0)) {
    cv::putText(m, "waiting for data", cv::Point(left + 20, height / 2), font, 0.7, black, 1, cv::LINE_AA);
    cv::rectangle(m, box, black, 1);
    return img;
  }
  const double lx0 = std::floor(std::log10(tmin)), lx1 = std::max(lx0 + 1, std::ceil(std::log10(tmax)));
  const double ly0 = std::floor(std::log10(ymin)), ly1 = std::max(ly0 + 1, std::ceil(std::log10(ymax)));
  auto px = [&](double tau) { return box.x + (std::log10(tau) - lx0) / (lx1 - lx0) * box.width; };
  auto py = [&](double y) { return box.y + box.height - (std::log10(y) - ly0) / (ly1 - ly0) * box.height; };
  auto pt = [&](double tau, double y) {  // clamped to the plot box
    const double yy = std::min<double>(box.y + box.height, std::max<double>(box.y, py(y)));
    return cv::Point(static_cast<int>(std::lround(px(tau))), static_cast<int>(std::lround(yy)));
  };
  char buf[32];
  for (double d = lx0; d <= lx1 + 1e-9; d += 1) {
    const int x = static_cast<int>(std::lround(px(std::pow(10.0, d))));
    cv::line(m, cv::Point(x, box.y), cv::Point(x, box.y + box.height), grid, 1);
    std::snprintf(buf, sizeof buf, "1e%g", d);
    cv::putText(m, buf, cv::Point(x - 14, box.y + box.height + 16), font, 0.4, black, 1, cv::LINE_AA);
  }
  for (double d = ly0; d <= ly1 + 1e-9; d += 1) {
    const int y = static_cast<int>(std::lround(py(std::pow(10.0, d))));
    cv::line(m, cv::Point(box.x, y), cv::Point(box.x + box.width, y), grid, 1);
    std::snprintf(buf, sizeof buf, "1e%g", d);
    cv::putText(m, buf, cv::Point(5, y + 4), font, 0.4, black, 1, cv::LINE_AA);
  }
  cv::putText(m, "tau [s]", cv::Point(box.x + box.width / 2 - 25, height - 8), font, 0.45, black, 1, cv::LINE_AA);
  cv::putText(m, "ADEV [rad/s]", cv::Point(5, height - 8), font, 0.4, black, 1, cv::LINE_AA);
  cv::rectangle(m, box, black, 1);
  // Axis colours (RGB buffer): x red, y green, z blue.
  const cv::Scalar colors[] = {cv::Scalar(214, 39, 40), cv::Scalar(44, 160, 44), cv::Scalar(31, 119, 180),
                               cv::Scalar(148, 103, 189)};
  int legend_y = box.y + 15;
  for (size_t s = 0; s < series.size(); ++s) {
    if (!series[s].curve) continue;
    const cv::Scalar col = colors[s % 4];
    const cv::Scalar light(255 - (255 - col[0]) / 3, 255 - (255 - col[1]) / 3, 255 - (255 - col[2]) / 3);
    const auto& pts = series[s].curve->points;
    cv::Point prev(-1, -1);
    for (size_t i = 0; i < pts.size(); ++i) {
      const auto& p = pts[i];
      if (!(p.tau > 0) || !(p.dev > 0) || !std::isfinite(p.dev)) continue;
      if (p.dev_lo > 0 && std::isfinite(p.dev_hi) && p.dev_hi > p.dev_lo)
        cv::line(m, pt(p.tau, p.dev_lo), pt(p.tau, p.dev_hi), light, 2);  // confidence interval
      const cv::Point c = pt(p.tau, p.dev);
      cv::circle(m, c, 2, col, cv::FILLED, cv::LINE_AA);
      if (prev.x >= 0) cv::line(m, prev, c, col, 1, cv::LINE_AA);
      prev = c;
    }
    const auto& model = series[s].model_adev;
    cv::Point mprev(-1, -1);
    for (size_t i = 0; i < model.size() && i < pts.size(); ++i) {
      if (!(model[i] > 0) || !(pts[i].tau > 0)) continue;
      const cv::Point c = pt(pts[i].tau, model[i]);
      if (mprev.x >= 0) cv::line(m, mprev, c, black, 1, cv::LINE_AA);
      mprev = c;
    }
    cv::line(m, cv::Point(box.x + box.width - 110, legend_y - 4), cv::Point(box.x + box.width - 90, legend_y - 4), col, 2);
    cv::putText(m, series[s].name, cv::Point(box.x + box.width - 85, legend_y), font, 0.4, black, 1, cv::LINE_AA);
    legend_y += 15;
  }
  cv::line(m, cv::Point(box.x + box.width - 110, legend_y - 4), cv::Point(box.x + box.width - 90, legend_y - 4), black, 1);
  cv::putText(m, "IEEE fit", cv::Point(box.x + box.width - 85, legend_y), font, 0.4, black, 1, cv::LINE_AA);
  return img;
#endif
}

}  // namespace gyro_allan
