// QuickView: the online quick answer between full analyses — each axis's overlapping Allan deviation kept up to date
// sample by sample (SlidingAllan) over the window, and the IEEE 952 fit of it on request.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "gyro_allan/analysis.hpp"
#include "gyro_allan/sliding_allan.hpp"

namespace gyro_allan {

struct QuickViewOptions {
  double window_s = 3600;           ///< window [s of input]; in samples: window_s / tau0
  InputKind input = InputKind::Rate;
  bool angle_increments = false;    ///< angle input: per-sample increments instead of the accumulated angle
  /// Tau grid and confidence. The octave grid (21 points over a 1 h window at 1 kHz) costs a fifth of log:10's 60 per
  /// sample (bench_sliding: 2.1 against 11 us per 3-axis sample); the full analysis keeps its own grid.
  DeviationOptions deviation{TauGrid{TauGridKind::Octave, 10}};
  int64_t min_samples = 1000;       ///< samples before the sample period is estimated and the first answer (>= 3)
};

/// What the quick view knows: per axis an AxisAnalysis with axis, oadev, method QuickFit and, once fitted, fit,
/// coefficients (the fit's), final_model_var and final_error; nothing else of the full pipeline (no sanitation beyond
/// gaps, no at-rest check, wavelet split, model check or verdict).
struct QuickAnswer {
  int64_t newest_ns = 0;   ///< stamp of the newest sample
  int64_t window_first_ns = 0;  ///< the analyzer's oldest stamp in the window (set by OnlineAnalyzer::takeQuick)
  int64_t samples = 0;     ///< samples in the quick window (all axes alike)
  int segments = 0;        ///< gap-free segments in it
  double tau0 = 0;         ///< the sample period the curves assume [s]
  std::vector<AxisAnalysis> axes;
};

/// Feeds three axes into SlidingAllan engines. The sample period is the least-squares slope of stamp against sample
/// index over the first min_samples samples (batched or jittered stamps scatter around it); after that the samples are taken as consecutive, and a stamp
/// more than max(10 periods, 0.05 s) ahead of the sample clock (which follows the stamps with a time constant of 100
/// samples) starts a new gap-free segment, as do a zero stamp and a non-finite value (that sample is skipped).
class QuickView {
 public:
  /// Throws std::invalid_argument on window_s <= 0 or min_samples < 3.
  explicit QuickView(const QuickViewOptions& options);
  void add(int64_t stamp_ns, const std::array<double, 3>& gyro);
  /// The period is known and the window holds min_samples.
  bool ready() const;
  /// The curves now, unfitted (ready() must be true; else throws std::logic_error).
  QuickAnswer curves() const;
  /// Fits each axis's curve as the full analysis fits its joint fit (fitWithModelEdf: the curve then carries the
  /// model-based EDF and bounds), without the unified intervals: values and delta-method sigmas, `supported` when a
  /// term's weight is 1.96 sigma above 0, interval ends and an unsupported term's sigma NaN.
  static void fit(QuickAnswer* q, const FitOptions& fit, double confidence);
  /// Starts over (the period is estimated again).
  void reset();
  /// Starts over with a known period [s] (e.g. the full analysis's), > 0.
  void resetWithPeriod(double tau0);
  double tau0() const { return tau0_; }
  const QuickViewOptions& options() const { return options_; }
  /// Heap memory of the engines and the start-up buffer [bytes].
  size_t memoryBytes() const;

 private:
  struct Pending {
    int64_t ns;
    std::array<double, 3> g;
  };
  void build(double tau0);
  void feed(int64_t ns, const std::array<double, 3>& g);
  QuickViewOptions options_;
  std::vector<Pending> pending_;   ///< samples before the period is known
  double tau0_ = 0;
  std::array<std::unique_ptr<SlidingAllan>, 3> engines_;
  double clock_s_ = 0;             ///< the sample clock [s since first_ns_]
  int64_t first_ns_ = 0, newest_ns_ = 0;
};

}  // namespace gyro_allan
