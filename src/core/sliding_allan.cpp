// Sliding-window overlapping Allan variance (see sliding_allan.hpp): ring buffer, running and rebuilt sums per m.
#include "gyro_allan/sliding_allan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace gyro_allan {

SlidingAllan::SlidingAllan(const SlidingAllanOptions& options) : opt_(options) {
  if (!(std::isfinite(opt_.tau0) && opt_.tau0 > 0))
    throw std::invalid_argument("SlidingAllan: tau0 must be finite and > 0");
  if (opt_.window_samples < 2)
    throw std::invalid_argument("SlidingAllan: window_samples must be >= 2");
  if (opt_.window_samples > (int64_t(1) << 40))
    throw std::invalid_argument("SlidingAllan: window_samples too large");
  if (opt_.recompute_steps < 2)
    throw std::invalid_argument("SlidingAllan: recompute_steps must be >= 2");
  if (!(opt_.confidence > 0 && opt_.confidence < 1))
    throw std::invalid_argument("SlidingAllan: confidence must be in (0, 1)");
  m_ = tauGridFactors(opt_.grid, opt_.window_samples / 2);
  if (m_.empty()) throw std::invalid_argument("SlidingAllan: tau grid has no averaging factor");
  cap_ = opt_.window_samples + 1;
  // The ring starts small and doubles as the window fills (a long window costs memory only once it holds samples).
  int64_t size = 1;
  while (size < std::min<int64_t>(cap_ + 1, int64_t(1) << 16)) size <<= 1;
  buf_.assign(static_cast<size_t>(size), 0.0);
  mask_ = size - 1;
  sum_.assign(m_.size(), 0.0L);
  fresh_.assign(m_.size(), 0.0L);
  count_.assign(m_.size(), 0);
  fresh_count_.assign(m_.size(), 0);
}

void SlidingAllan::reset() {
  head_ = start_ = cursor_ = 0;
  seg_.clear();
  new_segment_ = true;
  phase_ = 0;
  std::fill(sum_.begin(), sum_.end(), 0.0L);
  std::fill(fresh_.begin(), fresh_.end(), 0.0L);
  std::fill(count_.begin(), count_.end(), 0);
  std::fill(fresh_count_.begin(), fresh_count_.end(), 0);
  total_ = 0;
}

void SlidingAllan::newSegment() { new_segment_ = true; }

int64_t SlidingAllan::segmentEnd(int64_t i) const {
  auto it = std::upper_bound(seg_.begin(), seg_.end(), i);
  return it == seg_.end() ? std::numeric_limits<int64_t>::max() : *it;
}

void SlidingAllan::removeOldest() {
  const int64_t s = start_;
  const int64_t end = std::min(segmentEnd(s), head_);
  const bool in_fresh = s < cursor_;
  for (size_t k = 0; k < m_.size(); ++k) {
    const int64_t m = m_[k];
    if (s + 2 * m >= end) break;  // m ascending: no longer term exists either
    const double t = term(s, m);
    sum_[k] -= t;
    --count_[k];
    if (in_fresh) {
      fresh_[k] -= t;
      --fresh_count_[k];
    }
  }
  ++start_;
  while (seg_.size() > 1 && seg_[1] <= start_) seg_.pop_front();
}

void SlidingAllan::pushPhase(double x) {
  if (head_ - start_ >= cap_) removeOldest();
  if (head_ - start_ + 1 > mask_) {  // full ring (it holds at most mask_ points): twice the size, same indices
    std::vector<double> bigger(buf_.size() * 2);
    const int64_t mask = static_cast<int64_t>(bigger.size()) - 1;
    for (int64_t i = start_; i < head_; ++i) bigger[static_cast<size_t>(i & mask)] = buf_[static_cast<size_t>(i & mask_)];
    buf_.swap(bigger);
    mask_ = mask;
  }
  const int64_t n = head_;
  buf_[n & mask_] = x;
  ++head_;
  const int64_t lo = std::max(start_, seg_.back());
  for (size_t k = 0; k < m_.size(); ++k) {
    const int64_t i = n - 2 * m_[k];
    if (i < lo) break;
    const double t = term(i, m_[k]);
    sum_[k] += t;
    ++count_[k];
    if (i < cursor_) {
      fresh_[k] += t;
      ++fresh_count_[k];
    }
  }
  advanceCursor();
}

void SlidingAllan::advanceCursor() {
  for (int step = 0; step < opt_.recompute_steps; ++step) {
    if (cursor_ < start_) cursor_ = start_;
    const int64_t newest = head_ - 1;
    if (cursor_ + 2 > newest) {
      // Every available term starts before the cursor: the rebuilt sums are complete and exact.
      sum_ = fresh_;
      count_ = fresh_count_;
      ++recomputes_;
      std::fill(fresh_.begin(), fresh_.end(), 0.0L);
      std::fill(fresh_count_.begin(), fresh_count_.end(), 0);
      cursor_ = start_;
      return;
    }
    const int64_t i = cursor_;
    const int64_t end = std::min(segmentEnd(i), head_);
    for (size_t k = 0; k < m_.size(); ++k) {
      const int64_t m = m_[k];
      if (i + 2 * m >= end) break;
      fresh_[k] += term(i, m);
      ++fresh_count_[k];
    }
    ++cursor_;
  }
}

void SlidingAllan::recomputeNow() {
  std::fill(sum_.begin(), sum_.end(), 0.0L);
  std::fill(count_.begin(), count_.end(), 0);
  for (int64_t i = start_; i + 2 <= head_ - 1; ++i) {
    const int64_t end = std::min(segmentEnd(i), head_);
    for (size_t k = 0; k < m_.size(); ++k) {
      const int64_t m = m_[k];
      if (i + 2 * m >= end) break;
      sum_[k] += term(i, m);
      ++count_[k];
    }
  }
  std::fill(fresh_.begin(), fresh_.end(), 0.0L);
  std::fill(fresh_count_.begin(), fresh_count_.end(), 0);
  cursor_ = start_;
}

void SlidingAllan::addRate(double rate) {
  if (!std::isfinite(rate)) throw std::invalid_argument("SlidingAllan::addRate: non-finite sample");
  if (new_segment_) {
    new_segment_ = false;
    angle_input_ = false;
    rate_ref_ = rate;
    phase_ = 0;
    seg_.push_back(head_);
    pushPhase(0.0);
  }
  phase_ += static_cast<long double>(rate - rate_ref_) * static_cast<long double>(opt_.tau0);
  pushPhase(static_cast<double>(phase_));
  ++total_;
}

void SlidingAllan::addIncrement(double increment) {
  if (!std::isfinite(increment)) throw std::invalid_argument("SlidingAllan::addIncrement: non-finite sample");
  addRate(increment / opt_.tau0);
}

void SlidingAllan::addAngle(double angle) {
  if (!std::isfinite(angle)) throw std::invalid_argument("SlidingAllan::addAngle: non-finite sample");
  if (new_segment_) {
    new_segment_ = false;
    angle_input_ = true;
    angle_ref_ = angle;
    seg_.push_back(head_);
  }
  pushPhase(angle - angle_ref_);
  ++total_;
}

std::vector<double> SlidingAllan::newestSegmentRates(int64_t max_samples) const {
  std::vector<double> out;
  if (seg_.empty()) return out;
  int64_t first = std::max(seg_.back(), start_);
  if (max_samples > 0) first = std::max(first, head_ - 1 - max_samples);
  if (head_ - first < 2) return out;
  out.reserve(static_cast<size_t>(head_ - first - 1));
  const double ref = angle_input_ ? 0.0 : rate_ref_;
  for (int64_t k = first; k + 1 < head_; ++k)
    out.push_back((buf_[(k + 1) & mask_] - buf_[k & mask_]) / opt_.tau0 + ref);
  return out;
}

int64_t SlidingAllan::samples() const {
  const int64_t p = phasePoints();
  const int64_t s = static_cast<int64_t>(seg_.size());
  return p > s ? p - s : 0;
}

double SlidingAllan::fill() const {
  return std::min(1.0, static_cast<double>(samples()) / static_cast<double>(opt_.window_samples));
}

size_t SlidingAllan::memoryBytes() const {
  return buf_.capacity() * sizeof(double) + (sum_.capacity() + fresh_.capacity()) * sizeof(long double) +
         (count_.capacity() + fresh_count_.capacity() + m_.capacity()) * sizeof(int64_t) +
         seg_.size() * sizeof(int64_t);
}

DeviationCurve SlidingAllan::curve() const {
  DeviationCurve c;
  c.name = "oadev";
  c.tau0 = opt_.tau0;
  c.n_phase = phasePoints();
  for (size_t k = 0; k < m_.size(); ++k) {
    if (count_[k] <= 0) continue;
    DeviationPoint p;
    p.m = m_[k];
    p.tau = static_cast<double>(m_[k]) * opt_.tau0;
    p.n_terms = count_[k];
    const long double s = std::max(sum_[k], 0.0L);
    p.var = static_cast<double>(s / (2.0L * static_cast<long double>(p.tau) * p.tau * count_[k]));
    p.dev = std::sqrt(p.var);
    p.alpha = opt_.alpha;
    c.points.push_back(p);
  }
  if (opt_.alpha_from_slope && c.points.size() >= 2) {
    // Least-squares log-log slope over the points within half a decade of tau on each side (neighbouring points
    // alone are too noisy at long tau), mapped to the power-law exponent of the dominant noise.
    const size_t n = c.points.size();
    std::vector<double> lt(n), lv(n);
    for (size_t j = 0; j < n; ++j) {
      lt[j] = std::log10(c.points[j].tau);
      lv[j] = c.points[j].var > 0 ? std::log10(c.points[j].var) : std::nan("");
    }
    for (size_t j = 0; j < n; ++j) {
      double sx = 0, sy = 0, sxx = 0, sxy = 0;
      int k = 0;
      for (size_t i = 0; i < n; ++i) {
        if (std::fabs(lt[i] - lt[j]) > 0.5 || !std::isfinite(lv[i])) continue;
        sx += lt[i];
        sy += lv[i];
        sxx += lt[i] * lt[i];
        sxy += lt[i] * lv[i];
        ++k;
      }
      int alpha = opt_.alpha;
      const double den = k * sxx - sx * sx;
      if (k >= 2 && den > 0) {
        const double mu = (k * sxy - sx * sy) / den;
        if (mu < -1.5) alpha = 2;        // white (quantization) angle noise
        else if (mu < -0.5) alpha = 0;   // white rate noise (ARW)
        else if (mu < 0.5) alpha = -1;   // flicker rate noise (bias instability)
        else alpha = -2;                 // random-walk rate noise
      }
      c.points[j].alpha = alpha;
    }
  }
  if (opt_.compute_edf && !c.points.empty()) fillConfidence(&c, opt_.confidence);
  return c;
}

}  // namespace gyro_allan
