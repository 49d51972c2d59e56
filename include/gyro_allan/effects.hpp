// Closed-form Allan-variance terms of effects the IEEE 952 model lacks (sinusoid, Gauss-Markov, bias step, warm-up).
#pragma once

#include <cstdint>
#include <vector>

namespace gyro_allan {

// Every function returns the overlapping Allan variance at averaging time tau of the effect with UNIT amplitude
// parameter squared, so the effect's AVAR is c * basis(tau) with c = amplitude^2 (the ExtraTerm convention of
// noise_model.hpp). All throw std::invalid_argument on non-positive tau or out-of-range parameters.

/// Sinusoid y = A sin(2 pi f0 t + phi), per unit A^2 (A in rad/s). Continuous averaging (tau0 <= 0):
/// (sin^2(pi f0 tau) / (pi f0 tau))^2. With tau0 > 0 the m = tau/tau0 sample mean is used instead:
/// sin^4(pi f0 tau) / (m sin(pi f0 tau0))^2 (exact for sampled data, matters near Nyquist).
double sinusoidAvar(double tau, double f0, double tau0 = 0);

/// Any stationary component given by its one-sided PSD on equally spaced bins f_i = f_start + i df (f_i in
/// (0, fs/2]): power[i] is the component's power in bin i (units^2, i.e. PSD x df), so a sinusoid of amplitude A is
/// power A^2/2 in one bin. Returns the overlapping AVAR of the m = tau/tau0 sample means (tau0 > 0):
/// sum_i power[i] 2 sin^4(pi f_i tau) / (m sin(pi f_i tau0))^2 (= sum_i 2 power[i] sinusoidAvar(tau, f_i, tau0)),
/// evaluated with a rotation recurrence over the bins (no sin call per bin). Bins at multiples of fs contribute 0.
double spectrumAvar(double tau, double f_start, double df, const std::vector<double>& power, double tau0);

/// First-order Gauss-Markov (exponentially correlated, R(t) = sigma^2 exp(-|t|/tc)), per unit sigma^2:
/// (tc/tau)^2 (2 tau/tc - 3 + 4 exp(-tau/tc) - exp(-2 tau/tc)). Rises as (2/3) tau/tc, peaks ~0.6 at tau ~ 1.9 tc,
/// then falls as 2 tc/tau (white). With tau0 > 0 the exact sampled (AR(1), phi = exp(-tau0/tc)) form is used, with
/// m = tau/tau0: (Var(S_m) - Cov(S_m, S'_m)) / m^2, Var(S_m) = m + 2 phi (m (1-phi) - (1-phi^m)) / (1-phi)^2,
/// Cov = phi (1-phi^m)^2 / (1-phi)^2; it matters when tc is within ~20 samples (e.g. a sensor's internal filter).
double gaussMarkovAvar(double tau, double tc, double tau0 = 0);

/// Bias step of unit size at time t_step in a record of length record_s, as seen by the overlapping estimator
/// (not an ensemble quantity): the integral of the squared difference-of-means over the start times whose two
/// windows straddle the step, divided by 2 (record_s - 2 tau). For a step well inside the record it is
/// tau / (3 (record_s - 2 tau)). Zero when 2 tau >= record_s.
double biasStepAvar(double tau, double t_step, double record_s);

/// Warm-up drift a (1 - exp(-t/theta)) over a record of length record_s, per unit a^2 (overlapping estimator):
/// theta^3 (1 - e^{-tau/theta})^4 (1 - e^{-2 (record_s - 2 tau)/theta}) / (4 tau^2 (record_s - 2 tau)).
double warmupAvar(double tau, double theta, double record_s);

/// Noise correlated over a few samples (a sensor's internal low-pass / decimation filter), beyond its
/// white-equivalent part: for autocovariances gamma_k vanishing beyond lag L, AVAR(m) = S/m - 3 M1/m^2 exactly for
/// m >= L, with S = gamma_0 + 2 sum gamma_k (the white level, N^2 = S tau0) and M1 = sum_k k gamma_k. This returns
/// the second part per unit M1 (rate^2): -3 (tau0/tau)^2. It is NEGATIVE: the shape of the IEEE quantization term
/// with the opposite sign, which the non-negative IEEE fit cannot represent.
double shortCorrelationAvar(double tau, double tau0);

/// Isolated impulses (shocks): per unit sum of squared impulse areas (sum of (spike * tau0)^2, rad^2), well inside
/// the record: 1 / (tau (record_s - 2 tau)).
double impulseAvar(double tau, double record_s);

/// Overlapping Allan variance of samples y at averaging factor m (sum of squared differences of m-sample means over
/// every start, / (2 (n - 2m + 1))); the brute-force reference used to build empirical bases (e.g. of a temperature
/// series) and to verify the closed forms. Returns 0 when n < 2m + 1; throws on m < 1.
double overlappingAvarAt(const std::vector<double>& y, int64_t m);

}  // namespace gyro_allan
