// Allan deviation figures: one layout drawn through a painter into SVG text or OpenCV pixels (PNG by zlib), and the
// figure analyze_bag draws from its results.
//
// Written here rather than taken from a plotting library: Debian has no C++ plotting library that writes PNG and SVG
// without pulling a GUI toolkit, and a log-log panel needs only lines, markers, a band and decade ticks. OpenCV's
// imgproc (already used for the nodelet's image) rasterizes; zlib deflates the PNG.
#include "gyro_allan/io/plot.hpp"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>
#include <stdexcept>

#include "gyro_allan/io/report.hpp"  // writeFileAtomic
#include "gyro_allan/kalibr.hpp"     // accelConventionalFactor / Unit

#ifdef GYRO_ALLAN_HAVE_OPENCV
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#endif

namespace gyro_allan {
namespace {

struct P {
  double x = 0, y = 0;
};

/// Text anchors: left edge, centre or right edge at x; y is the baseline.
enum class Anchor { Left, Centre, Right };

/// A run of text, raised and smaller when `sup`.
struct TextPart {
  std::string s;
  bool sup = false;
};

/// "10^{-3}" -> "10", superscript "-3"; "m/s^{2}]" -> "m/s", "2", "]".
std::vector<TextPart> parseText(const std::string& t) {
  std::vector<TextPart> parts;
  size_t at = 0;
  while (at < t.size()) {
    const size_t open = t.find("^{", at);
    const size_t close = open == std::string::npos ? std::string::npos : t.find('}', open);
    if (close == std::string::npos) {
      parts.push_back({t.substr(at), false});
      break;
    }
    if (open > at) parts.push_back({t.substr(at, open - at), false});
    parts.push_back({t.substr(open + 2, close - open - 2), true});
    at = close + 1;
  }
  return parts;
}

/// What a backend can draw. Text may hold superscripts as ^{...} (parseText).
class Painter {
 public:
  virtual ~Painter() = default;
  virtual void polyline(const std::vector<P>& pts, Rgb c, double width, Mark dash) = 0;
  virtual void polygon(const std::vector<P>& pts, Rgb c, double alpha) = 0;
  virtual void marker(P p, Mark shape, double r, Rgb c) = 0;
  virtual void rect(double x, double y, double w, double h, Rgb stroke, bool fill_white) = 0;
  virtual void text(double x, double y, const std::string& t, double size, Anchor a, Rgb c, bool vertical) = 0;
  virtual double textWidth(const std::string& t, double size) = 0;
};

const Rgb kBlack{0, 0, 0}, kGrid{222, 222, 222}, kMinorGrid{240, 240, 240}, kGray{110, 110, 110}, kRed{214, 39, 40};

/// Liang–Barsky: the part of segment a-b inside [x0,x1] x [y0,y1]; false when none.
bool clipSegment(P* a, P* b, double x0, double y0, double x1, double y1) {
  double t0 = 0, t1 = 1;
  const double dx = b->x - a->x, dy = b->y - a->y;
  const double p[4] = {-dx, dx, -dy, dy}, q[4] = {a->x - x0, x1 - a->x, a->y - y0, y1 - a->y};
  for (int i = 0; i < 4; ++i) {
    if (p[i] == 0) {
      if (q[i] < 0) return false;
      continue;
    }
    const double r = q[i] / p[i];
    if (p[i] < 0) {
      if (r > t1) return false;
      t0 = std::max(t0, r);
    } else {
      if (r < t0) return false;
      t1 = std::min(t1, r);
    }
  }
  const P a0 = *a;
  *a = {a0.x + t0 * dx, a0.y + t0 * dy};
  *b = {a0.x + t1 * dx, a0.y + t1 * dy};
  return true;
}

std::string hex(Rgb c) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", c.r, c.g, c.b);
  return buf;
}

std::string escapeXml(const std::string& s) {
  std::string o;
  for (char ch : s) {
    if (ch == '&') o += "&amp;";
    else if (ch == '<') o += "&lt;";
    else if (ch == '>') o += "&gt;";
    else if (ch == '"') o += "&quot;";
    else o += ch;
  }
  return o;
}

class SvgPainter : public Painter {
 public:
  SvgPainter(int w, int h) {
    o_ << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w
       << "\" height=\"" << h << "\" viewBox=\"0 0 " << w << ' ' << h
       << "\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\">\n<rect width=\"100%\" height=\"100%\" "
          "fill=\"#ffffff\"/>\n";
  }
  std::string finish() {
    o_ << "</svg>\n";
    return o_.str();
  }
  void polyline(const std::vector<P>& pts, Rgb c, double width, Mark dash) override {
    if (pts.size() < 2) return;
    o_ << "<polyline fill=\"none\" stroke=\"" << hex(c) << "\" stroke-width=\"" << num(width) << '"';
    if (dash == Mark::Dashed) o_ << " stroke-dasharray=\"6,4\"";
    if (dash == Mark::Dotted) o_ << " stroke-dasharray=\"1.5,3\"";
    o_ << " points=\"";
    points(pts);
    o_ << "\"/>\n";
  }
  void polygon(const std::vector<P>& pts, Rgb c, double alpha) override {
    o_ << "<polygon fill=\"" << hex(c) << "\" fill-opacity=\"" << num(alpha) << "\" stroke=\"none\" points=\"";
    points(pts);
    o_ << "\"/>\n";
  }
  void marker(P p, Mark shape, double r, Rgb c) override {
    if (shape == Mark::Squares) {
      o_ << "<rect x=\"" << num(p.x - r) << "\" y=\"" << num(p.y - r) << "\" width=\"" << num(2 * r) << "\" height=\""
         << num(2 * r) << "\" fill=\"" << hex(c) << "\"/>\n";
    } else if (shape == Mark::Triangles) {
      o_ << "<polygon fill=\"" << hex(c) << "\" points=\"";
      points({{p.x, p.y - r}, {p.x - r, p.y + r}, {p.x + r, p.y + r}});
      o_ << "\"/>\n";
    } else {
      o_ << "<circle cx=\"" << num(p.x) << "\" cy=\"" << num(p.y) << "\" r=\"" << num(r) << "\" fill=\"" << hex(c)
         << "\"/>\n";
    }
  }
  void rect(double x, double y, double w, double h, Rgb stroke, bool fill_white) override {
    o_ << "<rect x=\"" << num(x) << "\" y=\"" << num(y) << "\" width=\"" << num(w) << "\" height=\"" << num(h)
       << "\" fill=\"" << (fill_white ? "#ffffff" : "none") << "\" stroke=\"" << hex(stroke) << "\"/>\n";
  }
  void text(double x, double y, const std::string& t, double size, Anchor a, Rgb c, bool vertical) override {
    const char* anchor = a == Anchor::Left ? "start" : a == Anchor::Centre ? "middle" : "end";
    o_ << "<text x=\"" << num(x) << "\" y=\"" << num(y) << "\" font-size=\"" << num(size) << "\" text-anchor=\""
       << anchor << "\" fill=\"" << hex(c) << '"';
    if (vertical) o_ << " transform=\"rotate(-90 " << num(x) << ' ' << num(y) << ")\"";
    o_ << '>';
    bool raised = false;
    for (const TextPart& p : parseText(t)) {
      if (p.sup) {
        o_ << "<tspan dy=\"" << num(-0.45 * size) << "\" font-size=\"" << num(0.75 * size) << "\">" << escapeXml(p.s) << "</tspan>";
        raised = true;
      } else if (raised) {
        o_ << "<tspan dy=\"" << num(0.45 * size) << "\">" << escapeXml(p.s) << "</tspan>";
        raised = false;
      } else {
        o_ << escapeXml(p.s);
      }
    }
    o_ << "</text>\n";
  }
  double textWidth(const std::string& t, double size) override {  // DejaVu Sans averages ~0.6 em a character
    double w = 0;
    for (const TextPart& p : parseText(t)) w += 0.6 * size * (p.sup ? 0.75 : 1.0) * static_cast<double>(p.s.size());
    return w;
  }

 private:
  static std::string num(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f", v);
    std::string s = buf;
    if (s.size() > 2 && s.compare(s.size() - 2, 2, ".0") == 0) s.resize(s.size() - 2);
    return s;
  }
  void points(const std::vector<P>& pts) {
    for (size_t i = 0; i < pts.size(); ++i) o_ << (i ? " " : "") << num(pts[i].x) << ',' << num(pts[i].y);
  }
  std::ostringstream o_;
};

#ifdef GYRO_ALLAN_HAVE_OPENCV
class CvPainter : public Painter {
 public:
  explicit CvPainter(cv::Mat* m) : m_(*m) {}
  void polyline(const std::vector<P>& pts, Rgb c, double width, Mark dash) override {
    const int th = std::max(1, static_cast<int>(std::lround(width)));
    if (dash == Mark::Line) {
      for (size_t i = 1; i < pts.size(); ++i) line(pts[i - 1], pts[i], c, th);
      return;
    }
    // Dash pattern walked along the polyline (on, off lengths in px).
    const double on = dash == Mark::Dashed ? 6.0 : 1.5, off = dash == Mark::Dashed ? 4.0 : 3.0;
    double phase = 0;  // position within the pattern
    for (size_t i = 1; i < pts.size(); ++i) {
      const P a = pts[i - 1], b = pts[i];
      const double len = std::hypot(b.x - a.x, b.y - a.y);
      double s = 0;
      while (s < len) {
        const bool drawing = phase < on;
        const double step = std::min(len - s, drawing ? on - phase : on + off - phase);
        if (drawing) {
          const double t0 = s / len, t1 = (s + step) / len;
          line({a.x + t0 * (b.x - a.x), a.y + t0 * (b.y - a.y)}, {a.x + t1 * (b.x - a.x), a.y + t1 * (b.y - a.y)}, c,
               th);
        }
        s += step;
        phase = std::fmod(phase + step, on + off);
      }
    }
  }
  void polygon(const std::vector<P>& pts, Rgb c, double alpha) override {
    if (pts.size() < 3) return;
    std::vector<cv::Point> q;
    int x0 = m_.cols, y0 = m_.rows, x1 = 0, y1 = 0;
    for (const P& p : pts) {
      q.push_back(fixed(p));
      x0 = std::min(x0, static_cast<int>(std::floor(p.x))), x1 = std::max(x1, static_cast<int>(std::ceil(p.x)));
      y0 = std::min(y0, static_cast<int>(std::floor(p.y))), y1 = std::max(y1, static_cast<int>(std::ceil(p.y)));
    }
    const cv::Rect roi = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1) & cv::Rect(0, 0, m_.cols, m_.rows);
    if (roi.area() <= 0) return;
    cv::Mat mask = cv::Mat::zeros(roi.size(), CV_8UC1);
    for (auto& p : q) p -= cv::Point(roi.x << kShift, roi.y << kShift);
    const cv::Point* poly[] = {q.data()};
    const int n = static_cast<int>(q.size());
    cv::fillPoly(mask, poly, &n, 1, cv::Scalar(255), cv::LINE_AA, kShift);
    cv::Mat area = m_(roi);
    const double col[3] = {static_cast<double>(c.r), static_cast<double>(c.g), static_cast<double>(c.b)};
    for (int y = 0; y < area.rows; ++y) {
      const uint8_t* mk = mask.ptr<uint8_t>(y);
      uint8_t* px = area.ptr<uint8_t>(y);
      for (int x = 0; x < area.cols; ++x) {
        if (!mk[x]) continue;
        const double w = alpha * mk[x] / 255.0;
        for (int k = 0; k < 3; ++k) px[3 * x + k] = static_cast<uint8_t>(std::lround((1 - w) * px[3 * x + k] + w * col[k]));
      }
    }
  }
  void marker(P p, Mark shape, double r, Rgb c) override {
    if (shape == Mark::Squares) {
      cv::rectangle(m_, fixed({p.x - r, p.y - r}), fixed({p.x + r, p.y + r}), scalar(c), cv::FILLED, cv::LINE_AA, kShift);
    } else if (shape == Mark::Triangles) {
      const cv::Point t[3] = {fixed({p.x, p.y - r}), fixed({p.x - r, p.y + r}), fixed({p.x + r, p.y + r})};
      cv::fillConvexPoly(m_, t, 3, scalar(c), cv::LINE_AA, kShift);
    } else {
      cv::circle(m_, fixed(p), static_cast<int>(std::lround(r * (1 << kShift))), scalar(c), cv::FILLED, cv::LINE_AA,
                 kShift);
    }
  }
  void rect(double x, double y, double w, double h, Rgb stroke, bool fill_white) override {
    const cv::Rect r(static_cast<int>(std::lround(x)), static_cast<int>(std::lround(y)), static_cast<int>(std::lround(w)),
                     static_cast<int>(std::lround(h)));
    if (fill_white) cv::rectangle(m_, r, cv::Scalar(255, 255, 255), cv::FILLED);
    cv::rectangle(m_, r, scalar(stroke), 1);
  }
  void text(double x, double y, const std::string& t, double size, Anchor a, Rgb c, bool vertical) override {
    const std::vector<TextPart> parts = parseText(t);
    const double w = textWidth(t, size);
    const double shift = a == Anchor::Left ? 0 : a == Anchor::Centre ? w / 2.0 : w;
    if (!vertical) {
      drawParts(m_, parts, x - shift, y, size, c);
      return;
    }
    // Vertical: drawn on its own strip, turned a quarter left, darkened into the image (text is dark on white).
    const int iw = static_cast<int>(std::ceil(w)) + 4, ih = static_cast<int>(std::ceil(1.3 * size)) + 4;
    cv::Mat strip(ih, iw, CV_8UC3, cv::Scalar(255, 255, 255));
    drawParts(strip, parts, 2, ih - 0.3 * size - 2, size, c);
    cv::Mat turned;
    cv::rotate(strip, turned, cv::ROTATE_90_COUNTERCLOCKWISE);
    const int left = static_cast<int>(std::lround(x - ih + 0.3 * size + 2)), top = static_cast<int>(std::lround(y - iw + shift + 2));
    const cv::Rect dst = cv::Rect(left, top, turned.cols, turned.rows) & cv::Rect(0, 0, m_.cols, m_.rows);
    if (dst.area() <= 0) return;
    cv::Mat part = turned(cv::Rect(dst.x - left, dst.y - top, dst.width, dst.height));
    cv::Mat target = m_(dst);
    cv::min(target, part, target);
  }
  double textWidth(const std::string& t, double size) override {
    double w = 0;
    int bl = 0;
    for (const TextPart& p : parseText(t)) w += cv::getTextSize(p.s, kFont, scaleOf(size, p.sup), 1, &bl).width + (p.sup ? 1 : 0);
    return w;
  }

 private:
  static constexpr int kShift = 4;  // sub-pixel bits of OpenCV's fixed-point coordinates
  static constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
  static cv::Point fixed(P p) {
    return cv::Point(static_cast<int>(std::lround(p.x * (1 << kShift))), static_cast<int>(std::lround(p.y * (1 << kShift))));
  }
  static cv::Scalar scalar(Rgb c) { return cv::Scalar(c.r, c.g, c.b); }  // the buffer is RGB
  static double scaleOf(double size, bool sup) { return (sup ? 0.75 : 1.0) * size / 26.0; }  // Hershey: ~26 px at 1
  static void drawParts(cv::Mat& m, const std::vector<TextPart>& parts, double x, double y, double size, Rgb c) {
    int bl = 0;
    for (const TextPart& p : parts) {
      const double sc = scaleOf(size, p.sup);
      const double yy = p.sup ? y - 0.45 * size : y;
      if (p.sup) x += 1;
      cv::putText(m, p.s, cv::Point(static_cast<int>(std::lround(x)), static_cast<int>(std::lround(yy))), kFont, sc,
                  scalar(c), 1, cv::LINE_AA);
      x += cv::getTextSize(p.s, kFont, sc, 1, &bl).width;
    }
  }
  void line(P a, P b, Rgb c, int th) { cv::line(m_, fixed(a), fixed(b), scalar(c), th, cv::LINE_AA, kShift); }
  cv::Mat& m_;
};
#endif

/// Decade tick labels as 10^{k}, others as plain numbers.
void tickLabel(Painter& p, double x, double y, double value, double size, Anchor a) {
  const double e = std::log10(value);
  char buf[32];
  if (std::abs(e - std::round(e)) < 1e-9) {
    std::snprintf(buf, sizeof buf, "10^{%d}", static_cast<int>(std::lround(e)));
  } else {
    std::snprintf(buf, sizeof buf, "%g", value);
  }
  p.text(x, y, buf, size, a, kBlack, false);
}

bool usable(double v) { return std::isfinite(v) && v > 0; }

/// One panel at (ox, oy), w x h.
void drawPanel(Painter& pt, const Panel& panel, double ox, double oy, double w, double h) {
  const bool has_note = !panel.note.empty();
  const double left = 64, right = 12, top = has_note ? 44 : 30, bottom = 40;
  const double bx = ox + left, by = oy + top, bw = w - left - right, bh = h - top - bottom;
  pt.text(bx + bw / 2, oy + 18, panel.title, 13, Anchor::Centre, panel.alert ? kRed : kBlack, false);
  if (has_note) pt.text(bx + bw / 2, oy + 33, panel.note, 10, Anchor::Centre, kGray, false);
  double xmin = INFINITY, xmax = 0, ymin = INFINITY, ymax = 0;
  for (const Layer& l : panel.layers)
    for (size_t i = 0; i < l.x.size(); ++i) {
      if (!usable(l.x[i])) continue;
      xmin = std::min(xmin, l.x[i]), xmax = std::max(xmax, l.x[i]);
      if (!l.sets_range) continue;
      for (double v : {i < l.y.size() ? l.y[i] : NAN, i < l.y_hi.size() ? l.y_hi[i] : NAN})
        if (usable(v)) ymin = std::min(ymin, v), ymax = std::max(ymax, v);
    }
  if (!(xmax > 0) || !(ymax > 0)) {
    pt.rect(bx, by, bw, bh, kBlack, false);
    pt.text(bx + bw / 2, by + bh / 2, "waiting for data", 13, Anchor::Centre, kGray, false);
    return;
  }
  // Log axes: x over the data widened by 1.5x each side, y from half the lowest to twice the highest value.
  const double lx0 = std::log10(xmin / 1.5), lx1 = std::max(lx0 + 0.5, std::log10(xmax * 1.5));
  const double ly0 = std::log10(ymin / 2), ly1 = std::max(ly0 + 0.5, std::log10(ymax * 2));
  auto px = [&](double x) { return bx + (std::log10(x) - lx0) / (lx1 - lx0) * bw; };
  auto py = [&](double y) { return by + bh - (std::log10(y) - ly0) / (ly1 - ly0) * bh; };
  // Grid: every 1..9 x 10^k inside, decades darker and labelled (and 2, 5 x 10^k when fewer than two decades show).
  auto grid = [&](double l0, double l1, bool is_x) {
    int decades = 0;
    for (int d = static_cast<int>(std::ceil(l0 - 1e-9)); d <= l1 + 1e-9; ++d) ++decades;
    for (int d = static_cast<int>(std::floor(l0)); d <= l1; ++d)
      for (int k = 1; k <= 9; ++k) {
        const double v = k * std::pow(10.0, d), lv = std::log10(v);
        if (lv < l0 - 1e-9 || lv > l1 + 1e-9) continue;
        const bool major = k == 1;
        const bool labelled = major || (decades < 2 && (k == 2 || k == 5));
        if (is_x) {
          const double x = px(v);
          pt.polyline({{x, by}, {x, by + bh}}, major ? kGrid : kMinorGrid, 1, Mark::Line);
          if (labelled) tickLabel(pt, x, by + bh + 15, v, 10, Anchor::Centre);
        } else {
          const double y = py(v);
          pt.polyline({{bx, y}, {bx + bw, y}}, major ? kGrid : kMinorGrid, 1, Mark::Line);
          if (labelled) tickLabel(pt, bx - 4, y + 4, v, 10, Anchor::Right);
        }
      }
  };
  grid(lx0, lx1, true);
  grid(ly0, ly1, false);
  pt.text(bx + bw / 2, by + bh + 33, panel.xlabel, 11, Anchor::Centre, kBlack, false);
  if (!panel.ylabel.empty()) pt.text(ox + 14, by + bh / 2, panel.ylabel, 11, Anchor::Centre, kBlack, true);
  std::vector<P> occupied;  // where the data are (the legend avoids them)
  for (const Layer& l : panel.layers) {
    const size_t n = std::min(l.x.size(), l.y.size());
    if (l.mark == Mark::Band) {
      std::vector<P> lo, hi;
      auto flush = [&]() {
        if (lo.size() >= 2) {
          std::vector<P> poly = lo;
          poly.insert(poly.end(), hi.rbegin(), hi.rend());
          pt.polygon(poly, l.color, 0.22);
        }
        lo.clear(), hi.clear();
      };
      for (size_t i = 0; i < n && i < l.y_hi.size(); ++i) {
        if (!usable(l.x[i]) || !usable(l.y[i]) || !usable(l.y_hi[i])) {
          flush();
          continue;
        }
        const double x = px(l.x[i]);
        lo.push_back({x, std::min(by + bh, std::max(by, py(l.y[i])))});
        hi.push_back({x, std::min(by + bh, std::max(by, py(l.y_hi[i])))});
        if (l.sets_range) occupied.push_back(lo.back()), occupied.push_back(hi.back());
      }
      flush();
    } else if (l.mark == Mark::Line || l.mark == Mark::Dashed || l.mark == Mark::Dotted) {
      std::vector<P> run;
      auto flush = [&]() {
        if (run.size() >= 2) pt.polyline(run, l.color, l.width, l.mark);
        run.clear();
      };
      bool have_prev = false;
      P prev;
      for (size_t i = 0; i < n; ++i) {
        if (!usable(l.x[i]) || !usable(l.y[i])) {
          flush();
          have_prev = false;
          continue;
        }
        const P cur{px(l.x[i]), py(l.y[i])};
        if (have_prev) {
          P a = prev, b = cur;
          if (clipSegment(&a, &b, bx, by, bx + bw, by + bh)) {
            if (run.empty() || std::hypot(run.back().x - a.x, run.back().y - a.y) > 1e-6) {
              flush();
              run.push_back(a);
            }
            run.push_back(b);
            if (l.sets_range) occupied.push_back(b);
          } else {
            flush();
          }
        }
        prev = cur, have_prev = true;
      }
      flush();
    } else {
      const double r = l.mark == Mark::Dots ? 2.6 : 2.2;
      for (size_t i = 0; i < n; ++i) {
        if (!usable(l.x[i]) || !usable(l.y[i])) continue;
        const P c{px(l.x[i]), py(l.y[i])};
        if (c.y < by || c.y > by + bh) continue;
        pt.marker(c, l.mark, r, l.color);
        occupied.push_back(c);
      }
    }
  }
  pt.rect(bx, by, bw, bh, kBlack, false);
  // Legend: one row per labelled layer, in the corner of the box with the fewest data points under it.
  std::vector<const Layer*> entries;
  std::set<std::string> seen;
  for (const Layer& l : panel.layers)
    if (!l.label.empty() && seen.insert(l.label).second) entries.push_back(&l);
  if (entries.empty()) return;
  const double row = 13, sample = 22;
  double lw = 0;
  for (const Layer* l : entries) lw = std::max(lw, pt.textWidth(l->label, 9));
  lw += sample + 14;
  const double lh = row * static_cast<double>(entries.size()) + 6;
  const P corners[4] = {{bx + bw - lw - 5, by + 5}, {bx + 5, by + bh - lh - 5}, {bx + 5, by + 5},
                        {bx + bw - lw - 5, by + bh - lh - 5}};
  int best = 0;
  size_t best_count = SIZE_MAX;
  for (int c = 0; c < 4; ++c) {
    size_t count = 0;
    for (const P& q : occupied)
      count += q.x >= corners[c].x && q.x <= corners[c].x + lw && q.y >= corners[c].y && q.y <= corners[c].y + lh;
    if (count < best_count) best = c, best_count = count;
  }
  const P at = corners[best];
  pt.rect(at.x, at.y, lw, lh, Rgb{190, 190, 190}, true);
  for (size_t i = 0; i < entries.size(); ++i) {
    const Layer& l = *entries[i];
    const double y = at.y + 3 + row * (static_cast<double>(i) + 0.5);
    const double x0 = at.x + 5, x1 = x0 + sample;
    if (l.mark == Mark::Band) {
      pt.polygon({{x0, y - 4}, {x1, y - 4}, {x1, y + 4}, {x0, y + 4}}, l.color, 0.22);
    } else if (l.mark == Mark::Line || l.mark == Mark::Dashed || l.mark == Mark::Dotted) {
      pt.polyline({{x0, y}, {x1, y}}, l.color, l.width, l.mark);
    } else {
      pt.marker({(x0 + x1) / 2, y}, l.mark, 2.2, l.color);
    }
    pt.text(x1 + 5, y + 3.5, l.label, 9, Anchor::Left, kBlack, false);
  }
}

void checkSize(const Figure& f) {
  const int cols = std::max(1, f.columns);
  const int rows = static_cast<int>((f.panels.size() + static_cast<size_t>(cols) - 1) / static_cast<size_t>(cols));
  if (f.panel_width < 200 || f.panel_height < 150 || f.panel_width * cols > 4096 || f.panel_height * std::max(1, rows) > 4096)
    throw std::invalid_argument("plot size " + std::to_string(f.panel_width * cols) + "x" +
                                std::to_string(f.panel_height * std::max(1, rows)) + " (panels " +
                                std::to_string(f.panel_width) + "x" + std::to_string(f.panel_height) +
                                ") outside 200x150 per panel .. 4096x4096");
}

void drawFigure(Painter& p, const Figure& f) {
  const int cols = std::max(1, f.columns);
  for (size_t i = 0; i < f.panels.size(); ++i) {
    const Panel& panel = f.panels[i];
    if (panel.title.empty() && panel.layers.empty()) continue;
    drawPanel(p, panel, static_cast<double>(static_cast<int>(i) % cols * f.panel_width),
              static_cast<double>(static_cast<int>(i) / cols * f.panel_height), f.panel_width, f.panel_height);
  }
}

int figureWidth(const Figure& f) { return std::max(1, f.columns) * f.panel_width; }
int figureHeight(const Figure& f) {
  const size_t cols = static_cast<size_t>(std::max(1, f.columns));
  return static_cast<int>(std::max<size_t>(1, (f.panels.size() + cols - 1) / cols)) * f.panel_height;
}

void appendChunk(std::string* out, const char* type, const std::string& data) {
  const uint32_t n = static_cast<uint32_t>(data.size());
  const unsigned char len[4] = {static_cast<unsigned char>(n >> 24), static_cast<unsigned char>(n >> 16),
                                static_cast<unsigned char>(n >> 8), static_cast<unsigned char>(n)};
  out->append(reinterpret_cast<const char*>(len), 4);
  const size_t start = out->size();
  out->append(type, 4);
  out->append(data);
  const uLong crc = crc32(0L, reinterpret_cast<const Bytef*>(out->data() + start), static_cast<uInt>(4 + data.size()));
  const unsigned char c[4] = {static_cast<unsigned char>(crc >> 24), static_cast<unsigned char>(crc >> 16),
                              static_cast<unsigned char>(crc >> 8), static_cast<unsigned char>(crc)};
  out->append(reinterpret_cast<const char*>(c), 4);
}

// Figure colours (the "tab10" palette).
const Rgb kBlue{31, 119, 180}, kBrown{140, 86, 75}, kCyan{23, 190, 207}, kGrayData{127, 127, 127};
const Rgb kTermColors[kNumTerms] = {{148, 103, 189}, {44, 160, 44}, {188, 189, 34}, {255, 127, 14}, {214, 39, 40}};
const char* kTermSlopes[kNumTerms] = {"slope -1", "slope -1/2", "slope 0", "slope +1/2", "slope +1"};

Layer curveLayer(const DeviationCurve& c, Mark mark, Rgb color, const std::string& label) {
  Layer l;
  l.mark = mark, l.color = color, l.label = label;
  for (const auto& p : c.points) {
    l.x.push_back(p.tau);
    l.y.push_back(mark == Mark::Band ? p.dev_lo : p.dev);
    if (mark == Mark::Band) l.y_hi.push_back(p.dev_hi);
  }
  return l;
}

Layer varianceLine(const DeviationCurve& c, const std::vector<double>& var, Mark mark, Rgb color, double width,
                   const std::string& label) {
  Layer l;
  l.mark = mark, l.color = color, l.label = label, l.width = width;
  for (size_t i = 0; i < c.points.size() && i < var.size(); ++i) {
    l.x.push_back(c.points[i].tau);
    l.y.push_back(var[i] > 0 ? std::sqrt(var[i]) : NAN);
  }
  return l;
}

Panel axisPanel(const AxisAnalysis& a, bool gyro) {
  Panel p;
  const std::string sensor = gyro ? "gyro" : "accelerometer";
  const std::string name = !gyro && a.axis.rfind("accel_", 0) == 0 ? a.axis.substr(6) : a.axis;
  const Quality q = a.quality.quality;
  p.title = sensor + " " + name + " (" + methodName(a.method) + (q == Quality::Bad ? ", BAD FIT" : q == Quality::Doubtful ? ", doubtful" : "") + ")";
  p.alert = q == Quality::Bad;
  p.ylabel = gyro ? "Allan deviation [rad/s]" : "Allan deviation [m/s^{2}]";
  if (a.oadev.points.empty()) {
    p.note = "no oadev";
    return p;
  }
  p.layers.push_back(curveLayer(a.oadev, Mark::Band, kBlue, "95 % interval"));
  p.layers.push_back(curveLayer(a.oadev, Mark::Dots, kBlue, "oadev"));
  if (a.has_split && a.split.ok) {
    p.layers.push_back(curveLayer(a.split.denoised_curve, Mark::Squares, kCyan, "wavelet: denoised"));
    p.layers.push_back(curveLayer(a.split.removed_curve, Mark::Triangles, kGrayData, "wavelet: removed"));
  }
  for (int t = 0; t < kNumTerms; ++t) {
    const Coefficient& c = a.coefficients[static_cast<size_t>(t)];
    if (!c.supported || !(c.value > 0)) continue;
    std::vector<double> var;
    for (const auto& pt : a.oadev.points) var.push_back(c.value * c.value * noiseTermBasis(t, pt.tau, a.oadev.tau0));
    const double factor = gyro ? conventionalFactor(t) : accelConventionalFactor(t);
    const char* unit = gyro ? conventionalUnit(t) : accelConventionalUnit(t);
    static const char* gyro_names[kNumTerms] = {"Q", "N", "B", "K", "R"};
    static const char* accel_names[kNumTerms] = {"Q", "VRW", "B", "AccRW", "R"};  // as the summary table names them
    char label[96];
    std::snprintf(label, sizeof label, "%s %.3g %s (%s)", (gyro ? gyro_names : accel_names)[t], c.value * factor, unit,
                  kTermSlopes[t]);
    Layer l = varianceLine(a.oadev, var, Mark::Dotted, kTermColors[t], 1.3, label);
    l.sets_range = false;
    p.layers.push_back(l);
  }
  if (a.has_check && !a.check.effects.empty()) {
    std::string added;
    for (const auto& e : a.check.effects) added += (added.empty() ? "" : ", ") + e.type;
    p.layers.push_back(varianceLine(a.oadev, a.check.model_var_after, Mark::Dashed, kBrown, 1.2, "model check (+" + added + ")"));
  }
  p.layers.push_back(varianceLine(a.oadev, a.final_model_var, Mark::Line, kBlack, 1.6, "reported model"));
  return p;
}

}  // namespace

bool rasterAvailable() {
#ifdef GYRO_ALLAN_HAVE_OPENCV
  return true;
#else
  return false;
#endif
}

std::string renderSvg(const Figure& f) {
  checkSize(f);
  SvgPainter p(figureWidth(f), figureHeight(f));
  drawFigure(p, f);
  return p.finish();
}

RgbImage renderRaster(const Figure& f) {
  checkSize(f);
#ifndef GYRO_ALLAN_HAVE_OPENCV
  throw std::invalid_argument("plot rendering to pixels unavailable: built without OpenCV (libopencv-imgproc-dev)");
#else
  RgbImage img;
  img.width = figureWidth(f);
  img.height = figureHeight(f);
  img.data.assign(static_cast<size_t>(img.width) * static_cast<size_t>(img.height) * 3, 255);
  cv::Mat m(img.height, img.width, CV_8UC3, img.data.data());  // wraps the buffer: drawing fills img.data (RGB)
  CvPainter p(&m);
  drawFigure(p, f);
  return img;
#endif
}

std::string encodePng(const RgbImage& im) {
  if (im.width <= 0 || im.height <= 0 || im.data.size() != static_cast<size_t>(im.width) * im.height * 3)
    throw std::invalid_argument("encodePng: image size does not match its buffer");
  const size_t stride = static_cast<size_t>(im.width) * 3;
  std::string raw;
  raw.reserve((stride + 1) * static_cast<size_t>(im.height));
  for (int y = 0; y < im.height; ++y) {
    raw.push_back('\0');  // filter type 0 (none) per scanline
    raw.append(reinterpret_cast<const char*>(im.data.data() + static_cast<size_t>(y) * stride), stride);
  }
  uLongf zlen = compressBound(static_cast<uLong>(raw.size()));
  std::string z(zlen, '\0');
  if (compress2(reinterpret_cast<Bytef*>(&z[0]), &zlen, reinterpret_cast<const Bytef*>(raw.data()),
                static_cast<uLong>(raw.size()), 6) != Z_OK)
    throw std::runtime_error("encodePng: zlib compression failed");
  z.resize(zlen);
  std::string out("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr(13, '\0');
  const uint32_t w = static_cast<uint32_t>(im.width), h = static_cast<uint32_t>(im.height);
  for (int i = 0; i < 4; ++i) {
    ihdr[static_cast<size_t>(i)] = static_cast<char>(w >> (24 - 8 * i));
    ihdr[static_cast<size_t>(4 + i)] = static_cast<char>(h >> (24 - 8 * i));
  }
  ihdr[8] = 8;  // bit depth
  ihdr[9] = 2;  // colour type RGB; compression, filter and interlace methods 0
  appendChunk(&out, "IHDR", ihdr);
  appendChunk(&out, "IDAT", z);
  appendChunk(&out, "IEND", "");
  return out;
}

Figure analysisFigure(const std::vector<AxisAnalysis>& gyro, const std::vector<AxisAnalysis>& accel) {
  Figure f;
  f.columns = static_cast<int>(std::max<size_t>(1, std::max(gyro.size(), accel.size())));
  for (const auto* sensor : {&gyro, &accel}) {
    if (sensor->empty()) continue;
    for (int c = 0; c < f.columns; ++c)
      f.panels.push_back(static_cast<size_t>(c) < sensor->size() ? axisPanel((*sensor)[static_cast<size_t>(c)], sensor == &gyro)
                                                                 : Panel{});
  }
  // Panels narrow enough for the 4096 px limit when a CSV has many columns.
  f.panel_width = std::max(200, std::min(500, 4096 / f.columns));
  return f;
}

Figure windowFigure(const std::vector<AxisAnalysis>& axes, const std::string& title, const std::string& note, int width,
                    int height) {
  const Rgb colors[] = {kRed, {44, 160, 44}, kBlue, {148, 103, 189}};
  Figure f;
  f.panel_width = width, f.panel_height = height;
  Panel p;
  p.title = title, p.note = note, p.ylabel = "Allan deviation [rad/s]";
  bool any_model = false;
  for (size_t s = 0; s < axes.size(); ++s) {
    const AxisAnalysis& a = axes[s];
    const Rgb c = colors[s % 4];
    p.layers.push_back(curveLayer(a.oadev, Mark::Band, c, ""));
    p.layers.push_back(curveLayer(a.oadev, Mark::Dots, c, a.axis));
    if (a.final_model_var.size() != a.oadev.points.size()) continue;
    p.layers.push_back(varianceLine(a.oadev, a.final_model_var, Mark::Line, c, 1.2, ""));
    any_model = true;
  }
  if (any_model) {  // one legend entry for the model lines
    Layer key;
    key.mark = Mark::Line, key.color = kBlack, key.width = 1.2, key.label = "model (lines)";
    p.layers.push_back(key);
  }
  f.panels.push_back(p);
  return f;
}

std::string writeFigure(const std::string& dir, const Figure& f) {
  writeFileAtomic(dir + "/allan.svg", renderSvg(f));
  if (!rasterAvailable()) return "built without OpenCV (libopencv-imgproc-dev): allan.svg only";
  writeFileAtomic(dir + "/allan.png", encodePng(renderRaster(f)));
  return "";
}

}  // namespace gyro_allan
