// Log-log Allan deviation plot rendered to an RGB8 pixel buffer (OpenCV drawing), for the nodelet's ~plot Image.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "gyro_allan/allan.hpp"

namespace gyro_allan {

/// One axis to draw: measured curve (dev, dev_lo, dev_hi per point) and the fitted model ADEV at the same taus
/// (empty: no model).
struct PlotSeries {
  std::string name;
  const DeviationCurve* curve = nullptr;
  std::vector<double> model_adev;
};

/// An RGB8 image, row-major, 3 bytes per pixel (sensor_msgs/Image encoding "rgb8", step = 3 * width).
struct RgbImage {
  int width = 0, height = 0;
  std::vector<uint8_t> data;
};

/// True when this build can render (OpenCV was found at configure time).
bool plotImageAvailable();

/// Draws the curves on log-log axes with decade grid and labels, confidence bars, model lines, a legend and a title.
/// Throws std::invalid_argument for a size below 200 x 150 or above 4096 x 4096, or when rendering is unavailable.
RgbImage renderAllanPlot(const std::vector<PlotSeries>& series, int width, int height, const std::string& title);

}  // namespace gyro_allan
