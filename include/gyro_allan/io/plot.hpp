// Log-log Allan deviation figures: panels of bands, markers and lines, rendered to SVG text or to an RGB raster/PNG;
// what analyze_bag writes as allan.png/allan.svg and the nodelet publishes as ~plot.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "gyro_allan/analysis.hpp"

namespace gyro_allan {

struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
};

enum class Mark { Line, Dashed, Dotted, Dots, Squares, Triangles, Band };

/// One thing drawn in a panel, in data units (x = tau [s], y = deviation); points with a non-finite or non-positive
/// value are skipped (a line or band is broken there).
struct Layer {
  Mark mark = Mark::Line;
  Rgb color;
  std::string label;         ///< legend entry (empty: none)
  std::vector<double> x, y;  ///< Band: y is the lower edge
  std::vector<double> y_hi;  ///< Band: the upper edge
  double width = 1.0;        ///< line width [px]
  bool sets_range = true;    ///< counts for the panel's y range (a term's line far below the data does not)
};

struct Panel {
  std::string title;
  bool alert = false;  ///< title in red (a bad fit)
  std::string xlabel = "tau [s]", ylabel;
  std::string note;    ///< one line under the title (e.g. "quick answer, 4 s old"); empty: none
  std::vector<Layer> layers;
};

/// Panels row-major, `columns` per row, each panel_width x panel_height pixels; a default Panel{} is left blank.
struct Figure {
  int columns = 1;
  int panel_width = 500, panel_height = 400;
  std::vector<Panel> panels;
};

/// An RGB8 image, row-major, 3 bytes per pixel (sensor_msgs/Image encoding "rgb8", step = 3 * width).
struct RgbImage {
  int width = 0, height = 0;
  std::vector<uint8_t> data;
};

/// True when this build can rasterize (OpenCV imgproc was found at configure time); SVG needs nothing.
bool rasterAvailable();

/// The figure as a standalone SVG document. Throws std::invalid_argument for a panel below 200 x 150 or a figure
/// above 4096 x 4096 pixels.
std::string renderSvg(const Figure& f);
/// The same drawing as pixels (same sizes checked; also throws when rasterizing is unavailable).
RgbImage renderRaster(const Figure& f);
/// A PNG file's bytes (8-bit RGB, deflate by zlib).
std::string encodePng(const RgbImage& im);

/// What analyze_bag draws: one row per sensor (gyro; accelerometer when given), one panel per axis with the measured
/// oadev and its 95 % band, the reported model, each supported term's line (legend: its value in the summary's
/// units), the wavelet split's parts and the model check's curve when it added effects.
Figure analysisFigure(const std::vector<AxisAnalysis>& gyro, const std::vector<AxisAnalysis>& accel);

/// The nodelet's ~plot: every axis's oadev in one width x height panel (x red, y green, z blue), the data with its
/// band and the axis's model (final_model_var, when it has one per point); `note` is printed under the title.
Figure windowFigure(const std::vector<AxisAnalysis>& axes, const std::string& title, const std::string& note, int width,
                    int height);

/// Writes DIR/allan.svg and, when rasterizing is available, DIR/allan.png (atomically). Returns "" or a one-line
/// reason why allan.png was not written; throws std::runtime_error naming a file that cannot be written.
std::string writeFigure(const std::string& dir, const Figure& f);

}  // namespace gyro_allan
