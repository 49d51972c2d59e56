// Spike detection and removal in gyro rate samples: one decision rule (candidate test, run classification, robust
// sigma) used by both the batch removeSpikes and the streaming SpikeFilter. Rule: include/gyro_allan/spikes.hpp.
#include "block_ranges.hpp"
#include "gyro_allan/spikes.hpp"
#include "gyro_allan/stats.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace gyro_allan {
namespace {

constexpr int64_t kScaleSamples = int64_t(1) << 16;  // the robust sigma uses 2^15-2^16 evenly spaced samples

/// Samples of one gap-free segment from index 0; data[j - base] holds sample j for j in [base, hi). `ended`: hi is
/// the segment's end (windows are cut there), else windows must lie inside [.., hi).
struct View {
  const double* data;
  int64_t base;
  int64_t hi;
  bool ended;
  double at(int64_t j) const { return data[j - base]; }
};

/// d_i: sample i minus the median of its +-h neighbours (itself excluded, the window cut at the segment ends).
double neighbourDev(const View& v, int64_t i, int h, std::vector<double>& w) {
  const int64_t lo = std::max<int64_t>(0, i - h), hi = std::min<int64_t>(v.hi, i + h + 1);
  w.clear();
  for (int64_t j = lo; j < hi; ++j)
    if (j != i) w.push_back(v.at(j));
  return v.at(i) - medianInPlace(w);
}

/// |d_i| > thr. A window (sample included) spanning at most thr cannot hold such a sample: checked first (cheap).
bool isCandidate(const View& v, int64_t i, int h, double thr, std::vector<double>& w) {
  const int64_t lo = std::max<int64_t>(0, i - h), hi = std::min<int64_t>(v.hi, i + h + 1);
  double mn = v.at(lo), mx = mn;
  for (int64_t j = lo + 1; j < hi; ++j) {
    const double y = v.at(j);
    mn = std::min(mn, y);
    mx = std::max(mx, y);
  }
  if (mx - mn <= thr) return false;
  return std::fabs(neighbourDev(v, i, h, w)) > thr;
}

/// Robust sigma from |d| of evenly spaced samples: max(MAD / 0.6745, q95 / 1.96), or the smallest nonzero |d| when
/// both are 0 (a quantized output whose d is mostly exactly 0), or 0 (nothing to measure against). Reorders ad.
double scaleFromAbsDev(std::vector<double>& ad) {
  if (ad.empty()) return 0;
  const double mad = medianInPlace(ad);
  const size_t k95 = static_cast<size_t>(std::floor(0.95 * static_cast<double>(ad.size() - 1)));
  std::nth_element(ad.begin(), ad.begin() + static_cast<long>(k95), ad.end());
  const double s = std::max(mad / kMadPerSigma, ad[k95] / kZ95);
  if (s > 0) return s;
  double smallest = 0;
  for (double a : ad)
    if (a > 0 && (smallest == 0 || a < smallest)) smallest = a;
  return smallest;
}

/// Power-of-two step giving at most 2^16 evenly spaced samples of `upto` (as many as possible).
int64_t scaleStep(int64_t upto) {
  int64_t step = 1;
  while ((upto + step - 1) / step > kScaleSamples) step *= 2;
  return step;
}

struct Rule {
  int h = 8;
  int max_run = 3;
  int sat = 5;
  double thr = 0;
  bool restore_noise = true;
};

/// Decision on a maximal run [s, e) of candidates (e - s <= max_run): spike or not, and the replacement value.
/// Needs the samples [s - max(h, sat), e + max(h, sat)) (cut at the segment ends).
bool classifyRun(const View& v, int64_t s, int64_t e, const Rule& r, std::vector<double>& w, double* replacement,
                 double* noise) {
  // Saturation: a sample in a run of >= sat identical values.
  for (int64_t k = s; k < e; ++k) {
    const double y = v.at(k);
    int64_t l = k, u = k;
    while (l > 0 && u - l + 1 < r.sat && v.at(l - 1) == y) --l;
    while (u + 1 < v.hi && u - l + 1 < r.sat && v.at(u + 1) == y) ++u;
    if (u - l + 1 >= r.sat) return false;
  }
  const int64_t l0 = std::max<int64_t>(0, s - r.h), r1 = std::min<int64_t>(v.hi, e + r.h);
  if (l0 == s && r1 == e) return false;
  // Far from both sides' levels: a bias step's edge samples are close to one of them.
  for (int side = 0; side < 2; ++side) {
    const int64_t a = side == 0 ? l0 : e, b = side == 0 ? s : r1;
    if (a == b) continue;
    w.clear();
    for (int64_t j = a; j < b; ++j) w.push_back(v.at(j));
    const double m = medianInPlace(w);
    for (int64_t k = s; k < e; ++k)
      if (!(std::fabs(v.at(k) - m) > r.thr)) return false;
  }
  w.clear();
  for (int64_t j = l0; j < s; ++j) w.push_back(v.at(j));
  for (int64_t j = e; j < r1; ++j) w.push_back(v.at(j));
  *replacement = medianInPlace(w);
  // Local noise sigma: MAD of the same neighbours about their median / 0.6745 (local, so batch and streaming agree
  // whatever sigma each estimated).
  if (r.restore_noise) {
    for (double& y : w) y = std::fabs(y - *replacement);
    *noise = medianInPlace(w) / kMadPerSigma;
  } else {
    *noise = 0;
  }
  return true;
}

/// Standard deviation and excess kurtosis about the mean (scaled by the largest deviation: no overflow).
void moments(const std::vector<double>& x, double* sd, double* kurt) {
  *sd = 0;
  *kurt = 0;
  if (x.empty()) return;
  long double sum = 0;
  for (double y : x) sum += y;
  const double mean = static_cast<double>(sum / static_cast<long double>(x.size()));
  double M = 0;
  for (double y : x) M = std::max(M, std::fabs(y - mean));
  if (!(M > 0) || !std::isfinite(M)) return;
  long double s2 = 0, s4 = 0;
  for (double y : x) {
    const long double u = (y - mean) / M, u2 = u * u;
    s2 += u2;
    s4 += u2 * u2;
  }
  const long double n = static_cast<long double>(x.size()), m2 = s2 / n, m4 = s4 / n;
  *sd = M * static_cast<double>(std::sqrt(m2));
  if (m2 > 0) *kurt = static_cast<double>(m4 / (m2 * m2)) - 3.0;
}

/// Central moments from sums of (x - shift)^k: sd and excess kurtosis.
void momentsFromSums(int64_t n, long double s1, long double s2, long double s3, long double s4, double* sd,
                     double* kurt) {
  *sd = 0;
  *kurt = 0;
  if (n <= 0) return;
  const long double N = static_cast<long double>(n), a = s1 / N;
  const long double m2 = s2 / N - a * a;
  const long double m4 = s4 / N - 4 * a * s3 / N + 6 * a * a * s2 / N - 3 * a * a * a * a;
  if (!(m2 > 0)) return;
  *sd = static_cast<double>(std::sqrt(m2));
  *kurt = static_cast<double>(m4 / (m2 * m2)) - 3.0;
}

/// Pools (n, sd, excess kurtosis) of two sets of samples, each about its own mean.
void poolMoments(int64_t n1, double sd1, double k1, int64_t n2, double sd2, double k2, double* sd, double* k) {
  const double S = std::max(sd1, sd2);
  if (!(S > 0) || n1 + n2 <= 0) {
    *sd = 0;
    *k = 0;
    return;
  }
  const double a = sd1 / S, b = sd2 / S, N = static_cast<double>(n1 + n2);
  const double m2 = (n1 * a * a + n2 * b * b) / N;
  const double m4 = (n1 * (k1 + 3) * a * a * a * a + n2 * (k2 + 3) * b * b * b * b) / N;
  *sd = S * std::sqrt(m2);
  *k = m2 > 0 ? m4 / (m2 * m2) - 3.0 : 0.0;
}

void requireFiniteSamples(const std::vector<double>& x, const char* what) {
  for (size_t i = 0; i < x.size(); ++i)
    if (!std::isfinite(x[i]))
      throw std::invalid_argument(std::string(what) + ": non-finite sample at index " + std::to_string(i));
}

void noteSpike(SpikeReport* r, int64_t index, double excursion, int max_listed) {
  ++r->count;
  if (std::fabs(excursion) > std::fabs(r->largest_excursion)) r->largest_excursion = excursion;
  if (static_cast<int>(r->first_indices.size()) < max_listed) r->first_indices.push_back(index);
}

/// Standard Gaussian draw fixed by an index (splitmix64 -> two uniforms -> Box-Muller).
double gaussOfIndex(int64_t k) {
  auto mix = [](uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  };
  const uint64_t a = mix(static_cast<uint64_t>(k) * 2 + 0x5eed), b = mix(static_cast<uint64_t>(k) * 2 + 1 + 0x5eed);
  const double u1 = (static_cast<double>(a >> 11) + 0.5) * (1.0 / 9007199254740992.0);
  const double u2 = static_cast<double>(b >> 11) * (1.0 / 9007199254740992.0);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

}  // namespace

double spikeReplacement(const SpikeRun& run, int64_t k) {
  return run.noise_sigma > 0 ? run.level + run.noise_sigma * gaussOfIndex(k) : run.level;
}

void validateSpikeOptions(const SpikeOptions& o) {
  if (!(o.z > 0) || !std::isfinite(o.z)) throw std::invalid_argument("spikes: z must be positive and finite");
  if (o.half_window < 1 || o.half_window > 1000) throw std::invalid_argument("spikes: half_window must be in 1..1000");
  if (o.max_run < 1 || o.max_run > o.half_window)
    throw std::invalid_argument("spikes: max_run must be in 1..half_window");
  if (o.saturation_run < 2 || o.saturation_run > 100000)
    throw std::invalid_argument("spikes: saturation_run must be in 2..100000");
  if (!(o.sigma >= 0) || !std::isfinite(o.sigma))
    throw std::invalid_argument("spikes: sigma must be >= 0 and finite (0 = estimate)");
  if (o.warmup < 4 * int64_t(o.half_window) + 4 || o.warmup > (int64_t(1) << 30))
    throw std::invalid_argument("spikes: warmup must be in 4 half_window + 4 .. 2^30 samples");
  if (o.max_listed < 0 || o.max_listed > 10000) throw std::invalid_argument("spikes: max_listed must be in 0..10000");
}

void SpikeReport::merge(const SpikeReport& o, int64_t index_offset, int max_listed) {
  double sd_b, k_b, sd_a, k_a;
  poolMoments(samples, std_before, excess_kurtosis_before, o.samples, o.std_before, o.excess_kurtosis_before, &sd_b,
              &k_b);
  poolMoments(samples, std_after, excess_kurtosis_after, o.samples, o.std_after, o.excess_kurtosis_after, &sd_a, &k_a);
  std_before = sd_b;
  excess_kurtosis_before = k_b;
  std_after = sd_a;
  excess_kurtosis_after = k_a;
  samples += o.samples;
  segments += o.segments;
  count += o.count;
  runs += o.runs;
  rejected += o.rejected;
  if (o.longest_segment > longest_segment) {
    longest_segment = o.longest_segment;
    robust_sigma = o.robust_sigma;
    threshold = o.threshold;
  }
  if (o.z > 0) z = o.z;
  if (std::fabs(o.largest_excursion) > std::fabs(largest_excursion)) largest_excursion = o.largest_excursion;
  removed = removed || o.removed;
  for (int64_t i : o.first_indices)
    if (static_cast<int>(first_indices.size()) < max_listed) first_indices.push_back(i + index_offset);
}

SpikeReport detectSpikes(const std::vector<double>& x, const SpikeOptions& o, std::vector<SpikeRun>* runs) {
  validateSpikeOptions(o);
  requireFiniteSamples(x, "spikes");
  if (runs) runs->clear();
  SpikeReport r;
  const int64_t n = static_cast<int64_t>(x.size());
  r.samples = n;
  r.segments = 1;
  r.longest_segment = n;
  r.z = o.z;
  moments(x, &r.std_before, &r.excess_kurtosis_before);
  r.std_after = r.std_before;
  r.excess_kurtosis_after = r.excess_kurtosis_before;
  const int h = o.half_window;
  if (n < 2 * int64_t(h) + 2) return r;
  const View v{x.data(), 0, n, true};
  std::vector<double> w;
  w.reserve(static_cast<size_t>(2 * h + 2));
  if (o.sigma > 0) {
    r.robust_sigma = o.sigma;
  } else {
    const int64_t step = scaleStep(n);
    std::vector<double> ad;
    ad.reserve(static_cast<size_t>((n + step - 1) / step));
    for (int64_t i = 0; i < n; i += step) ad.push_back(std::fabs(neighbourDev(v, i, h, w)));
    r.robust_sigma = scaleFromAbsDev(ad);
  }
  r.threshold = o.z * r.robust_sigma;
  if (!(r.threshold > 0)) return r;
  Rule rule;
  rule.h = h;
  rule.max_run = o.max_run;
  rule.sat = o.saturation_run;
  rule.thr = r.threshold;
  rule.restore_noise = o.restore_noise;
  // Candidates: blocks of B >= h samples whose three-block range is at most thr hold none (each window lies within
  // them); the rest are tested sample by sample (isCandidate repeats the range test per window: same answer).
  const int64_t B = std::max<int64_t>(16, h);
  const int64_t nb = (n + B - 1) / B;
  std::vector<double> bmin, bmax;
  detail::blockMinMax(x, B, &bmin, &bmax);
  std::vector<int64_t> cand;
  for (int64_t b = 0; b < nb; ++b) {
    double mn = bmin[static_cast<size_t>(b)], mx = bmax[static_cast<size_t>(b)];
    if (b > 0) mn = std::min(mn, bmin[static_cast<size_t>(b - 1)]), mx = std::max(mx, bmax[static_cast<size_t>(b - 1)]);
    if (b + 1 < nb) mn = std::min(mn, bmin[static_cast<size_t>(b + 1)]), mx = std::max(mx, bmax[static_cast<size_t>(b + 1)]);
    if (mx - mn <= r.threshold) continue;
    for (int64_t i = b * B; i < std::min(n, (b + 1) * B); ++i)
      if (isCandidate(v, i, h, r.threshold, w)) cand.push_back(i);
  }
  // Maximal runs of consecutive candidates.
  for (size_t a = 0; a < cand.size();) {
    size_t b = a + 1;
    while (b < cand.size() && cand[b] == cand[b - 1] + 1) ++b;
    const int64_t s = cand[a], e = cand[b - 1] + 1;
    double rep = 0, noise = 0;
    if (e - s <= o.max_run && classifyRun(v, s, e, rule, w, &rep, &noise)) {
      ++r.runs;
      for (int64_t k = s; k < e; ++k) noteSpike(&r, k, x[static_cast<size_t>(k)] - rep, o.max_listed);
      if (runs) runs->push_back({s, static_cast<int>(e - s), rep, noise});
    } else {
      r.rejected += e - s;
    }
    a = b;
  }
  return r;
}

void applySpikeRuns(const std::vector<SpikeRun>& runs, std::vector<double>* x, SpikeReport* report) {
  for (const auto& run : runs) {
    if (run.begin < 0 || run.length < 1 || run.begin + run.length > static_cast<int64_t>(x->size()))
      throw std::invalid_argument("applySpikeRuns: run outside the samples");
    for (int64_t k = run.begin; k < run.begin + run.length; ++k) (*x)[static_cast<size_t>(k)] = spikeReplacement(run, k);
  }
  if (report) {
    report->removed = !runs.empty();
    moments(*x, &report->std_after, &report->excess_kurtosis_after);
  }
}

SpikeReport removeSpikes(std::vector<double>* x, const SpikeOptions& o) {
  if (!x) throw std::invalid_argument("removeSpikes: null samples");
  std::vector<SpikeRun> runs;
  SpikeReport r = detectSpikes(*x, o, &runs);
  if (!runs.empty()) applySpikeRuns(runs, x, &r);
  return r;
}

// ---- SpikeFilter ---------------------------------------------------------------------------------------------

SpikeFilter::SpikeFilter(const SpikeOptions& o) : o_(o) {
  validateSpikeOptions(o_);
  if (o_.sigma > 0) {
    scale_ = o_.sigma;
    scale_known_ = true;
  }
}

int SpikeFilter::delay() const { return o_.max_run + std::max(o_.half_window, o_.saturation_run); }

void SpikeFilter::estimateScale(bool ended) {
  if (o_.sigma > 0) return;
  // |d| of samples 0, step_, 2 step_, ... as far as their windows are complete: the batch estimator's samples.
  const int64_t avail = ended ? n_ : n_ - o_.half_window;
  const View v{buf_.data(), base_, n_, ended};
  while (reservoir_next_ < avail) {
    reservoir_.push_back(std::fabs(neighbourDev(v, reservoir_next_, o_.half_window, scratch_)));
    ++added_since_;
    reservoir_next_ += step_;
    if (static_cast<int64_t>(reservoir_.size()) > kScaleSamples) {
      size_t k = 0;
      for (size_t i = 0; i < reservoir_.size(); i += 2) reservoir_[k++] = reservoir_[i];
      reservoir_.resize(k);
      step_ *= 2;
      reservoir_next_ = (reservoir_next_ + step_ - 1) / step_ * step_;
    }
  }
  const bool first = !scale_known_ && (ended || n_ >= o_.warmup);
  const bool refresh =
      scale_known_ && added_since_ >= std::max<int64_t>(4096, static_cast<int64_t>(reservoir_.size()) / 4);
  if (first || refresh) {
    std::vector<double> ad = reservoir_;
    scale_ = scaleFromAbsDev(ad);
    scale_known_ = true;
    added_since_ = 0;
  }
}

void SpikeFilter::computeCandidates(bool ended) {
  const int64_t avail = ended ? n_ : n_ - o_.half_window;
  const double thr = o_.z * scale_;
  const View v{buf_.data(), base_, n_, ended};
  for (; cand_hi_ < avail; ++cand_hi_)
    cand_[static_cast<size_t>(cand_hi_ - base_)] = thr > 0 && isCandidate(v, cand_hi_, o_.half_window, thr, scratch_);
}

bool SpikeFilter::emitOne(bool ended, double* out) {
  if (next_out_ >= n_ || !scale_known_) return false;
  const int h = o_.half_window;
  const bool detect = n_ >= 2 * int64_t(h) + 2;  // as the batch: shorter segments are examined for nothing
  if (!ended && (!detect || next_out_ + delay() >= n_)) return false;
  const int64_t i = next_out_;
  const double xi = buf_[static_cast<size_t>(i - base_)];
  double y = xi;
  if (detect && scale_ > 0 && cand_[static_cast<size_t>(i - base_)]) {
    if (!(run_begin_ <= i && i < run_end_)) {
      const View v{buf_.data(), base_, n_, ended};
      auto cand = [&](int64_t j) { return j < cand_hi_ && cand_[static_cast<size_t>(j - base_)] != 0; };
      if (i > 0 && cand(i - 1)) {
        // The rest of a run already found longer than max_run.
        run_begin_ = i;
        run_end_ = i + 1;
        run_spike_ = false;
      } else {
        int64_t e = i + 1;
        while (e - i <= o_.max_run && cand(e)) ++e;
        run_begin_ = i;
        run_end_ = e;
        Rule rule;
        rule.h = h;
        rule.max_run = o_.max_run;
        rule.sat = o_.saturation_run;
        rule.thr = o_.z * scale_;
        rule.restore_noise = o_.restore_noise;
        run_spike_ = e - i <= o_.max_run && classifyRun(v, i, e, rule, scratch_, &run_value_, &run_noise_);
        if (run_spike_) ++seg_.runs;
      }
    }
    if (run_spike_) {
      noteSpike(&seg_, i, xi - run_value_, o_.max_listed);
      y = spikeReplacement(SpikeRun{run_begin_, static_cast<int>(run_end_ - run_begin_), run_value_, run_noise_}, i);
    } else {
      ++seg_.rejected;
    }
  }
  ++next_out_;
  const long double u = static_cast<long double>(y) - shift_;
  out_s1_ += u;
  out_s2_ += u * u;
  out_s3_ += u * u * u;
  out_s4_ += u * u * u * u;
  ++out_n_;
  *out = y;
  return true;
}

void SpikeFilter::compact() {
  // Keep what decisions still look back at: the run start's left window and saturation check, plus slack.
  const int64_t keep = next_out_ - (std::max(o_.half_window, o_.saturation_run) + o_.max_run + 2);
  if (keep - base_ >= 8192) {
    const int64_t drop = keep - base_;
    buf_.erase(buf_.begin(), buf_.begin() + static_cast<long>(drop));
    cand_.erase(cand_.begin(), cand_.begin() + static_cast<long>(drop));
    base_ += drop;
  }
}

size_t SpikeFilter::push(double x, std::vector<double>* out) {
  if (!std::isfinite(x)) throw std::invalid_argument("SpikeFilter::push: non-finite sample");
  if (n_ == 0) shift_ = x;
  buf_.push_back(x);
  cand_.push_back(0);
  ++n_;
  const long double u = static_cast<long double>(x) - shift_;
  in_s1_ += u;
  in_s2_ += u * u;
  in_s3_ += u * u * u;
  in_s4_ += u * u * u * u;
  estimateScale(false);
  if (!scale_known_) return 0;
  computeCandidates(false);
  size_t got = 0;
  double y;
  while (emitOne(false, &y)) {
    if (out) out->push_back(y);
    ++got;
  }
  compact();
  return got;
}

void SpikeFilter::flush(std::vector<double>* out) {
  if (n_ > 0) {
    estimateScale(true);
    if (!scale_known_) {  // cannot happen (ended estimates), kept for safety
      scale_known_ = true;
      scale_ = 0;
    }
    computeCandidates(true);
    double y;
    while (emitOne(true, &y))
      if (out) out->push_back(y);
    total_.merge(closedSegment(), offset_, o_.max_listed);
    offset_ += n_;
  }
  // A new segment: sigma kept only when fixed.
  buf_.clear();
  cand_.clear();
  base_ = n_ = cand_hi_ = next_out_ = 0;
  run_begin_ = run_end_ = -1;
  run_spike_ = false;
  reservoir_.clear();
  step_ = 1;
  reservoir_next_ = added_since_ = 0;
  if (!(o_.sigma > 0)) {
    scale_ = 0;
    scale_known_ = false;
  }
  seg_ = SpikeReport();
  in_s1_ = in_s2_ = in_s3_ = in_s4_ = out_s1_ = out_s2_ = out_s3_ = out_s4_ = 0;
  out_n_ = 0;
}

SpikeReport SpikeFilter::closedSegment() const {
  SpikeReport s = seg_;
  s.samples = n_;
  s.segments = 1;
  s.longest_segment = n_;
  s.z = o_.z;
  s.robust_sigma = scale_;
  s.threshold = o_.z * scale_;
  s.removed = s.count > 0;
  momentsFromSums(n_, in_s1_, in_s2_, in_s3_, in_s4_, &s.std_before, &s.excess_kurtosis_before);
  momentsFromSums(out_n_, out_s1_, out_s2_, out_s3_, out_s4_, &s.std_after, &s.excess_kurtosis_after);
  return s;
}

SpikeReport SpikeFilter::report() const {
  SpikeReport r = total_;
  if (n_ > 0) r.merge(closedSegment(), offset_, o_.max_listed);
  return r;
}

}  // namespace gyro_allan
