// runPipeline: the rules of one record's analysis, from raw stamps and samples to per-axis results and warnings
// (sanitation, at-rest check, the per-axis task graph, accelerometer) — shared by analyze_bag and OnlineAnalyzer.
#include "gyro_allan/pipeline.hpp"

#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <algorithm>
#include <climits>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <exception>
#include <future>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <system_error>
#include <thread>

#include "gyro_allan/quality.hpp"

namespace gyro_allan {

namespace {

/// One line for the user about the spikes removed from one gyro axis, with the with-spikes N alongside.
std::string spikeWarning(const AxisAnalysis& a) {
  char buf[400];
  int len = std::snprintf(buf, sizeof buf,
                          "axis %s: %lld spikes removed (samples more than %.3g robust sigmas = %.3g rad/s from their "
                          "neighbours' median; excess kurtosis %.3g -> %.3g)",
                          a.axis.c_str(), static_cast<long long>(a.spikes.count), a.spikes.z, a.spikes.threshold,
                          a.spikes.excess_kurtosis_before, a.spikes.excess_kurtosis_after);
  const Coefficient &w = a.coefficients_with_spikes[kAngleRandomWalk], &o = a.fit.terms[kAngleRandomWalk];
  if (a.has_with_spikes && w.supported && o.supported && o.value > 0 && len > 0 && len < static_cast<int>(sizeof buf))
    std::snprintf(buf + len, sizeof buf - static_cast<size_t>(len),
                  "; with them N would be %.4g deg/sqrt(h) (x%.3g); --keep-spikes keeps them",
                  w.value * conventionalFactor(kAngleRandomWalk), w.value / o.value);
  return buf;
}

/// Mean of all samples over segments, then removed (accelerometer: gravity; Allan variance ignores constants, the
/// removal only keeps the accumulated phase small).
double removeMean(std::vector<std::vector<double>>* segments) {
  double sum = 0;
  size_t n = 0;
  for (const auto& s : *segments)
    for (double x : s) sum += x, ++n;
  const double mean = n ? sum / static_cast<double>(n) : 0;
  for (auto& s : *segments)
    for (double& x : s) x -= mean;
  return mean;
}

/// The warning for an axis whose verdict is bad (stderr and report.yaml warnings).
std::string badFitWarning(const AxisAnalysis& a) {
  return "axis " + a.axis + ": BAD FIT (" + a.quality.reason +
         "): its coefficients, and any imu.yaml value it decides, are not a measurement";
}

}  // namespace

/// Gives freed heap pages back to the system between stages (large arrays freed inside the heap would otherwise
/// stay resident until the heap top is free).
void releaseFreed() {
#ifdef __GLIBC__
  malloc_trim(0);
#endif
}

/// Only the longest static stretch was analysed: said in the axis's notes, and the verdict is judged again with it.
void noteStaticStretch(const PipelineResult& meta, AxisAnalysis* a) {
  if (!meta.rest_restricted) return;
  char buf[200];
  a->static_stretch = true;
  std::snprintf(buf, sizeof buf, "only the longest static stretch of the record was analysed, %.1f-%.1f s (the sensor moved outside it)",
                meta.rest_from_s, meta.rest_to_s);
  a->notes.push_back(buf);
  a->quality = assessQuality(*a);
  unboundIntervalsIfBad(a->quality, &a->coefficients);
}

void runTaskGraph(const std::vector<std::function<void()>>& tasks, const std::vector<std::vector<size_t>>& deps,
                  int jobs) {
  const size_t n = tasks.size();
  size_t workers = jobs > 0 ? static_cast<size_t>(jobs) : std::max(1u, std::thread::hardware_concurrency());
  workers = std::max<size_t>(1, std::min(workers, n));
  std::mutex m;
  std::condition_variable cv;
  std::vector<int> state(n, 0);  // 0 waiting, 1 running, 2 done
  std::vector<std::exception_ptr> errors(n);
  size_t running = 0;
  bool failed = false;
  auto ready = [&](size_t k) {
    for (size_t d : deps[k])
      if (state[d] != 2) return false;
    return true;
  };
  auto work = [&]() {
    std::unique_lock<std::mutex> lock(m);
    for (;;) {
      size_t pick = n;
      bool waiting = false;
      for (size_t k = 0; k < n && !failed; ++k) {
        if (state[k] != 0) continue;
        waiting = true;
        if (ready(k)) {
          pick = k;
          break;
        }
      }
      if (pick == n) {
        // Nothing to start now: leave if nothing ever will be (all started, a failure, or no task running that
        // could make one ready), else wait for a task to finish.
        if (!waiting || failed || running == 0) return;
        cv.wait(lock);
        continue;
      }
      state[pick] = 1;
      ++running;
      lock.unlock();
      try {
        tasks[pick]();
      } catch (...) {
        errors[pick] = std::current_exception();
      }
      releaseFreed();  // each stage frees its working arrays; give the pages back before the next one starts
      lock.lock();
      state[pick] = 2;
      --running;
      if (errors[pick]) failed = true;
      cv.notify_all();
    }
  };
  std::vector<std::thread> pool;
  for (size_t w = 1; w < workers; ++w) pool.emplace_back(work);
  work();
  for (auto& th : pool) th.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

namespace {

/// The working state of one runPipeline call, its stages as methods (the graph's tasks capture this object).
struct PipelineRun {
  PipelineRun(PipelineInput& in, const PipelineOptions& options)
      : options(options), opt(options.analysis), so(options.sanitize), compact(in.compact), names(in.names),
        t(in.t), values(in.values), gyro_c(in.gyro_c), accel(in.accel_c), t_c(in.t_c), accel_t_c(in.accel_t_c),
        temp_t(in.temperature_t),
        temp_v(in.temperature) {}

  const PipelineOptions& options;
  const AnalysisOptions& opt;
  const SanitizeOptions& so;
  const bool compact;
  const std::vector<std::string>& names;
  std::vector<double>& t;
  std::vector<std::vector<double>>& values;
  std::array<CompactSeries, 3>& gyro_c;
  std::array<CompactSeries, 3>& accel;
  CompactStamps& t_c;
  CompactStamps& accel_t_c;
  const std::vector<double>& temp_t;
  const std::vector<double>& temp_v;

  PipelineResult meta;
  SanitizedSeries ss;
  double tau0 = 0;
  double rest_t0 = 0, rest_t1 = 0;  // the analysed stretch by stamp (for the accelerometer's own sanitation)
  double accel_tau0 = 0;            // the accelerometer's period (its own stamps' or tau0)
  bool accelOwnStamps0 = false;     // accelOwnStamps() before its stamps were freed
  bool accel_published = false;
  std::vector<std::vector<double>> temperature_segments;
  // Gyro axes.
  std::vector<AxisAnalysis> results;
  std::vector<std::vector<Warning>> axis_warnings;
  std::vector<std::unique_ptr<AxisStages>> stages;
  std::vector<std::function<void()>> tasks;
  std::vector<std::vector<size_t>> deps;
  std::vector<size_t> split_tasks;
  // Accelerometer.
  std::string accel_note;  // why the accelerometer was not analysed (stdout, not a warning: gyro-only IMUs are fine)
  std::vector<AxisAnalysis> accel_results;
  std::vector<double> accel_means;
  std::string accel_error;  // set: not analysed, with this reason
  AnalysisOptions ao;
  SanitizedSeries sa;
  std::string accel_sanitize_error;  // from the accelerometer's sanitation (taken into accel_error if it is analysed)
  bool accel_settled = false;        // sa is sanitized and restricted (settleAccelSanitize)
  std::vector<std::string> accel_errors = std::vector<std::string>(3);
  // The accelerometer's sanitation, run beside the gyro's (startAccelSanitize); last member, so it is waited for
  // before anything it uses is destroyed.
  std::future<void> accel_sanitized;

  /// Reports a finished stage to the profiling callback, if any.
  void profileStage(const char* stage) {
    if (options.stage) options.stage(stage);
  }

  /// Whether the accelerometer has stamps of its own (a separate stream).
  bool accelOwnStamps() const { return !accel_t_c.empty(); }

  /// Whether the accelerometer is analysed if it turns out to be published: compact input with one sample per stamp.
  bool accelPresent() const {
    return options.accel && compact && !accel[0].empty() &&
           accel[0].size() == (accelOwnStamps() ? accel_t_c.size() : t_c.size());
  }

  /// Whether the accelerometer publishes anything (an IMU without one publishes zeros): any finite non-zero sample.
  void scanAccelPublished() {
    if (accelPresent())
      for (const auto& v : accel)
        for (size_t i = 0; i < v.size() && !accel_published; ++i) accel_published = v[i] != 0 && std::isfinite(v[i]);
  }

  /// Starts the accelerometer's sanitation on a second thread: it needs only the stamps and its own samples, and the
  /// gyro's sanitation beside it is single-threaded (the second core was idle there). Not for an accelerometer that
  /// publishes nothing, nor with jobs = 1 (sequential: the graph's task sanitizes it). settleAccelSanitize restricts
  /// it to the gyro's static stretch after the rest check.
  void startAccelSanitize() {
    accelOwnStamps0 = accelOwnStamps();
    scanAccelPublished();
    if (!accelPresent() || !accel_published || options.jobs == 1) return;
    if (accelOwnStamps()) {
      try {
        accel_sanitized = std::async(std::launch::async, [this] { sanitizeAccel(accel_t_c.toSeconds()); });
      } catch (const std::system_error&) {
      }
      return;
    }
    if (compact) t = t_c.toSeconds();  // one copy of the stamps for both sanitations (freed once both are done)
    try {
      accel_sanitized = std::async(std::launch::async, [this] { sanitizeAccel(t); });
    } catch (const std::system_error&) {
      // no thread to be had: the graph's accelerometer task sanitizes it instead (as with jobs = 1)
    }
  }

  /// The accelerometer's samples at the stamps t_seconds sanitized into sa (an error into accel_sanitize_error).
  void sanitizeAccel(const std::vector<double>& t_seconds) {
    try {
      sa = sanitizeCompact(t_seconds, {&accel[0], &accel[1], &accel[2]}, so);
    } catch (const std::exception& e) {
      accel_sanitize_error = e.what();
    }
  }

  /// After checkRest: waits for the accelerometer's sanitation, restricts it to the gyro's static stretch and frees
  /// its stamps before the axes start (they would otherwise be held through the gyro's splits).
  void settleAccelSanitize() {
    if (!accel_sanitized.valid()) return;
    accel_sanitized.get();
    if (compact && !accelOwnStamps()) std::vector<double>().swap(t);  // the stamps both sanitations read
    if (!accel_published) {
      sa = SanitizedSeries();
      accel_settled = true;
      return;
    }
    restrictAccel();
  }

  /// The sanitized accelerometer restricted to the gyro's static stretch, its stamps freed (sa settled).
  void restrictAccel() {
    try {
      if (accel_sanitize_error.empty() && meta.rest_restricted) sa.restrictToTime(rest_t0, rest_t1);
    } catch (const std::exception& e) {
      accel_sanitize_error = e.what();
    }
    std::vector<double>().swap(sa.t);
    accel_settled = true;
  }

  /// Checks the input's shape, sanitizes the stamps and gyro samples, and takes the stamp report and tau0 into meta.
  void sanitizeGyro(StampReport* counted) {
    if (compact) {
      if (t.empty()) t = t_c.toSeconds();  // else already made for the accelerometer's sanitation beside this one
    } else {
      if (values.empty() || values.size() > 3) throw std::invalid_argument("1 to 3 value columns expected");
      if (names.size() != values.size()) throw std::invalid_argument("one name per value column expected");
    }
    if (compact) {
      ss = sanitizeCompact(t, {&gyro_c[0], &gyro_c[1], &gyro_c[2]}, so);  // kept indices; values stay compact
    } else {
      std::vector<const std::vector<double>*> ptrs;
      for (const auto& v : values) ptrs.push_back(&v);
      ss = sanitize(t, ptrs, so);
      for (auto& v : values) std::vector<double>().swap(v);
    }
    // Freed now unless the accelerometer's sanitation still reads it (then settleAccelSanitize frees it).
    if (compact && (!accel_sanitized.valid() || accelOwnStamps())) std::vector<double>().swap(t);
    releaseFreed();
    profileStage("sanitize");
    meta.stamps = ss.report;
    if (counted) *counted = ss.counted;
    for (const auto& w : ss.report.warnings()) meta.warnings.push_back({WarningKind::Stamps, w});
    if (ss.report.kept < 3 || !(ss.report.nominal_period_s > 0))
      throw std::invalid_argument("too few valid samples (" + std::to_string(ss.report.kept) + " of " +
                                  std::to_string(ss.report.input) + ")");
    tau0 = ss.report.nominal_period_s;
    meta.tau0 = tau0;
  }

  /// At rest? Throws when the sensor moved and has no usable static stretch, else restricts ss to the longest one.
  void checkRest() {
    // At rest? (rest.hpp) The gyro axes and, when published, the accelerometer, fed sample by sample from their
    // stored form. A sensor that moved is analysed over its longest static stretch, or not at all. (accel_published:
    // scanAccelPublished, before the sanitation.)
    if (opt.input == InputKind::Rate && options.rest_check) {
      std::vector<size_t> sizes;
      for (const auto& seg : ss.segments) sizes.push_back(seg.size());
      const size_t n_axes = compact ? 3 : names.size();
      // Channel c of sample i of segment k, read-only (called from several threads): gyro axes, then the
      // accelerometer's, whose NaN samples (the gyro's were dropped by the sanitation) take the last finite value.
      auto sample = [&](int c, size_t k, size_t i) -> double {
        const size_t idx = ss.segments[k].begin + i;
        if (!compact) return ss.v[static_cast<size_t>(c)][idx];
        const size_t j = ss.kept.empty() ? idx : ss.kept[idx];
        if (c < 3) return gyro_c[static_cast<size_t>(c)][j];
        const CompactSeries& a = accel[static_cast<size_t>(c - 3)];
        for (size_t q = j + 1; q-- > 0;)
          if (std::isfinite(a[q])) return a[q];
        return 0.0;
      };
      // An accelerometer with stamps of its own is not sample-aligned with the gyro: the gyro alone decides.
      meta.rest = detectRest(static_cast<int>(n_axes), accel_published && !accelOwnStamps(), tau0, sizes, sample);
      meta.rest_checked = true;
      profileStage("rest");
      if (!meta.rest.at_rest) {
        const RestInterval st = meta.rest.longest_static;
        char buf[600];
        if (!meta.rest.static_usable) {
          std::snprintf(buf, sizeof buf,
                        "not at rest: the sensor moved (%s); moving in %.0f %% of the record and no static stretch "
                        "of %g s (longest %.1f s): noise coefficients need a static recording (--no-rest-check "
                        "analyses it anyway)",
                        meta.rest.reason.c_str(), 100 * meta.rest.moving_fraction, RestOptions().min_static_s,
                        static_cast<double>(st.end - st.begin) * tau0);
          throw NotAtRest(buf);
        }
        rest_t0 = ss.t[static_cast<size_t>(st.begin)];
        rest_t1 = ss.t[static_cast<size_t>(st.end - 1)];
        meta.rest_restricted = true;
        meta.rest_from_s = rest_t0 - ss.t.front();
        meta.rest_to_s = rest_t1 - ss.t.front();
        meta.rest_excluded = ss.restrictTo(static_cast<size_t>(st.begin), static_cast<size_t>(st.end));
        std::snprintf(buf, sizeof buf,
                      "the sensor moved (%s; %.0f %% of the record): only the longest static stretch is analysed, "
                      "%.1f-%.1f s (%.1f s of %.1f s)",
                      meta.rest.reason.c_str(), 100 * meta.rest.moving_fraction, meta.rest_from_s, meta.rest_to_s,
                      meta.rest_to_s - meta.rest_from_s, ss.t.back() - ss.t.front());
        meta.warnings.push_back({WarningKind::Motion, buf});
      }
    }
  }

  /// Adds each gyro axis's tasks (prepare, split, check, finish) to the graph; interpolates the temperature first.
  void addGyroTasks() {
    temperature_segments = ss.interpolateSegments(temp_t, temp_v);
    // Gyro axes as a task graph on --jobs threads: per axis prepare (oadev + fit), then the wavelet split and the
    // model check; a free thread takes the earliest ready stage, so axes are worked on in order and at most --jobs
    // stages (not whole axes) hold working memory at a time.
    const size_t n_gyro = names.size();
    results.resize(n_gyro);
    axis_warnings.resize(n_gyro);
    stages.resize(n_gyro);
    std::vector<double>().swap(ss.t);  // stamps are not needed any more (temperature already interpolated)
    size_t last_split = SIZE_MAX;
    for (size_t a = 0; a < n_gyro; ++a) {
      const size_t prep = tasks.size();
      tasks.push_back([&, a] {
        // This axis as doubles (its compact copy is freed), split into segments.
        std::vector<std::vector<double>> segs;
        if (compact) {
          segs = ss.segmentValuesOf(gyro_c[a]);
          gyro_c[a].clear();
        } else {
          segs = ss.takeSegmentValues(static_cast<int>(a));
        }
        if (opt.input == InputKind::Rate) {
          // Saturation warnings here; isolated spikes are removed and reported by the analysis itself (spikes.hpp)
          // unless --keep-spikes, when they are only warned about as before.
          ValueAnomalies va;
          if (segs.size() == 1) {
            va = detectValueAnomalies(segs[0]);
          } else {
            std::vector<double> all;
            for (const auto& g : segs) all.insert(all.end(), g.begin(), g.end());
            va = detectValueAnomalies(all);
          }
          if (opt.remove_spikes) va.spikes = 0;
          axis_warnings[a] = va.warnings("axis " + names[a]);
        }
        stages[a] = std::make_unique<AxisStages>(names[a], std::move(segs), tau0, opt,
                                                 temperature_segments.empty() ? nullptr : &temperature_segments);
        stages[a]->prepare();
      });
      deps.push_back({});
      // Splits one at a time: the split holds the most memory (~3.5 records), so two never overlap. (On a pulse count
      // the split's sawtooth bootstrap runs its replicas after freeing its own parts, within the same.)
      tasks.push_back([&, a] { stages[a]->split(); });
      deps.push_back(last_split == SIZE_MAX ? std::vector<size_t>{prep} : std::vector<size_t>{prep, last_split});
      last_split = tasks.size() - 1;
      split_tasks.push_back(last_split);
      tasks.push_back([&, a] { stages[a]->check(); });
      deps.push_back({prep});
      // Finish as soon as both are done: the axis's samples are freed here, not after the whole graph.
      tasks.push_back([&, a] {
        results[a] = stages[a]->finish();
        stages[a].reset();
        noteStaticStretch(meta, &results[a]);
      });
      deps.push_back({tasks.size() - 3, tasks.size() - 2});
    }
  }

  /// Adds the accelerometer's three axes to the graph when it is analysed (and its sanitation, when it was not run
  /// beside the gyro's: jobs = 1, or no thread to be had).
  void addAccelTasks() {
    // Accelerometer: the same engine, joint fit only (the wavelet split and model check are tuned for gyros and
    // would double the run time); the mean (gravity) is removed first. Its sanitation ran beside the gyro's
    // (startAccelSanitize; here with jobs = 1); its three axes are graph tasks after the second-to-last wavelet
    // split, so they run beside the last gyro axis's split and check.
    if (accelPresent()) {
      if (!accel_published) {  // an IMU without accelerometer publishes zeros
        accel_note = "accelerometer: linear_acceleration is all zero (not published?): not analysed";
      } else {
        accel_results.resize(3);
        accel_means.resize(3);
      }
    }
    ao = opt;
    ao.wavelet_split = false;
    ao.model_check = false;
    ao.method = Method::JointFit;
    ao.gmwm = false;  // GMWM (#16): gyro only
    if (accel_results.empty()) return;
    const size_t sanitize_task = tasks.size();
    tasks.push_back([&] {
      try {
        if (!accel_settled) {  // jobs = 1, or the thread could not be started: sanitized here
          sanitizeAccel(accelOwnStamps() ? accel_t_c.toSeconds() : t_c.toSeconds());
          restrictAccel();
        }
        t_c.clear();
        accel_t_c.clear();
        if (!accel_sanitize_error.empty()) throw std::invalid_argument(accel_sanitize_error);
        accel_tau0 = tau0;
        if (accelOwnStamps0) {
          accel_tau0 = sa.report.nominal_period_s;
          if (sa.report.kept < 3 || !(accel_tau0 > 0))
            throw std::invalid_argument("too few valid accelerometer samples (" + std::to_string(sa.report.kept) +
                                        " of " + std::to_string(sa.report.input) + ")");
        }
      } catch (const std::exception& e) {
        accel_error = e.what();
      }
    });
    // After every split but the last: on 2 threads the accelerometer then overlaps the last gyro axis's split and
    // check (an earlier axis's check may still hold its samples with more threads). Waiting for the last check too
    // would run the three accelerometer axes after everything else, one of them alone on 2 cores.
    std::vector<size_t> after;
    if (split_tasks.size() > 1) after.push_back(split_tasks[split_tasks.size() - 2]);
    deps.push_back(after);
    for (size_t a = 0; a < 3; ++a) {
      tasks.push_back([&, a] {
        if (!accel_error.empty()) return;
        try {
          std::vector<std::vector<double>> segs = sa.segmentValuesOf(accel[a]);
          accel[a].clear();
          accel_means[a] = removeMean(&segs);
          AxisStages st("accel_" + names[a], std::move(segs), accel_tau0, ao);
          st.prepare();
          accel_results[a] = st.finish();  // joint fit only: no split or model check
          noteStaticStretch(meta, &accel_results[a]);
        } catch (const std::exception& e) {
          accel_errors[a] = e.what();
        }
      });
      deps.push_back({sanitize_task});
    }
  }

  /// After the graph: frees the stamps, gathers the warnings, and moves the results into meta.
  void collect() {
    for (size_t a = 0; a < results.size(); ++a) {
      // A gyro at rest reads Earth rate plus bias: hundreds of deg/s means wrong units or a moving sensor.
      if (opt.input == InputKind::Rate && std::fabs(results[a].mean) > 1.0)
        axis_warnings[a].push_back({WarningKind::MeanRate, "axis " + names[a] + ": mean rate " +
                                                               std::to_string(results[a].mean) +
                                                               " rad/s is not a gyro at rest (wrong units or a moving sensor?)"});
    }
    {
      const StampReport keep = ss.report;
      ss = SanitizedSeries();  // free the stamps
      ss.report = keep;
    }
    for (const auto& w : axis_warnings) meta.warnings.insert(meta.warnings.end(), w.begin(), w.end());
    for (const auto& r : results)
      if (r.spikes_checked && r.spikes.count > 0) meta.warnings.push_back({WarningKind::Spikes, spikeWarning(r)});
    for (const auto& r : results)
      if (r.quality.quality == Quality::Bad) meta.warnings.push_back({WarningKind::BadFit, badFitWarning(r)});
    for (const auto& e : accel_errors)
      if (accel_error.empty() && !e.empty()) accel_error = e;
    if (!accel_error.empty()) {
      accel_results.clear();
      accel_means.clear();
      meta.warnings.push_back({WarningKind::Accelerometer, "accelerometer not analysed: " + accel_error});
    }
    for (const auto& r : accel_results)
      if (r.quality.quality == Quality::Bad) meta.warnings.push_back({WarningKind::BadFit, badFitWarning(r)});
    profileStage("analysis");
    meta.gyro = std::move(results);
    meta.accel = std::move(accel_results);
    meta.accel_means = std::move(accel_means);
    meta.accel_note = accel_note;
    meta.accel_tau0 = meta.accel.empty() ? 0 : accel_tau0;
    if (!meta.accel.empty() && accelOwnStamps0)
      for (const auto& w : sa.report.warnings()) meta.warnings.push_back({WarningKind::Accelerometer, "accelerometer: " + w});
  }
};

}  // namespace

PipelineResult runPipeline(PipelineInput&& in, const PipelineOptions& options, StampReport* counted) {
  PipelineRun run(in, options);
  run.startAccelSanitize();
  run.sanitizeGyro(counted);
  run.checkRest();
  run.settleAccelSanitize();
  run.addGyroTasks();
  run.addAccelTasks();
  runTaskGraph(run.tasks, run.deps, options.jobs);
  run.profileStage("axes");
  run.collect();
  return std::move(run.meta);
}

}  // namespace gyro_allan
