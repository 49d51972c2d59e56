// Raw-sample diagnostics for the model check: Welch PSD and peaks, autocorrelation, mean-shift (bias step)
// detection, linear regression (rate vs temperature), warm-up fit and impulsive outliers.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

namespace gyro_allan {

/// One-sided power spectral density (units^2/Hz): integrates over [0, fs/2] to the variance.
struct Psd {
  double fs = 0;        ///< sample rate, Hz
  double df = 0;        ///< bin spacing, Hz
  int segments = 0;     ///< segments averaged
  std::vector<double> f;
  std::vector<double> p;
};

/// Welch estimate: Hann window, each segment's mean removed, `overlap` in [0, 0.9]. nperseg is clipped to the
/// record length and must be >= 16 after clipping. Throws std::invalid_argument on bad input.
Psd welchPsd(const std::vector<double>& x, double fs, int64_t nperseg, double overlap = 0.5);

/// A narrow feature of a PSD standing above its local floor (running median of the surrounding bins).
struct SpectralPeak {
  double frequency_hz = 0;   ///< power-weighted centroid of the excess over the floor
  double prominence_db = 0;  ///< 10 log10(peak bin / local median)
  double power = 0;          ///< excess power over the floor summed over the feature (units^2): A^2/2 for a sinusoid
  double amplitude = 0;      ///< sqrt(2 power): the amplitude of an equivalent sinusoid
  double bandwidth_hz = 0;   ///< width of the feature where the excess exceeds half its maximum (>= df)
  double df = 0;             ///< resolution of the PSD it was found in
  double floor = 0;          ///< local floor (running median) at the peak, units^2/Hz
  std::vector<double> profile_f;  ///< bins of the feature (Hz)
  std::vector<double> profile_p;  ///< their excess power over the floor (units^2, sums to `power`)
};

/// Peaks at least min_prominence_db above the running median of +-halfwidth bins (halfwidth chosen from the PSD
/// size), strongest first, at most max_peaks, one per feature. Bins below 6 df are not searched.
std::vector<SpectralPeak> findPsdPeaks(const Psd& psd, double min_prominence_db, int max_peaks);

/// A sinusoid A cos(2 pi f t + phi) in a record, its frequency and amplitude from least squares on the samples.
/// Sigmas are the Cramer-Rao bounds for a line in locally white noise of one-sided PSD S over the record length T:
/// sigma_A^2 = S / T, sigma_f^2 = 3 S / (pi^2 A^2 T^3).
struct SpectralLine {
  double frequency_hz = 0, frequency_sigma_hz = 0;
  double amplitude = 0, amplitude_sigma = 0;  ///< units of x
  double noise_psd = 0;     ///< S, one-sided, units^2/Hz
  double power_ratio = 0;   ///< periodogram of the whole record at the line over the noise level: A^2 T / (2 S)
  double false_alarm = 1;   ///< chance that noise alone gives a peak this high somewhere in the band searched
  int frequencies = 0;      ///< independent frequencies (whole-record bins) in that band
};

/// Chance that noise alone puts a whole-record periodogram peak `ratio` times above its level somewhere in a band
/// of `frequencies` whole-record bins searched on a fine grid (the family-wise false-alarm probability of
/// findSlowLines, also used for the Welch band).
double lineFalseAlarm(double ratio, int frequencies);

/// Joint least squares of sinusoids at the given frequencies, with a mean and a linear trend, on x (rate fs): the
/// cos and sin coefficients of each, phase referred to sample 0 (x[i] ~ c cos(2 pi f i / fs) + s sin(...)).
std::vector<std::pair<double, double>> fitSinusoids(const std::vector<double>& x, double fs,
                                                     const std::vector<double>& frequencies_hz);

/// Refines a line near f0 by least squares on the samples x (rate fs): the frequency within f0 +- half_width that
/// maximizes the whole-record periodogram (a zoom transform: x shifted by -f0 and averaged over blocks short enough
/// for that band, then golden-section search), then amplitude by linear least squares (mean, trend, cos, sin) on
/// every sample at that frequency. noise_psd: S at the line, for the sigmas.
SpectralLine refineLine(const std::vector<double>& x, double fs, double f0, double half_width, double noise_psd);

/// Lines between f_lo and f_hi (f_hi well below fs/2; meant for the band under a Welch search's resolution, down to
/// a few periods per record): periodogram of the whole record (block means of the detrended record, so that f_hi is
/// an eighth of their rate; Tukey window, 4x zero padding); noise level g^2 (w + b/f + k/f^2) fitted by Whittle
/// maximum likelihood with non-negative terms; the strongest peak is a line when its family-wise false-alarm
/// probability over the band (lineFalseAlarm) is below `false_alarm`; its frequency refined by least squares on the
/// block means, its amplitude by least squares on every sample; it leaves the block means and the search repeats, at
/// most max_lines times. Empty when the band holds fewer than 8 bins.
std::vector<SpectralLine> findSlowLines(const std::vector<double>& x, double fs, double f_lo, double f_hi,
                                        double false_alarm, int max_lines);

/// Biased autocovariance (mean removed, divided by n) at lags 0..max_lag, by FFT.
std::vector<double> autocovariance(const std::vector<double>& x, int64_t max_lag);

/// Means of consecutive blocks of `block` samples (a trailing partial block is dropped).
std::vector<double> blockMeans(const std::vector<double>& x, int64_t block);

/// Exponential decay a exp(-lag dt / tc) fitted to a normalized autocorrelation (rho[0] = 1 ignored) over the lags
/// where rho stays above `floor` (log-linear least squares). ok == false when fewer than 2 such lags.
struct ExponentialAcfFit {
  bool ok = false;
  double tc = 0;        ///< correlation time, s
  double a = 0;         ///< extrapolated correlation at lag 0+ (fraction of the variance that is correlated)
  double r2 = 0;        ///< coefficient of determination of the log-linear fit
  int lags = 0;
};
ExponentialAcfFit fitExponentialAcf(const std::vector<double>& rho, double dt, double floor);

/// A shift of the mean (bias step) found on block means.
struct MeanShift {
  bool found = false;
  int64_t index = 0;     ///< first sample after the step
  double size = 0;       ///< mean after minus mean before (local least squares), units of x
  double z = 0;          ///< block-mean difference in units of the robust (MAD) scale of all block-mean differences
};

/// Finds the most significant mean shift: differences of consecutive block means of `block` samples are compared
/// with their robust scale; the largest (z >= z_min) is localized to a sample by a least-squares step fit over
/// the two blocks on either side. Returns found == false when nothing reaches z_min.
MeanShift detectMeanShift(const std::vector<double>& x, int64_t block, double z_min);

/// Ordinary least squares y = intercept + slope x with the slope's standard error and the correlation r.
struct LinearRegression {
  double slope = 0, slope_sigma = 0, intercept = 0, r = 0;
  double rss = 0;  ///< residual sum of squares
  int n = 0;
};
LinearRegression linearRegression(const std::vector<double>& x, const std::vector<double>& y);

/// Warm-up drift c + a (1 - exp(-t/theta)) fitted to block means (t of block centres) by a log grid over theta in
/// [theta_min, theta_max] with linear least squares for c and a.
struct WarmupFit {
  bool ok = false;
  double theta = 0, a = 0, a_sigma = 0;
  double rss = 0;  ///< residual sum of squares at the optimum
};
WarmupFit fitWarmup(const std::vector<double>& block_means, double block_s, double theta_min, double theta_max);

/// Impulsive outliers: samples more than z_min robust sigmas away from the median of their +-half_window neighbours;
/// robust sigma = median of those distances over 2^15-2^16 evenly spaced samples (all if fewer) / 0.6745. Only windows whose
/// range exceeds z_min robust sigmas are examined sample by sample (O(n) for ordinary noise).
struct Outliers {
  std::vector<int64_t> index;
  double sum_sq_area = 0;   ///< sum over outliers of ((x - local median) * tau0)^2
  double robust_sigma = 0;
};
Outliers detectOutliers(const std::vector<double>& x, double tau0, double z_min, int half_window = 8);

}  // namespace gyro_allan
