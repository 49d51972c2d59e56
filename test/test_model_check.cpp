// Closed-loop model check on simulated gyros with one undeclared effect each (no hint given to the analyzer), and
// on clean controls: effect found with its parameters, error reduced, base coefficients back to the truth; the
// acceptance rule (kept effects lower the RMS error by min_rms_gain and are significant) over classes and seeds.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <complex>
#include <cstdio>
#include <functional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <unsupported/Eigen/FFT>

#include "gyro_allan/allan.hpp"
#include "gyro_allan/analysis.hpp"
#include "gyro_allan/model_check.hpp"
#include "gyro_allan/noise_model.hpp"
#include "gyro_allan/simulate.hpp"

using namespace gyro_allan;

namespace {

// Base IEEE noise of every simulation (truth for the coefficient checks).
AxisNoise baseNoise() {
  AxisNoise a;
  a.quantization = 2e-6;
  a.angle_random_walk = 1e-4;
  a.bias_instability = 5e-6;
  a.rate_random_walk = 2e-7;
  return a;
}

struct Outcome {
  FitResult plain;
  ModelCheck mc;
};

// Adds a Gaussian narrowband process with a Lorentzian PSD (centre f0, half-power width fwhm) kept out to
// +-half_span from f0 and zero beyond (so that it adds nothing to the white level the base coefficients are checked
// against), standard deviation `sigma`; synthesized by inverse FFT with independent complex Gaussian bins.
void addLorentzian(std::vector<double>* rate, double tau0, double f0, double fwhm, double half_span, double sigma,
                   uint64_t seed) {
  const size_t n = rate->size();
  const double T = n * tau0, df = 1.0 / T;
  std::vector<std::complex<double>> c(n, 0.0);
  std::vector<double> s(n, 0.0);
  double total = 0;
  for (size_t k = 1; k < n / 2; ++k) {
    const double d = k * df - f0;
    if (std::fabs(d) > half_span) continue;
    s[k] = 1.0 / (1.0 + 4.0 * d * d / (fwhm * fwhm));
    total += s[k] * df;
  }
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd(0.0, 1.0);
  for (size_t k = 1; k < n / 2; ++k) {
    if (s[k] <= 0) continue;
    const double amp = std::sqrt(s[k] / total * sigma * sigma * df);  // E|c_k|^2 = 2 S df: Re part carries S df
    c[k] = {amp * nd(rng), amp * nd(rng)};
  }
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> y;
  fft.inv(y, c);  // scaled by 1/n
  for (size_t t = 0; t < n; ++t) (*rate)[t] += static_cast<double>(n) * y[t].real();
}

Outcome run(const AxisNoise& a, double rate_hz, double duration_s, uint64_t seed, bool temperature = false,
            const std::function<void(std::vector<double>*)>& add = nullptr) {
  SimulationSpec spec;
  spec.rate_hz = rate_hz;
  spec.duration_s = duration_s;
  spec.seed = seed;
  spec.axes[0] = a;
  spec.temperature = temperature;
  SimulatedData d = simulate(spec);
  if (add) add(&d.rate[0]);
  DeviationOptions o;
  o.grid.kind = TauGridKind::Log;
  o.grid.per_decade = 10;
  const DeviationCurve curve = oadev(d.rate[0], 1.0 / rate_hz, o);
  Outcome out;
  ModelCheckOptions mo;
  out.plain = fitNoiseModel(curve, mo.fit);
  out.mc = checkModel(d.rate[0], 1.0 / rate_hz, curve, out.plain, mo, temperature ? &d.temperature : nullptr);
  return out;
}

double param(const DetectedEffect& e, const std::string& name) {
  auto it = e.parameters.find(name);
  if (it == e.parameters.end()) throw std::runtime_error("missing parameter " + name);
  return it->second.value;
}

// N within 3 % of the truth; Q, B, K, R: the truth inside the reported 95 % interval.
void expectBaseRecovered(const FitResult& f, const AxisNoise& truth, bool check_ramp = true) {
  ASSERT_TRUE(f.ok);
  EXPECT_NEAR(f.terms[kAngleRandomWalk].value, truth.angle_random_walk, 0.03 * truth.angle_random_walk);
  const double t[kNumTerms] = {truth.quantization, truth.angle_random_walk, truth.bias_instability,
                               truth.rate_random_walk, truth.rate_ramp};
  for (int k : {kQuantization, kBiasInstability, kRateRandomWalk, kRateRamp}) {
    if (k == kRateRamp && !check_ramp) continue;
    const Coefficient& c = f.terms[k];
    EXPECT_TRUE(t[k] >= c.lo95 && t[k] <= c.hi95)
        << noiseTermKey(k) << " truth " << t[k] << " outside [" << c.lo95 << ", " << c.hi95 << "], value " << c.value;
  }
}

// What a kept effect must do for the curve: the model with the effect is accepted by the data (chi2 p >= 0.01) and
// follows the curve within 25 % wherever the data's interval is tight (worst_adev_ratio; beside a Gauss-Markov term
// not met: docs/model_check.md, "Limits"). The RMS log10 error over every fitted point has a floor set by the long-tau scatter (~0.02
// for these records), so its ratio says little once the effect is in.
void expectEffectExplainsData(const ModelCheck& mc, bool check_worst = true) {
  EXPECT_GE(mc.fit_after.chi2_p, 0.01) << "refit chi2/dof " << mc.after.chi2_dof;
  if (check_worst) {
    EXPECT_LE(mc.fit_after.worst_adev_ratio, 1.25);
  }
}

// Angle random walk within 3 % of the truth (beside an added stochastic effect, the long-tau terms' intervals are
// not calibrated: docs/model_check.md, "Limits").
void expectArwRecovered(const FitResult& f, const AxisNoise& truth) {
  ASSERT_TRUE(f.ok);
  EXPECT_NEAR(f.terms[kAngleRandomWalk].value, truth.angle_random_walk, 0.03 * truth.angle_random_walk);
}

// The acceptance rule: kept effects lower the RMS log10 error by min_rms_gain (jointly, against the plain fit), each
// has a non-zero amplitude significant at min_amplitude_z in the final joint refit and a searched nonlinear parameter
// (tau_c_s, theta_s) within max_nonlinear_rel_sigma; no effect kept: the answer is the plain fit.
void expectRuleHolds(const ModelCheck& mc, const std::string& what) {
  SCOPED_TRACE(what);
  const ModelCheckOptions mo;
  ASSERT_TRUE(mc.ok) << mc.message;
  if (mc.effects.empty()) {
    EXPECT_DOUBLE_EQ(mc.after.rms_log10, mc.before.rms_log10);
    return;
  }
  EXPECT_LT(mc.after.rms_log10, mc.before.rms_log10 * (1.0 - mo.min_rms_gain));
  // The trials were fitted without their intervals (FitOptions::intervals); what is kept has them.
  EXPECT_TRUE(mc.fit_after.intervals);
  for (int k = 0; k < kNumTerms; ++k) {
    const Coefficient& c = mc.fit_after.terms[static_cast<size_t>(k)];
    EXPECT_TRUE(std::isfinite(c.hi68) && std::isfinite(c.hi95) && std::isfinite(c.sigma)) << noiseTermKey(k);
  }
  ASSERT_EQ(mc.fit_after.extra.size(), mc.effects.size());
  for (size_t e = 0; e < mc.effects.size(); ++e) {
    const Coefficient& c = mc.fit_after.extra[e];
    EXPECT_GT(c.value, 0.0) << mc.effects[e].type;
    EXPECT_GE(c.value, mo.min_amplitude_z * c.sigma) << mc.effects[e].type << " " << c.value << " +- " << c.sigma;
    for (const char* nl : {"tau_c_s", "theta_s"}) {
      auto it = mc.effects[e].parameters.find(nl);
      if (it == mc.effects[e].parameters.end()) continue;
      EXPECT_GT(it->second.value, 0.0);
      EXPECT_LE(it->second.sigma, mo.max_nonlinear_rel_sigma * it->second.value) << nl;
    }
  }
}

// Sensor classes of check_study (studies/check_study.cpp), for the property tests.
struct StudyCase {
  std::string name;
  AxisNoise a;
  double rate_hz = 100;
  bool temperature = false;
};
AxisNoise consumerMems() {  // N 0.5 deg/sqrt(h), B 20 deg/h, K 10 deg/h/sqrt(h)
  AxisNoise a;
  const double deg = M_PI / 180.0;
  a.angle_random_walk = 0.5 * deg / 60.0;
  a.bias_instability = 20 * deg / 3600.0;
  a.rate_random_walk = 10 * deg / 3600.0 / 60.0;
  return a;
}
std::vector<StudyCase> studyCases(uint64_t seed) {
  std::vector<StudyCase> v;
  v.push_back({"consumer", consumerMems(), 200});
  AxisNoise q = consumerMems();
  q.rate_lsb = 0.061 * M_PI / 180.0;
  v.push_back({"consumer_lsb", q, 200});
  v.push_back({"nav", baseNoise()});
  AxisNoise s = baseNoise();
  s.sine_amplitude = 1e-4;
  s.sine_frequency = 1.3;
  v.push_back({"sinusoid", s});
  AxisNoise g = baseNoise();
  g.gm_sigma = 6e-5;
  g.gm_tau = 10.0;
  v.push_back({"gauss_markov", g});
  AxisNoise b = baseNoise();
  b.step_size = 3e-4;
  b.step_time = (0.2 + 0.6 * static_cast<double>((seed * 37) % 100) / 100.0) * 3600.0;
  v.push_back({"bias_step", b});
  AxisNoise t = baseNoise();
  t.thermal_amplitude = 3e-4;
  t.thermal_tau = 200.0;
  v.push_back({"thermal", t, 100, true});
  v.push_back({"warmup", t});
  return v;
}

}  // namespace

TEST(ModelCheck, KeptEffectsLowerTheErrorAndAreSignificant) {
  // Property over sensor classes (clean consumer MEMS with and without output rounding, navigation-grade base
  // noise) and weak injected effects (sinusoid, Gauss-Markov, bias step, warm-up with and without temperature), two
  // seeds each: whatever is kept obeys the rule, whatever is not leaves the plain fit.
  int kept = 0;
  for (uint64_t seed : {3, 11}) {
    for (const StudyCase& c : studyCases(seed)) {
      const Outcome o = run(c.a, c.rate_hz, 3600.0, seed, c.temperature);
      expectRuleHolds(o.mc, c.name + " seed " + std::to_string(seed));
      kept += !o.mc.effects.empty();
      if (c.name.rfind("consumer", 0) == 0 || c.name == "nav") {
        EXPECT_TRUE(o.mc.effects.empty()) << c.name;
      }
    }
  }
  // The rule does not reject everything (12 runs with an injected effect). Was >= 6 with the EDF-weighted fit (76 %
  // of injected effects kept on the check_study tuning seeds, 114/150). With the GLS fit the plain model absorbs
  // bias steps into K and describes the curve within its scatter (steps kept 7/30 on the tuning seeds, all effects
  // 104/150 = 69 %); these 12 runs keep 5 (seed 3: the Gauss-Markov; seed 11: sinusoid, Gauss-Markov, thermal
  // drift, warm-up). Fewer than 5 is a regression.
  EXPECT_GE(kept, 5);
}

TEST(ModelCheck, EffectsThatWorsenTheFitAreNotKept) {
  // check_study cases whose candidate effect is found in the raw samples but whose refit may describe the curve
  // worse than the plain fit (a warm-up with its temperature series, two bias steps): either the effect is kept and
  // lowers the RMS log10 error by min_rms_gain (expectRuleHolds), or the plain fit is the answer and the candidate is
  // in `rejected` with the reason.
  struct Case {
    std::string name, type;
    uint64_t seed;
  };
  for (const Case& k : {Case{"thermal", "thermal_drift", 3}, Case{"bias_step", "bias_step", 17},
                        Case{"bias_step", "bias_step", 11}}) {
    SCOPED_TRACE(k.name + " seed " + std::to_string(k.seed));
    for (const StudyCase& c : studyCases(k.seed)) {
      if (c.name != k.name) continue;
      const Outcome o = run(c.a, c.rate_hz, 3600.0, k.seed, c.temperature);
      expectRuleHolds(o.mc, k.name);
      if (!o.mc.effects.empty()) continue;
      bool reported = false;
      for (const auto& r : o.mc.rejected) reported = reported || r.rfind(k.type + ":", 0) == 0;
      EXPECT_TRUE(reported);
    }
  }
}

TEST(ModelCheck, SignificanceGatesRejectWithNumbers) {
  // The significance options are honoured and every rejection says why: the Gauss-Markov case of GaussMarkovFound
  // (tau_c known to ~10 %) with max_nonlinear_rel_sigma 1 %, and the 2.5 Hz sinusoid of SinusoidFound (~20 sigma)
  // with min_amplitude_z 1000: nothing kept, the plain fit is the answer.
  SimulationSpec spec;
  spec.rate_hz = 100.0;
  spec.duration_s = 3600.0;
  spec.seed = 1;
  spec.axes[0] = baseNoise();
  spec.axes[0].gm_tau = 10.0;
  spec.axes[0].gm_sigma = 1e-4;
  spec.axes[0].sine_frequency = 2.5;
  spec.axes[0].sine_amplitude = 5e-4;
  const SimulatedData d = simulate(spec);
  DeviationOptions o;
  o.grid.kind = TauGridKind::Log;
  o.grid.per_decade = 10;
  const DeviationCurve curve = oadev(d.rate[0], 0.01, o);
  ModelCheckOptions mo;
  mo.max_nonlinear_rel_sigma = 0.01;
  mo.min_amplitude_z = 1000.0;
  mo.line_false_alarm = 0.0;  // the line is not taken out of the samples: it goes through the gates as a candidate
  const ModelCheck mc = checkModel(d.rate[0], 0.01, curve, fitNoiseModel(curve, mo.fit), mo);
  ASSERT_TRUE(mc.ok) << mc.message;
  EXPECT_TRUE(mc.effects.empty());
  EXPECT_DOUBLE_EQ(mc.after.rms_log10, mc.before.rms_log10);
  bool sine = false, gm = false;
  for (const auto& r : mc.rejected) {
    sine = sine || (r.rfind("sinusoid: amplitude", 0) == 0 && r.find("sigma (needs 1000") != std::string::npos);
    gm = gm || (r.rfind("gauss_markov:", 0) == 0 &&
                (r.find("needs <= 1 %") != std::string::npos || r.find("sigma (needs 1000") != std::string::npos));
  }
  EXPECT_TRUE(sine);
  EXPECT_TRUE(gm);
}

TEST(ModelCheck, SinusoidFound) {
  // 2.5 Hz and 0.2 Hz sinusoids (100 Hz, 1 h): f0 within 5 %, amplitude within 20 %, the refit explains the curve.
  for (const auto& fa : {std::pair<double, double>{2.5, 5e-4}, std::pair<double, double>{0.2, 2e-4}}) {
    AxisNoise a = baseNoise();
    a.sine_frequency = fa.first;
    a.sine_amplitude = fa.second;
    const Outcome o = run(a, 100.0, 3600.0, 2);
    ASSERT_TRUE(o.mc.ok) << o.mc.message;
    ASSERT_FALSE(o.mc.effects.empty()) << "f0 " << fa.first;
    const DetectedEffect& e = o.mc.effects.front();
    EXPECT_EQ(e.type, "sinusoid");
    EXPECT_NEAR(param(e, "frequency_hz"), fa.first, 0.05 * fa.first);
    EXPECT_NEAR(param(e, "amplitude"), fa.second, 0.2 * fa.second);
    EXPECT_NE(e.evidence.find("least squares on the samples"), std::string::npos);
    EXPECT_LE(std::fabs(param(e, "frequency_hz") - fa.first), 3 * e.parameters.at("frequency_hz").sigma);
    EXPECT_LT(o.mc.fit_before.chi2_p, 1e-6);  // the plain model is rejected
    expectEffectExplainsData(o.mc);
    expectBaseRecovered(o.mc.fit_after, a);
  }
}

TEST(ModelCheck, SlowSinusoidFound) {
  // The slow-line cases of a 20 min, 100 Hz gyro (N 2e-4 rad/sqrt(s), B 5e-6 rad/s) with a 2e-4 rad/s sinusoid,
  // from 0.1 Hz down to six periods per record: a sinusoid each time (not a Gauss-Markov process), its frequency
  // within 3 reported sigma and 1 %, its amplitude within 20 %, and the fit error down at least 5x.
  for (double f : {0.1, 0.037, 0.012, 0.005}) {
    AxisNoise a;
    a.angle_random_walk = 2e-4;
    a.bias_instability = 5e-6;
    a.sine_frequency = f;
    a.sine_amplitude = 2e-4;
    const Outcome o = run(a, 100.0, 1200.0, 4);
    ASSERT_TRUE(o.mc.ok) << o.mc.message;
    const DetectedEffect* sine = nullptr;
    for (const auto& e : o.mc.effects) {
      EXPECT_NE(e.type, "gauss_markov") << "f " << f;
      if (e.type == "sinusoid") sine = &e;
    }
    ASSERT_NE(sine, nullptr) << "f " << f;
    const EffectParameter fp = sine->parameters.at("frequency_hz");
    EXPECT_LE(std::fabs(fp.value - f), 3 * fp.sigma) << "f " << f << " sigma " << fp.sigma;
    EXPECT_NEAR(fp.value, f, 0.01 * f);
    EXPECT_NEAR(std::fabs(param(*sine, "amplitude")), 2e-4, 0.2 * 2e-4) << "f " << f;
    EXPECT_LE(5 * o.mc.after.rms_log10, o.mc.before.rms_log10) << "f " << f;
    // The band searched (report.yaml line_search): the whole-record periodogram from 4 periods per record to 32 bins
    // of the 8192-sample Welch PSD, 464 whole-record bins, the count the line's false-alarm probability is over.
    EXPECT_DOUBLE_EQ(o.mc.line_search.slow_lo_hz, 4.0 / 1200.0);
    EXPECT_DOUBLE_EQ(o.mc.line_search.slow_hi_hz, 32 * 100.0 / 8192);
    EXPECT_EQ(o.mc.line_search.slow_frequencies, 464);
    EXPECT_NE(sine->evidence.find("over 464 frequencies"), std::string::npos) << sine->evidence;
    EXPECT_DOUBLE_EQ(o.mc.line_search.false_alarm_each, 0.005);
  }
}

TEST(ModelCheck, LinesThatDoNotLowerTheErrorAreRejected) {
  // A strong random walk (N 1e-4 rad/sqrt(s), K 3e-6 rad/s/sqrt(s), 1 h at 100 Hz, seed 1048) puts a periodogram
  // peak at 0.049 Hz past the line test (false-alarm probability 0.002); taken out, it does not lower the RMS error
  // by min_rms_gain, so it is listed under rejected with both errors and the answer is the plain fit.
  AxisNoise a;
  a.angle_random_walk = 1e-4;
  a.rate_random_walk = 3e-6;
  const std::vector<double> y = simulateAxis(a, 100.0, 360000, 1048);
  DeviationOptions o;
  o.grid.kind = TauGridKind::Log;
  o.grid.per_decade = 10;
  const DeviationCurve curve = oadev(y, 0.01, o);
  ModelCheckOptions mo;
  const ModelCheck mc = checkModel(y, 0.01, curve, fitNoiseModel(curve, mo.fit), mo);
  ASSERT_TRUE(mc.ok) << mc.message;
  EXPECT_TRUE(mc.effects.empty());
  EXPECT_DOUBLE_EQ(mc.after.rms_log10, mc.before.rms_log10);
  bool rejected = false;
  for (const auto& r : mc.rejected)
    rejected = rejected || (r.rfind("sinusoid at", 0) == 0 && r.find("with the lines taken out") != std::string::npos);
  EXPECT_TRUE(rejected);
}

TEST(ModelCheck, GaussMarkovFound) {
  // Tc = 10 s (100 Hz, 1 h) and Tc = 100 s (10 Hz, 30000 s): Tc within 30 %, sigma within 20 %, the refit explains
  // the curve.
  struct Case {
    double tc, sigma, rate, duration;
  };
  for (const Case& c : {Case{10.0, 1e-4, 100.0, 3600.0}, Case{100.0, 5e-5, 10.0, 30000.0}}) {
    AxisNoise a = baseNoise();
    a.gm_tau = c.tc;
    a.gm_sigma = c.sigma;
    const Outcome o = run(a, c.rate, c.duration, 1);
    ASSERT_FALSE(o.mc.effects.empty()) << "Tc " << c.tc;
    const DetectedEffect& e = o.mc.effects.front();
    EXPECT_EQ(e.type, "gauss_markov");
    EXPECT_NEAR(param(e, "tau_c_s"), c.tc, 0.3 * c.tc);
    EXPECT_NEAR(param(e, "sigma"), c.sigma, 0.2 * c.sigma);
    expectEffectExplainsData(o.mc, false);
    expectArwRecovered(o.mc.fit_after, a);
  }
}

TEST(ModelCheck, BiasStepFound) {
  // 0.3 mrad/s step at 37 % (seed 1) and 44 % (seed 20) of a 1 h record. A step's AVAR is h^2 tau / (3 (T - 2 tau)),
  // nearly the rate random walk shape with K^2 = h^2 / T: the joint fit takes it as a K far above the truth and the
  // data accept that model (chi2 p >= 0.01), so the step is not added. It is found in the raw samples and reported in
  // `rejected` with its time (within 1 % of the record), so the user sees it.
  for (const auto& [at, seed] : {std::pair<double, uint64_t>{0.37, 1}, std::pair<double, uint64_t>{0.44, 20}}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    AxisNoise a = baseNoise();
    a.step_size = 3e-4;
    a.step_time = at * 3600.0;
    const Outcome o = run(a, 100.0, 3600.0, seed);
    ASSERT_TRUE(o.mc.ok) << o.mc.message;
    EXPECT_TRUE(o.mc.effects.empty());
    EXPECT_DOUBLE_EQ(o.mc.after.rms_log10, o.mc.before.rms_log10);
    EXPECT_GE(o.mc.fit_before.chi2_p, 0.01);
    EXPECT_GT(o.mc.fit_before.terms[kRateRandomWalk].value, 5.0 * a.rate_random_walk);
    bool reported = false;
    for (const auto& r : o.mc.rejected)
      if (r.rfind("bias_step:", 0) == 0) {
        reported = true;
        const size_t t = r.find("at t = ");
        ASSERT_NE(t, std::string::npos) << r;
        EXPECT_NEAR(std::atof(r.c_str() + t + 7), a.step_time, 0.01 * 3600.0) << r;
      }
    EXPECT_TRUE(reported);
  }
}

TEST(ModelCheck, ThermalDriftWithTemperature) {
  // Warm-up of 1 mrad/s, theta 200 s, with the temperature series (10 degC warm-up): thermal_drift with the
  // coefficient 1e-4 (rad/s)/degC within 20 %, the refit explains the curve.
  AxisNoise a = baseNoise();
  a.thermal_amplitude = 1e-3;
  a.thermal_tau = 200.0;
  const Outcome o = run(a, 100.0, 3600.0, 1, true);
  ASSERT_FALSE(o.mc.effects.empty());
  const DetectedEffect& e = o.mc.effects.front();
  EXPECT_EQ(e.type, "thermal_drift");
  EXPECT_NEAR(param(e, "coefficient_per_degc"), 1e-4, 2e-5);
  expectEffectExplainsData(o.mc);
  expectBaseRecovered(o.mc.fit_after, a);
}

TEST(ModelCheck, WarmupWithoutTemperature) {
  // Same drift, no temperature: warm-up with theta within 30 % and amplitude within 20 %, the refit explains
  // the curve.
  AxisNoise a = baseNoise();
  a.thermal_amplitude = 1e-3;
  a.thermal_tau = 200.0;
  const Outcome o = run(a, 100.0, 3600.0, 2);
  ASSERT_FALSE(o.mc.effects.empty());
  const DetectedEffect& e = o.mc.effects.front();
  EXPECT_EQ(e.type, "warmup");
  EXPECT_NEAR(param(e, "theta_s"), 200.0, 60.0);
  EXPECT_NEAR(param(e, "amplitude"), 1e-3, 2e-4);
  expectEffectExplainsData(o.mc);
  expectBaseRecovered(o.mc.fit_after, a);
}

TEST(ModelCheck, NarrowbandResonanceFound) {
  // A narrowband process (Lorentzian PSD at 20 Hz, 1.5 Hz wide, kept to +-10 Hz; sigma 7e-4 rad/s: its PSD peak
  // ~10 dB above the white floor, as on the ADIS16405 z gyro) added to the base noise, 100 Hz x 1 h, three seeds.
  // Found as narrowband at f0 within 5 %, amplitude (sqrt(2) sigma for the whole process) within 10 %, the refit
  // explains the curve (the feature's tails were the z residual on the ADIS), angle random walk back to the truth.
  const double sigma = 7e-4;
  const AxisNoise a = baseNoise();
  for (uint64_t seed : {4, 5, 6}) {
    const Outcome o = run(a, 100.0, 3600.0, seed, false,
                          [&](std::vector<double>* r) { addLorentzian(r, 0.01, 20.0, 1.5, 10.0, sigma, 90 + seed); });
    ASSERT_TRUE(o.mc.ok) << o.mc.message;
    ASSERT_FALSE(o.mc.effects.empty());
    const DetectedEffect& e = o.mc.effects.front();
    EXPECT_EQ(e.type, "narrowband") << e.evidence;
    std::printf("seed %d narrowband: f0 %.3f Hz, amplitude %.4g (truth %.4g), rms %.4f -> %.4f, chi2/dof %.2f -> "
                "%.2f, %zu effect(s)\n  %s\n",
                static_cast<int>(seed), param(e, "frequency_hz"), param(e, "amplitude"), std::sqrt(2.0) * sigma,
                o.mc.before.rms_log10, o.mc.after.rms_log10, o.mc.before.chi2_dof, o.mc.after.chi2_dof,
                o.mc.effects.size(), e.evidence.c_str());
    EXPECT_NEAR(param(e, "frequency_hz"), 20.0, 1.0);
    EXPECT_NEAR(param(e, "amplitude"), std::sqrt(2.0) * sigma, 0.1 * std::sqrt(2.0) * sigma);
    EXPECT_LT(o.mc.fit_before.chi2_p, 1e-6);  // the plain model is rejected
    expectEffectExplainsData(o.mc);
    expectArwRecovered(o.mc.fit_after, a);
  }
}

TEST(ModelCheck, NarrowbandAtOtherFrequenciesAndWidths) {
  // Lorentzian features where the floor and the resolution matter (100 Hz x 1 h, base noise): 5 Hz 1 Hz wide (its
  // upper tail must not tilt the floor), 2 Hz 0.3 Hz wide (3 coarse bins: must not be taken for a line), 0.5 Hz
  // 0.1 Hz wide (needs a finer PSD than the default mid resolution), and 120 Hz 4 Hz wide at 400 Hz. Each: found as
  // narrowband, f0 within 5 %, amplitude within 10 %, chi2/dof <= 3 and a smaller RMS log10 error.
  struct Case {
    double rate, f0, fwhm, half_span, sigma;
  };
  for (const Case& c : {Case{100, 5.0, 1.0, 4.9, 5e-4}, Case{100, 2.0, 0.3, 1.9, 4e-4}, Case{100, 0.5, 0.1, 0.4, 3e-4},
                        Case{400, 120.0, 4.0, 30.0, 1.4e-3}}) {
    SCOPED_TRACE("f0 " + std::to_string(c.f0) + " Hz, width " + std::to_string(c.fwhm) + " Hz");
    const AxisNoise a = baseNoise();
    const Outcome o = run(a, c.rate, 3600.0, 4, false, [&](std::vector<double>* r) {
      addLorentzian(r, 1.0 / c.rate, c.f0, c.fwhm, c.half_span, c.sigma, 7);
    });
    ASSERT_TRUE(o.mc.ok) << o.mc.message;
    ASSERT_FALSE(o.mc.effects.empty());
    const DetectedEffect& e = o.mc.effects.front();
    EXPECT_EQ(e.type, "narrowband") << e.evidence;
    EXPECT_NEAR(param(e, "frequency_hz"), c.f0, 0.05 * c.f0);
    EXPECT_NEAR(param(e, "amplitude"), std::sqrt(2.0) * c.sigma, 0.1 * std::sqrt(2.0) * c.sigma);
    EXPECT_LE(o.mc.after.chi2_dof, 3.0);
    EXPECT_LT(o.mc.after.rms_log10, o.mc.before.rms_log10);
  }
}

TEST(ModelCheck, CleanControlsAddNothing) {
  // IEEE noise only: no effect added on any of 5 seeds (the 100+-seed rate is measured by validate_adis controls).
  for (uint64_t seed = 11; seed <= 15; ++seed) {
    const Outcome o = run(baseNoise(), 100.0, 3600.0, seed);
    ASSERT_TRUE(o.mc.ok);
    EXPECT_TRUE(o.mc.effects.empty()) << "seed " << seed << ": " << o.mc.effects.front().type << " ("
                                      << o.mc.effects.front().evidence << ")";
    EXPECT_DOUBLE_EQ(o.mc.after.rms_log10, o.mc.before.rms_log10);
  }
}

// A stochastic effect is a candidate only where the plain fit's residual is structured. population_study seed
// 100458 (N 0.085 deg/sqrt(h), B 1.3 deg/h, R 0.45 deg/h^2; 712 Hz, 79 min; no effect): its block means' exponential
// autocorrelation (flicker) offers a Gauss-Markov whose refit gains 43 in BIC (margin 40); kept, it took the long-tau
// power from B and R and put the answer's ADEV 0.74 off the truth. The plain fit's residual p is 0.019 (not
// structured at 0.01): with the gate the candidate is turned down and named; without it (the test's control) the
// Gauss-Markov is kept, so the test fails if the gate is ignored.
TEST(ModelCheck, StochasticEffectsNeedAStructuredResidual) {
  AxisNoise a;
  a.angle_random_walk = 2.45921259e-05;
  a.bias_instability = 6.20400698e-06;
  a.rate_ramp = 6.04719903e-10;
  const double rate = 712.061723, duration = 4760.60593;
  std::vector<std::vector<double>> seg(1);
  seg[0] = simulateAxis(a, rate, static_cast<int64_t>(rate * duration), 100458 ^ 0xA5A5A5A5ULL, 0);
  AnalysisOptions ao;
  ao.model_check = false;
  ao.wavelet_split = false;
  const AxisAnalysis an = analyzeAxis("x", seg, 1.0 / rate, ao);
  ModelCheckOptions co = ao.check;
  co.fit = ao.fit;
  const ModelCheck gated = checkModel(seg[0], 1.0 / rate, an.oadev, an.fit, co);
  ASSERT_TRUE(gated.ok) << gated.message;
  EXPECT_FALSE(gated.residual_before.structured) << gated.residual_before.summary;
  EXPECT_TRUE(gated.effects.empty()) << gated.effects.front().type;
  bool named = false;
  for (const auto& r : gated.rejected) named = named || r.rfind("gauss_markov: the plain fit describes", 0) == 0;
  EXPECT_TRUE(named) << "the turned-down candidate is not listed";
  co.stochastic_needs_structure = false;
  const ModelCheck ungated = checkModel(seg[0], 1.0 / rate, an.oadev, an.fit, co);
  ASSERT_TRUE(ungated.ok) << ungated.message;
  ASSERT_EQ(ungated.effects.size(), 1u) << "control: without the gate the Gauss-Markov is kept";
  EXPECT_EQ(ungated.effects[0].type, "gauss_markov");
}

TEST(ModelCheck, ResidualAnalysisSeesStructure) {
  // A model 10 % low over the short half of the curve and 5 % high over the rest: two stretches, 2 runs.
  DeviationCurve c;
  c.name = "oadev";
  std::vector<double> model;
  std::vector<bool> used;
  for (int i = 0; i < 20; ++i) {
    DeviationPoint p;
    p.tau = std::pow(10.0, i / 5.0);
    p.m = i + 1;
    p.var = 1.0 / p.tau;
    p.edf = 1000;
    c.points.push_back(p);
    model.push_back(p.var * (i < 10 ? 0.9 : 1.05));
    used.push_back(true);
  }
  const ResidualAnalysis ra = analyzeResidual(c, model, used, 5.0);
  EXPECT_TRUE(ra.structured);
  EXPECT_GT(ra.bump_z, 5.0);
  EXPECT_NEAR(ra.bump_tau_hi, c.points[9].tau, 1e-9);
  EXPECT_GT(ra.short_trend_z, 4.0);
}

TEST(ModelCheck, BadInputThrows) {
  const std::vector<double> rate(1000, 0.0);
  DeviationCurve c;
  FitResult f;
  ModelCheckOptions mo;
  EXPECT_THROW(checkModel(rate, 0.0, c, f, mo), std::invalid_argument);
  EXPECT_THROW(checkModel(rate, 0.01, c, f, mo), std::invalid_argument);  // empty curve
  std::vector<double> r2 = rate;
  r2[3] = std::nan("");
  DeviationOptions o;
  o.grid.kind = TauGridKind::Octave;
  const DeviationCurve curve = oadev(std::vector<double>(1000, 1.0), 0.01, o);
  EXPECT_THROW(checkModel(r2, 0.01, curve, f, mo), std::invalid_argument);
  const std::vector<double> temp(10, 20.0);
  EXPECT_THROW(checkModel(rate, 0.01, curve, f, mo, &temp), std::invalid_argument);
}
