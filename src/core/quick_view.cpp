// QuickView: per-sample sliding overlapping Allan deviation of three axes and the IEEE fit of it (quick_view.hpp).
#include "gyro_allan/quick_view.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "gyro_allan/model_check.hpp"  // fitWithModelEdf

namespace gyro_allan {

QuickView::QuickView(const QuickViewOptions& options) : options_(options) {
  if (!(options_.window_s > 0) || !std::isfinite(options_.window_s)) throw std::invalid_argument("quick view: window_s must be > 0");
  if (options_.min_samples < 3) throw std::invalid_argument("quick view: min_samples must be >= 3");
}

void QuickView::reset() {
  pending_.clear();
  for (auto& e : engines_) e.reset();
  tau0_ = 0;
  first_ns_ = newest_ns_ = 0;
}

void QuickView::resetWithPeriod(double tau0) {
  if (!(tau0 > 0) || !std::isfinite(tau0)) throw std::invalid_argument("quick view: period must be > 0");
  reset();
  build(tau0);
}

void QuickView::build(double tau0) {
  tau0_ = tau0;
  SlidingAllanOptions so;
  so.tau0 = tau0;
  so.window_samples = std::max<int64_t>(2, std::llround(options_.window_s / tau0));
  so.grid = options_.deviation.grid;
  so.confidence = options_.deviation.confidence;
  for (auto& e : engines_) e = std::make_unique<SlidingAllan>(so);
}

void QuickView::add(int64_t stamp_ns, const std::array<double, 3>& g) {
  if (!engines_[0]) {
    if (stamp_ns == 0 || !std::isfinite(g[0]) || !std::isfinite(g[1]) || !std::isfinite(g[2])) return;
    if (!pending_.empty() && stamp_ns <= pending_.front().ns) {  // stamps going back before the first: start again
      pending_.clear();
    }
    pending_.push_back({stamp_ns, g});
    if (static_cast<int64_t>(pending_.size()) < options_.min_samples) return;
    // The period: least-squares slope of stamp against sample index (batched and jittered stamps scatter around it).
    const double n = static_cast<double>(pending_.size()), mid = (n - 1) / 2;
    double sxy = 0, sxx = 0;
    for (size_t i = 0; i < pending_.size(); ++i) {
      const double di = static_cast<double>(i) - mid;
      sxy += di * 1e-9 * static_cast<double>(pending_[i].ns - pending_.front().ns);
      sxx += di * di;
    }
    const double period = sxy / sxx;
    if (!(period > 0)) {
      pending_.erase(pending_.begin());
      return;
    }
    const std::vector<Pending> buffered = std::move(pending_);
    pending_.clear();
    build(period);
    for (const Pending& p : buffered) feed(p.ns, p.g);
    return;
  }
  feed(stamp_ns, g);
}

void QuickView::feed(int64_t ns, const std::array<double, 3>& g) {
  const bool bad = ns == 0 || !std::isfinite(g[0]) || !std::isfinite(g[1]) || !std::isfinite(g[2]);
  if (bad) {
    for (auto& e : engines_) e->newSegment();
    return;
  }
  if (first_ns_ == 0) {
    first_ns_ = ns;
    clock_s_ = -tau0_;
  }
  const double t = 1e-9 * static_cast<double>(ns - first_ns_);
  clock_s_ += tau0_;
  if (t - clock_s_ > std::max(10 * tau0_, 0.05)) {  // a gap: samples missing
    for (auto& e : engines_) e->newSegment();
    clock_s_ = t;
  }
  clock_s_ += 0.01 * (t - clock_s_);  // follows the stamps (a period estimated slightly off does not drift)
  newest_ns_ = std::max(newest_ns_, ns);
  for (int a = 0; a < 3; ++a) {
    SlidingAllan& e = *engines_[static_cast<size_t>(a)];
    if (options_.input == InputKind::Rate) e.addRate(g[static_cast<size_t>(a)]);
    else if (options_.angle_increments) e.addIncrement(g[static_cast<size_t>(a)]);
    else e.addAngle(g[static_cast<size_t>(a)]);
  }
}

bool QuickView::ready() const { return engines_[0] && engines_[0]->samples() >= options_.min_samples; }

QuickAnswer QuickView::curves() const {
  if (!ready()) throw std::logic_error("quick view: not ready");
  QuickAnswer q;
  q.newest_ns = newest_ns_;
  q.samples = engines_[0]->samples();
  q.segments = engines_[0]->segments();
  q.tau0 = tau0_;
  const char* names[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    AxisAnalysis a;
    a.axis = names[i];
    a.method = Method::QuickFit;
    a.oadev = engines_[static_cast<size_t>(i)]->curve();
    q.axes.push_back(std::move(a));
  }
  return q;
}

void QuickView::fit(QuickAnswer* q, const FitOptions& fit, double confidence) {
  FitOptions quick = fit;
  quick.intervals = false;  // the unified intervals cost ~50x the fit; the full analysis gives them every hop
  for (AxisAnalysis& a : q->axes) {
    if (a.oadev.points.empty()) continue;
    DeviationCurve weighted = a.oadev;
    a.fit = fitWithModelEdf(&weighted, quick, confidence);
    if (!a.fit.ok) continue;
    a.oadev = std::move(weighted);
    a.coefficients = a.fit.terms;
    a.final_model_var = a.fit.model_var;
    a.final_error = fitErrorOf(a.fit);
  }
}

size_t QuickView::memoryBytes() const {
  size_t b = pending_.capacity() * sizeof(Pending);
  for (const auto& e : engines_)
    if (e) b += e->memoryBytes();
  return b;
}

}  // namespace gyro_allan
