// Rest detector: block statistics of gyro and accelerometer channels that tell a sensor at rest from a moved one.
#include "gyro_allan/rest.hpp"
#include "gyro_allan/stats.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <thread>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace gyro_allan {
namespace detail {

inline std::string fmt(const char* f, double a) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, a);
  return buf;
}

namespace {

constexpr double kMadToSigma = 1.4826;


void checkOptions(double tau0, const RestOptions& o) {
  auto bad = [](const std::string& m) { throw std::invalid_argument("rest detector: " + m); };
  if (!(tau0 > 0) || !std::isfinite(tau0)) bad("sample interval tau0 must be positive and finite, got " + fmt("%g", tau0));
  if (!(o.block_s > 0) || !std::isfinite(o.block_s)) bad("block_s must be positive");
  if (o.min_block_samples < 4) bad("min_block_samples must be at least 4");
  if (!(o.block_z > 0) || !(o.record_ratio > 0) || !(o.clip_k > 0)) bad("block_z, record_ratio, clip_k must be > 0");
  if (o.window_blocks < 3 || o.min_window_blocks < 3 || o.min_window_blocks > o.window_blocks)
    bad("need 3 <= min_window_blocks <= window_blocks");
  if (!(o.max_rest_rate > 0) || !(o.gyro_floor >= 0) || !(o.accel_floor >= 0) || !(o.min_static_s >= 0))
    bad("max_rest_rate must be > 0, floors and min_static_s >= 0");
}

}  // namespace

/// One decided block (also what the batch form logs).
struct BlockDecision {
  int64_t begin = 0, end = 0;  // samples [begin, end) counted from the first add()
  bool moving = false;
  double score = 0;            // max |z| / max(1, S) over the changes it takes part in
  double strength = 0;         // trigger statistic / its threshold (> 1 when it fired), of the strongest trigger
  std::string channel, reason;
};

inline RestBlock toBlock(const BlockDecision& d) {
  RestBlock b;
  b.samples = {d.begin, d.end};
  b.moving = d.moving;
  b.score = d.score;
  b.channel = d.channel;
  b.reason = d.reason;
  return b;
}

/// Location (clipped mean) and white-noise level of one block of one channel, and its smallest non-zero first
/// difference (infinity if none): the per-block statistics of the rest detector (rest.hpp). Pure: the batch form
/// computes them for several channels on parallel threads.
void blockStatsOf(const double* x, size_t n, double clip_k, std::vector<double>* scratch_p, std::vector<double>* d_p,
                  double* loc, double* sigma, double* qmin_out) {
  std::vector<double>& scratch_ = *scratch_p;
  std::vector<double>& d = *d_p;
  scratch_.assign(x, x + n);
  const double med = medianInPlace(scratch_);
  // First differences: robust unit, then an RMS within 5 units (quantized sensors: differences mostly 0 and +-LSB).
  d.resize(n - 1);
  double qmin = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i + 1 < n; ++i) {
    d[i] = x[i + 1] - x[i];
    const double ad = std::fabs(d[i]);
    if (ad > 0 && ad < qmin) qmin = ad;
  }
  scratch_.assign(d.begin(), d.end());
  const double dmed = medianInPlace(scratch_);
  for (size_t i = 0; i < d.size(); ++i) scratch_[i] = std::fabs(d[i] - dmed);
  const double mad = kMadToSigma * medianInPlace(scratch_);
  double unit = mad;
  if (std::isfinite(qmin)) unit = std::max(unit, qmin);
  double s2 = 0;
  int64_t kept = 0;
  for (double v : d) {
    const double e = v - dmed;
    if (std::fabs(e) <= 5.0 * unit) s2 += e * e, ++kept;
  }
  const double sig = kept > 0 ? std::sqrt(s2 / kept / 2.0) : 0.0;
  double sum = 0;
  const double lo = med - clip_k * sig, hi = med + clip_k * sig;
  for (size_t i = 0; i < n; ++i) sum += std::min(hi, std::max(lo, x[i]));
  *loc = sig > 0 ? sum / n : med;
  *sigma = sig;
  *qmin_out = qmin;
}

class RestEngine {
 public:
  RestEngine(double tau0, int n_gyro, bool has_accel, const RestOptions& o)
      : tau0_(tau0), n_gyro_(n_gyro), opts_(o) {
    checkOptions(tau0, o);
    if (n_gyro < 1 || n_gyro > 3) throw std::invalid_argument("rest detector: 1 to 3 gyro axes, got " + std::to_string(n_gyro));
    n_ch_ = n_gyro + (has_accel ? 3 : 0);
    const char* xyz = "xyz";
    for (int c = 0; c < n_ch_; ++c) {
      const bool g = c < n_gyro;
      names_.push_back(std::string(g ? "gyro " : "accel ") + xyz[g ? c : c - n_gyro]);
      floor_.push_back(g ? o.gyro_floor : o.accel_floor);
    }
    block_n_ = std::max<int64_t>(o.min_block_samples, std::llround(o.block_s / tau0));
    buf_.assign(n_ch_, {});
    for (auto& b : buf_) b.reserve(block_n_);
    win_.assign(n_ch_, {});
    quantum_.assign(n_ch_, std::numeric_limits<double>::infinity());
    scratch_.reserve(block_n_);
  }

  bool hasAccel() const { return n_ch_ > n_gyro_; }
  int nGyro() const { return n_gyro_; }
  int64_t blockSamples() const { return block_n_; }

  /// Returns the number of decisions made.
  int add(const double* g, const double* a) {
    recent_.clear();
    if (!g) throw std::invalid_argument("rest detector: null gyro sample");
    if (hasAccel() && !a) throw std::invalid_argument("rest detector: accelerometer sample missing (has_accel)");
    for (int c = 0; c < n_ch_; ++c) {
      const double v = c < n_gyro_ ? g[c] : a[c - n_gyro_];
      if (!std::isfinite(v))
        throw std::invalid_argument("rest detector: " + names_[c] + " sample " + std::to_string(count_) +
                                    " is not finite");
    }
    for (int c = 0; c < n_ch_; ++c) buf_[c].push_back(c < n_gyro_ ? g[c] : a[c - n_gyro_]);
    ++count_;
    if (static_cast<int64_t>(buf_[0].size()) < block_n_) return 0;
    return closeBlock();
  }

  int newSegment() {
    recent_.clear();
    int made = 0;
    const int64_t tail = static_cast<int64_t>(buf_[0].size());
    if (tail >= opts_.min_block_samples) {
      made += closeBlock();
    } else if (tail > 0) {
      if (!pending_.empty()) {
        pending_.back().end = count_;  // the tail joins the last block (its statistics stay those of the full block)
      } else if (log_) {
        undecided_.push_back({count_ - tail, count_});
      }
      for (auto& b : buf_) b.clear();
    }
    // Decide what is left, the segment end having no neighbour.
    for (size_t i = 0; i < pending_.size(); ++i) {
      if (pending_[i].decided) continue;
      decide(i);
      ++made;
    }
    pending_.clear();
    return made;
  }

  const BlockDecision& last() const { return last_; }
  int64_t blocks() const { return n_decided_; }
  int64_t movingBlocks() const { return n_moving_; }
  int64_t samples() const { return count_; }
  double maxSpread() const { return max_spread_; }

  std::vector<BlockDecision>* log_ = nullptr;  // batch form: every decision
  std::vector<RestInterval> undecided_;        // batch form: segments too short for a block
  bool keep_recent_ = false;                   // streaming form: decisions of the latest call
  std::vector<RestBlock> recent_;

 private:
  struct Block {
    int64_t begin = 0, end = 0, n = 0;
    std::vector<double> loc, sigma;
    bool raw = false, decided = false;
    double score = 0;
    double strength = 0;  // strongest trigger that marked it
    std::string channel, reason;
  };

  void mark(Block& b, double strength, const std::string& channel, const std::string& reason) {
    b.raw = true;
    if (strength > b.strength) {
      b.strength = strength;
      b.channel = channel;
      b.reason = reason;
    }
  }

  // Location and white-noise level of the buffered block of channel c (blockStatsOf); keeps the channel's quantum.
  void blockStats(int c, double* loc, double* sigma) {
    double qmin;
    blockStatsOf(buf_[c].data(), buf_[c].size(), opts_.clip_k, &scratch_, &dbuf_, loc, sigma, &qmin);
    quantum_[c] = std::min(quantum_[c], qmin);
  }

  // ---- batch form (detectRest): blocks with precomputed statistics
 public:
  /// Batch form with the block statistics computed outside (blockStatsOf, possibly on other threads): one block of
  /// n samples, as closeBlock would close it after n add() calls.
  int addBlock(int64_t n, const double* loc, const double* sigma, const double* qmin) {
    recent_.clear();
    count_ += n;
    Block b;
    b.n = n;
    b.end = count_;
    b.begin = count_ - n;
    b.loc.assign(loc, loc + n_ch_);
    b.sigma.assign(sigma, sigma + n_ch_);
    for (int c = 0; c < n_ch_; ++c) quantum_[c] = std::min(quantum_[c], qmin[c]);
    return finishBlock(std::move(b));
  }
  /// Batch form: the end of a segment whose last `tail` samples (fewer than min_block_samples) formed no block.
  int endSegment(int64_t tail) {
    count_ += tail;
    for (int c = 0; c < n_ch_; ++c) buf_[c].assign(static_cast<size_t>(tail), 0.0);  // only their number matters
    return newSegment();
  }

 private:
  int closeBlock() {
    Block b;
    b.n = static_cast<int64_t>(buf_[0].size());
    b.end = count_;
    b.begin = count_ - b.n;
    b.loc.resize(n_ch_);
    b.sigma.resize(n_ch_);
    for (int c = 0; c < n_ch_; ++c) blockStats(c, &b.loc[c], &b.sigma[c]);
    for (auto& v : buf_) v.clear();
    return finishBlock(std::move(b));
  }

  int finishBlock(Block b) {
    // (c) rate magnitude
    double w2 = 0;
    for (int c = 0; c < n_gyro_; ++c) w2 += b.loc[c] * b.loc[c];
    const double w = std::sqrt(w2);
    if (w > opts_.max_rest_rate)
      mark(b, w / opts_.max_rest_rate, "gyro |w|",
           "gyro |w|: mean rate " + fmt("%.3g", w) + " rad/s over a block at t = " + fmt("%.1f", b.begin * tau0_) +
               " s, above " + fmt("%.3g", opts_.max_rest_rate) + " rad/s (a turning sensor, not a gyro bias)");
    pending_.push_back(std::move(b));
    if (pending_.size() >= 2) change(pending_[pending_.size() - 2], pending_.back());
    int made = 0;
    // Block k-2 is final once block k exists (its right neighbour k-1 has seen both its changes).
    if (pending_.size() >= 3) {
      decide(pending_.size() - 3);
      ++made;
    }
    while (pending_.size() > 4) pending_.pop_front();
    return made;
  }

  void change(Block& a, Block& b) {
    const std::string bs = fmt("%g", opts_.block_s);
    for (int c = 0; c < n_ch_; ++c) {
      const double d = b.loc[c] - a.loc[c];
      double pred = std::sqrt(a.sigma[c] * a.sigma[c] / a.n + b.sigma[c] * b.sigma[c] / b.n);
      if (std::isfinite(quantum_[c]))
        pred = std::max(pred, quantum_[c] / std::sqrt(12.0) * std::sqrt(1.0 / a.n + 1.0 / b.n));
      const double z = pred > 0 ? d / pred : (d == 0 ? 0.0 : std::copysign(1e300, d));
      std::deque<double>& w = win_[c];
      w.push_back(z);
      while (static_cast<int>(w.size()) > opts_.window_blocks) w.pop_front();
      double S = 1.0;
      if (static_cast<int>(w.size()) >= opts_.min_window_blocks) {
        scratch_.assign(w.begin(), w.end());
        const double m = medianInPlace(scratch_);
        for (size_t i = 0; i < w.size(); ++i) scratch_[i] = std::fabs(w[i] - m);
        S = kMadToSigma * medianInPlace(scratch_);
        if (S * pred > floor_[c]) max_spread_ = std::max(max_spread_, S);  // statistics below the floor never count
      }
      const double zn = std::fabs(z) / std::max(1.0, S);
      if (std::fabs(d) > floor_[c]) {
        a.score = std::max(a.score, zn);
        b.score = std::max(b.score, zn);
      }
      const double t = b.begin * tau0_;
      // (a) a block change beyond block_z noise units (the noise including the window's spread)
      if (zn > opts_.block_z && std::fabs(d) > floor_[c]) {
        const std::string r = names_[c] + ": " + bs + " s block means change by " + fmt("%.3g", zn) +
                              "x the noise level at t = " + fmt("%.1f", t) + " s (threshold " +
                              fmt("%g", opts_.block_z) + "x)";
        mark(a, zn / opts_.block_z, names_[c], r);
        mark(b, zn / opts_.block_z, names_[c], r);
      }
      // (b) block changes spread far beyond white noise all along the window
      if (S > opts_.record_ratio && S * pred > floor_[c]) {
        const std::string r = names_[c] + ": " + bs + " s block means wander " + fmt("%.3g", S) +
                              "x more than white noise would over the " + std::to_string(w.size()) +
                              " block changes up to t = " + fmt("%.1f", t) + " s (threshold " +
                              fmt("%g", opts_.record_ratio) + "x)";
        mark(a, S / opts_.record_ratio, names_[c], r);
        mark(b, S / opts_.record_ratio, names_[c], r);
      }
    }
  }

  void decide(size_t i) {
    Block& b = pending_[i];
    BlockDecision dcs;
    dcs.begin = b.begin;
    dcs.end = b.end;
    dcs.score = b.score;
    const Block* strongest = nullptr;
    for (size_t k = (i > 0 ? i - 1 : 0); k <= i + 1 && k < pending_.size(); ++k) {
      const Block& nb = pending_[k];
      if (nb.raw && (!strongest || nb.strength > strongest->strength)) strongest = &nb;
    }
    if (strongest) {
      dcs.moving = true;
      dcs.strength = strongest->strength;
      dcs.channel = strongest->channel;
      dcs.reason = strongest->reason;
    }
    b.decided = true;
    ++n_decided_;
    if (dcs.moving) ++n_moving_;
    if (log_) log_->push_back(dcs);
    if (keep_recent_) recent_.push_back(toBlock(dcs));
    last_ = std::move(dcs);
  }

  double tau0_;
  int n_gyro_;
  int n_ch_ = 0;
  RestOptions opts_;
  int64_t block_n_ = 0;
  std::vector<std::string> names_;
  std::vector<double> floor_;
  std::vector<std::vector<double>> buf_;
  std::vector<std::deque<double>> win_;
  std::vector<double> quantum_;
  std::vector<double> scratch_, dbuf_;
  std::deque<Block> pending_;  // blocks of the current segment still needed (at most 4)
  BlockDecision last_;
  int64_t count_ = 0, n_decided_ = 0, n_moving_ = 0;
  double max_spread_ = 0;
};

}  // namespace detail

// ---------------------------------------------------------------------------------------------------------------
RestMonitor::RestMonitor(double tau0, int n_gyro, bool has_accel, const RestOptions& opts)
    : engine_(new detail::RestEngine(tau0, n_gyro, has_accel, opts)) {
  engine_->keep_recent_ = true;
}
RestMonitor::~RestMonitor() = default;
RestMonitor::RestMonitor(RestMonitor&&) noexcept = default;
RestMonitor& RestMonitor::operator=(RestMonitor&&) noexcept = default;

bool RestMonitor::add(const double* gyro, const double* accel) { return engine_->add(gyro, accel) > 0; }
bool RestMonitor::newSegment() { return engine_->newSegment() > 0; }
bool RestMonitor::moving() const { return engine_->last().moving; }
double RestMonitor::score() const { return engine_->last().score; }
std::string RestMonitor::reason() const { return engine_->last().reason; }
int64_t RestMonitor::blocks() const { return engine_->blocks(); }
int64_t RestMonitor::moving_blocks() const { return engine_->movingBlocks(); }
RestInterval RestMonitor::lastBlock() const { return {engine_->last().begin, engine_->last().end}; }
const std::vector<RestBlock>& RestMonitor::decided() const { return engine_->recent_; }

// ---------------------------------------------------------------------------------------------------------------
using detail::fmt;

RestResult detectRest(const std::vector<const std::vector<std::vector<double>>*>& gyro,
                      const std::vector<const std::vector<std::vector<double>>*>& accel, double tau0,
                      const RestOptions& opts) {
  auto bad = [](const std::string& m) { throw std::invalid_argument("detectRest: " + m); };
  if (gyro.empty() || gyro.size() > 3) bad("need 1 to 3 gyro axes, got " + std::to_string(gyro.size()));
  if (!accel.empty() && accel.size() != 3) bad("need 0 or 3 accelerometer axes, got " + std::to_string(accel.size()));
  for (auto* p : gyro)
    if (!p) bad("null gyro axis");
  for (auto* p : accel)
    if (!p) bad("null accelerometer axis");
  const std::vector<std::vector<double>>& ref = *gyro[0];
  auto sameShape = [&](const std::vector<std::vector<double>>& s, const std::string& what) {
    if (s.size() != ref.size())
      bad(what + " has " + std::to_string(s.size()) + " segments, gyro x has " + std::to_string(ref.size()));
    for (size_t k = 0; k < s.size(); ++k)
      if (s[k].size() != ref[k].size())
        bad(what + " segment " + std::to_string(k) + " has " + std::to_string(s[k].size()) + " samples, gyro x has " +
            std::to_string(ref[k].size()));
  };
  const char* xyz = "xyz";
  for (size_t a = 1; a < gyro.size(); ++a) sameShape(*gyro[a], std::string("gyro ") + xyz[a]);
  for (size_t a = 0; a < accel.size(); ++a) sameShape(*accel[a], std::string("accel ") + xyz[a]);
  int64_t total = 0;
  for (const auto& s : ref) total += static_cast<int64_t>(s.size());
  if (total == 0) bad("no samples");
  bool has_accel = false;
  for (auto* p : accel)
    for (const auto& s : *p)
      for (double v : s)
        if (v != 0) has_accel = true;  // NaN also counts as published (and is refused below)
  std::vector<size_t> sizes;
  for (const auto& s : ref) sizes.push_back(s.size());
  for (size_t c = 0; c < gyro.size() + (has_accel ? 3 : 0); ++c) {  // the engine's own refusal of NaN/Inf
    const auto& axis = c < gyro.size() ? *gyro[c] : *accel[c - gyro.size()];
    for (const auto& seg : axis)
      for (size_t i = 0; i < seg.size(); ++i)
        if (!std::isfinite(seg[i]))
          bad(std::string(c < gyro.size() ? "gyro " : "accel ") + xyz[c < gyro.size() ? c : c - gyro.size()] +
              " sample " + std::to_string(i) + " is not finite");
  }
  const size_t ng = gyro.size();
  return detectRest(static_cast<int>(ng), has_accel, tau0, sizes,
                    [&](int c, size_t k, size_t i) {
                      const size_t cc = static_cast<size_t>(c);
                      return cc < ng ? (*gyro[cc])[k][i] : (*accel[cc - ng])[k][i];
                    },
                    opts);
}

RestResult detectRest(int n_gyro, bool has_accel, double tau0, const std::vector<size_t>& segment_sizes,
                      const std::function<double(int, size_t, size_t)>& sample, const RestOptions& opts) {
  int64_t total = 0;
  for (size_t n : segment_sizes) total += static_cast<int64_t>(n);
  if (total == 0) throw std::invalid_argument("detectRest: no samples");
  detail::RestEngine eng(tau0, n_gyro, has_accel, opts);
  std::vector<detail::BlockDecision> log;
  eng.log_ = &log;
  const int n_ch = n_gyro + (has_accel ? 3 : 0);
  // The engine's block layout: per segment, full blocks, then a tail that is a block of its own when it has at least
  // min_block_samples samples (else it joins the last block, or stays undecided).
  struct BlockRef {
    size_t seg, begin, n;
  };
  const size_t bn = static_cast<size_t>(eng.blockSamples());
  std::vector<BlockRef> blocks;
  std::vector<int64_t> short_tail(segment_sizes.size(), 0);
  for (size_t k = 0; k < segment_sizes.size(); ++k) {
    size_t pos = 0;
    for (; segment_sizes[k] - pos >= bn; pos += bn) blocks.push_back({k, pos, bn});
    const size_t tail = segment_sizes[k] - pos;
    if (static_cast<int64_t>(tail) >= opts.min_block_samples) blocks.push_back({k, pos, tail});
    else short_tail[k] = static_cast<int64_t>(tail);
  }
  // Phase 1: the block statistics (the costly part: three exact medians per block and channel), channels spread
  // over threads; blockStatsOf is the streaming engine's own function, so the statistics are identical.
  const size_t nb = blocks.size(), nc = static_cast<size_t>(n_ch);
  std::vector<double> loc(nb * nc), sig(nb * nc), qmin(nb * nc);
  const char* xyz = "xyz";
  auto work = [&](int first, int step) {
    std::vector<double> x, scratch, d;
    for (int c = first; c < n_ch; c += step)
      for (size_t b = 0; b < nb; ++b) {
        const BlockRef& r = blocks[b];
        x.resize(r.n);
        for (size_t i = 0; i < r.n; ++i) {
          x[i] = sample(c, r.seg, r.begin + i);
          if (!std::isfinite(x[i]))
            throw std::invalid_argument(std::string("rest detector: ") + (c < n_gyro ? "gyro " : "accel ") +
                                        xyz[c < n_gyro ? c : c - n_gyro] + " sample " + std::to_string(r.begin + i) +
                                        " of segment " + std::to_string(r.seg) + " is not finite");
        }
        detail::blockStatsOf(x.data(), r.n, opts.clip_k, &scratch, &d, &loc[b * nc + static_cast<size_t>(c)],
                     &sig[b * nc + static_cast<size_t>(c)], &qmin[b * nc + static_cast<size_t>(c)]);
      }
  };
  const int n_threads = std::max(1, std::min<int>(n_ch, static_cast<int>(std::thread::hardware_concurrency())));
  std::vector<std::exception_ptr> errors(static_cast<size_t>(n_threads));
  std::vector<std::thread> pool;
  for (int t = 1; t < n_threads; ++t)
    pool.emplace_back([&, t] {
      try {
        work(t, n_threads);
      } catch (...) {
        errors[static_cast<size_t>(t)] = std::current_exception();
      }
    });
  try {
    work(0, n_threads);
  } catch (...) {
    errors[0] = std::current_exception();
  }
  for (auto& th : pool) th.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  // Phase 2: the engine's decisions, block by block in order.
  size_t bi = 0;
  for (size_t k = 0; k < segment_sizes.size(); ++k) {
    for (; bi < nb && blocks[bi].seg == k; ++bi)
      eng.addBlock(static_cast<int64_t>(blocks[bi].n), &loc[bi * nc], &sig[bi * nc], &qmin[bi * nc]);
    eng.endSegment(short_tail[k]);
  }

  RestResult r;
  r.blocks = static_cast<int64_t>(log.size());
  r.spread = eng.maxSpread();
  // Per-sample state: 0 static, 1 moving, 2 undecided.
  struct Run {
    int64_t b, e;
    int state;
  };
  std::vector<Run> runs;
  auto push = [&](int64_t b, int64_t e, int st) {
    if (e <= b) return;
    if (!runs.empty() && runs.back().state == st && runs.back().e == b)
      runs.back().e = e;
    else
      runs.push_back({b, e, st});
  };
  std::vector<Run> items;
  for (const auto& d : log) items.push_back({d.begin, d.end, d.moving ? 1 : 0});
  for (const auto& u : eng.undecided_) items.push_back({u.begin, u.end, 2});
  std::sort(items.begin(), items.end(), [](const Run& x, const Run& y) { return x.b < y.b; });
  for (const auto& it : items) push(it.b, it.e, it.state);
  int64_t moving_samples = 0;
  for (const auto& run : runs) {
    if (run.state == 1) {
      r.moving.push_back({run.b, run.e});
      moving_samples += run.e - run.b;
    } else if (run.state == 0 && run.e - run.b > r.longest_static.end - r.longest_static.begin) {
      r.longest_static = {run.b, run.e};
    }
  }
  r.moving_fraction = static_cast<double>(moving_samples) / static_cast<double>(total);
  r.static_usable = (r.longest_static.end - r.longest_static.begin) * tau0 >= opts.min_static_s &&
                    r.longest_static.end > r.longest_static.begin;
  const detail::BlockDecision* strongest = nullptr;
  for (const auto& d : log) {
    r.score = std::max(r.score, d.score);
    if (d.moving) {
      ++r.moving_blocks;
      if (!strongest || d.strength > strongest->strength) strongest = &d;
    }
  }
  r.at_rest = strongest == nullptr;
  if (strongest) {
    r.channel = strongest->channel;
    r.reason = strongest->reason;
  } else if (log.size() < 3) {
    r.reason = "at rest as far as can be told: only " + std::to_string(log.size()) + " block(s) of " +
               fmt("%g", opts.block_s) + " s";
  } else if (r.score == 0 && r.spread == 0) {
    r.reason = "at rest: no " + fmt("%g", opts.block_s) + " s block mean changes by more than " +
               fmt("%g", opts.gyro_floor) + " rad/s (gyro)" +
               (has_accel ? " or " + fmt("%g", opts.accel_floor) + " m/s^2 (accel)" : std::string()) +
               ", the smallest change counted as motion";
  } else {
    r.reason = "at rest: largest block change " + fmt("%.3g", r.score) + "x the noise level (threshold " +
               fmt("%g", opts.block_z) + "x), largest spread " + fmt("%.3g", r.spread) + "x white noise (threshold " +
               fmt("%g", opts.record_ratio) + "x)";
  }
  return r;
}

RestResult detectRestSingle(const std::vector<const std::vector<double>*>& gyro,
                            const std::vector<const std::vector<double>*>& accel, double tau0,
                            const RestOptions& opts) {
  std::vector<std::vector<std::vector<double>>> g, a;
  for (auto* p : gyro) {
    if (!p) throw std::invalid_argument("detectRest: null gyro axis");
    g.push_back({*p});
  }
  for (auto* p : accel) {
    if (!p) throw std::invalid_argument("detectRest: null accelerometer axis");
    a.push_back({*p});
  }
  std::vector<const std::vector<std::vector<double>>*> gp, ap;
  for (auto& s : g) gp.push_back(&s);
  for (auto& s : a) ap.push_back(&s);
  return detectRest(gp, ap, tau0, opts);
}

}  // namespace gyro_allan
