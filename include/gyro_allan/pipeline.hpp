// The whole-record pipeline shared by analyze_bag and the online analyzer: raw stamps and samples -> sanitation,
// at-rest check, per-axis analysis (fit, wavelet split, model check with temperature), accelerometer, warnings.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "gyro_allan/analysis.hpp"
#include "gyro_allan/compact_series.hpp"
#include "gyro_allan/rest.hpp"
#include "gyro_allan/timing.hpp"
#include "gyro_allan/warning.hpp"

namespace gyro_allan {

/// Raw input of one record, in one of two forms. Bags (compact = true): stamps t_c (ns, 0 = zero stamp), the three
/// gyro axes and, optionally, the accelerometer (linear_acceleration, m/s^2; empty or all zero = none), held compactly;
/// the accelerometer either at the gyro's stamps or, from a stream of its own (a split gyro/accel pair), at its own
/// stamps accel_t_c (same origin as t_c).
/// CSV (compact = false): stamps t [s] and 1..3 value columns. Temperature: stamps [s, same origin as the samples'
/// stamps] and degC, optional. runPipeline consumes the input (frees it as it goes).
struct PipelineInput {
  std::vector<std::string> names{"x", "y", "z"};  ///< gyro axis names (CSV: its column names)
  bool compact = true;
  CompactStamps t_c;
  std::array<CompactSeries, 3> gyro_c, accel_c;
  CompactStamps accel_t_c;  ///< the accelerometer's own stamps [ns]; empty: it is sampled at t_c
  std::vector<double> t;
  std::vector<std::vector<double>> values;
  std::vector<double> temperature_t, temperature;
};

struct PipelineOptions {
  AnalysisOptions analysis;   ///< per-axis analysis (input kind, method, stages)
  SanitizeOptions sanitize;   ///< stamp sanitation (gap factor, nominal rate)
  bool rest_check = true;     ///< rate input: at-rest check; a moving record is cut to its longest static stretch
  bool accel = true;          ///< analyse the accelerometer (compact input with a published linear_acceleration)
  int jobs = 0;               ///< threads for the per-axis task graph (0 = one per core)
  /// Called after each stage ("sanitize", "rest", "axes", "analysis") for profiling; may be empty.
  std::function<void(const char*)> stage;
};

/// Everything the pipeline decided about one record.
struct PipelineResult {
  StampReport stamps;                  ///< sanitation counts of the gyro series
  std::vector<Warning> warnings;       ///< for the user, in order: stamps, motion, per axis, spikes, bad fits, accel
  double tau0 = 0;                     ///< nominal period, s
  bool rest_checked = false;
  RestResult rest;
  bool rest_restricted = false;        ///< only the longest static stretch was analysed
  double rest_from_s = 0, rest_to_s = 0;  ///< that stretch, s from the first kept stamp
  int64_t rest_excluded = 0;           ///< kept samples left out as moving
  std::vector<AxisAnalysis> gyro;      ///< one per gyro axis, in input order
  std::vector<AxisAnalysis> accel;     ///< accelerometer axes ("accel_x"...), empty when not analysed
  std::vector<double> accel_means;     ///< removed mean (gravity) per accelerometer axis, m/s^2
  double accel_tau0 = 0;               ///< the accelerometer's period, s (its own with its own stamps, else tau0)
  std::string accel_note;              ///< why the accelerometer was not analysed (not a warning), or empty
  /// Samples analysed (kept minus those left out as moving).
  int64_t analysed() const { return stamps.kept - rest_excluded; }
};

/// A record that moved and has no static stretch long enough to analyse (runPipeline throws it).
struct NotAtRest : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

/// Runs the pipeline on one record (consumed). Throws std::invalid_argument when the record is not analysable (too
/// few valid samples, moving without a usable static stretch (NotAtRest), too short for any Allan point), with a
/// one-line reason.
/// `counted`, when given, receives the sanitation's SanitizedSeries::counted (problems of the input samples from
/// options.sanitize.count_from on) as soon as it is known, also when the record then proves not analysable.
PipelineResult runPipeline(PipelineInput&& input, const PipelineOptions& options, StampReport* counted = nullptr);

/// The note and verdict of an axis analysed over a static stretch only (the pipeline applies it itself).
void noteStaticStretch(const PipelineResult& r, AxisAnalysis* a);

/// Runs tasks on up to `jobs` threads (0 = one per core): task k starts once every task in deps[k] has finished,
/// and a free thread always takes the ready task with the lowest index (so one thread runs them in index order).
/// After a failure no new task starts; the failure of the lowest-index task is rethrown.
void runTaskGraph(const std::vector<std::function<void()>>& tasks, const std::vector<std::vector<size_t>>& deps,
                  int jobs);

/// Gives freed heap pages back to the system (glibc malloc_trim; no-op elsewhere).
void releaseFreed();

}  // namespace gyro_allan
