// Discrete wavelet transforms with PyWavelets semantics (dwt/idwt, wavedec/waverec, swt/iswt) and MATLAB-style
// wavelet denoising (wden: sqtwolog, rigrsure, heursure, minimaxi; soft/hard; one/sln/mln) for the quantization split.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace gyro_allan {

/// An orthogonal wavelet filter bank named as PyWavelets names it (haar, db1-db20, sym2-sym20, coif1-coif5).
/// dec_lo/dec_hi/rec_lo/rec_hi are exactly pywt.Wavelet(name).dec_lo etc.:
///   rec_lo = scaling filter h, dec_lo[k] = h[L-1-k], rec_hi[k] = (-1)^k h[L-1-k], dec_hi[k] = (-1)^(k+1) h[k].
struct Wavelet {
  std::string name;
  std::vector<double> dec_lo, dec_hi, rec_lo, rec_hi;
  int vanishing_moments_psi = 0;

  /// Throws std::invalid_argument on an unknown name.
  explicit Wavelet(const std::string& name);
  int dec_len() const { return static_cast<int>(dec_lo.size()); }
};

/// Names accepted by Wavelet(name), in table order.
const std::vector<std::string>& waveletNames();
bool isWaveletName(const std::string& name);

/// Signal extension modes (PyWavelets names): "symmetric" (half-sample mirror), "periodization" (circular,
/// ceil(n/2) coefficients, an odd signal gets its last sample repeated), "zero", "periodic" (circular, n mod N).
enum class ExtensionMode { Symmetric, Periodization, Zero, Periodic };
/// Parses a mode name; throws std::invalid_argument otherwise.
ExtensionMode parseExtensionMode(const std::string& name);
std::string extensionModeName(ExtensionMode mode);

/// Length of each dwt output for an input of n samples (pywt.dwt_coeff_len): floor((n + F - 1) / 2),
/// or ceil(n / 2) for periodization.
int64_t dwt_coeff_len(int64_t n, int filter_len, ExtensionMode mode);
/// pywt.dwt_max_level: floor(log2(n / (filter_len - 1))), 0 if n < filter_len - 1.
int dwt_max_level(int64_t n, int filter_len);
/// pywt.swt_max_level: the largest level with n divisible by 2^level.
int swt_max_level(int64_t n);

struct DwtCoeffs {
  std::vector<double> cA;  ///< approximation
  std::vector<double> cD;  ///< detail
};

/// Single-level DWT (pywt.dwt): cA[o] = sum_j dec_lo[j] x_ext[2o + 1 - j] (periodization: x[(2o + F/2 - j) mod n']).
DwtCoeffs dwt(const std::vector<double>& x, const Wavelet& w, ExtensionMode mode);
/// Single-level inverse (pywt.idwt). cA and cD must have equal lengths; output length 2K - F + 2 (2K for
/// periodization). Throws std::invalid_argument on mismatched or too short inputs.
std::vector<double> idwt(const std::vector<double>& cA, const std::vector<double>& cD, const Wavelet& w,
                         ExtensionMode mode);

/// Multilevel DWT (pywt.wavedec): {cA_level, cD_level, ..., cD_1}. level < 0 means dwt_max_level(n, F).
std::vector<std::vector<double>> wavedec(const std::vector<double>& x, const Wavelet& w, ExtensionMode mode,
                                         int level = -1);
/// Multilevel inverse (pywt.waverec); an approximation one longer than the next detail is trimmed, as pywt does.
std::vector<double> waverec(const std::vector<std::vector<double>>& coeffs, const Wavelet& w, ExtensionMode mode);

/// Stationary (undecimated, a trous) transform with pywt.swt semantics (periodic, norm=False, trim_approx=False):
/// returns {(cA_level, cD_level), ..., (cA_1, cD_1)}; at level j (step s = 2^(j-1))
///   cA_j[o] = sum_k dec_lo[k] cA_{j-1}[(o + s F / 2 - s k) mod n].
/// level < 0 means swt_max_level(n); n must be divisible by 2^level.
std::vector<DwtCoeffs> swt(const std::vector<double>& x, const Wavelet& w, int level = -1);
/// Inverse of swt (pywt.iswt): uses cA of the first (coarsest) pair and every cD; each level is half the adjoint
/// of the analysis step, i.e. the average of the two decimated inverses, which is what pywt.iswt computes.
std::vector<double> iswt(const std::vector<DwtCoeffs>& coeffs, const Wavelet& w);

// ---- Denoising (MATLAB wden / thselect / wthresh / wnoisest semantics) ------------------------------------

/// Threshold selection rules (MATLAB thselect names).
enum class ThresholdRule { Sqtwolog, Rigrsure, Heursure, Minimaxi };
enum class ThresholdMode { Soft, Hard };
/// Noise scaling (MATLAB wden SCAL): none, single-level (level-1 MAD), multi-level (per-level MAD), plus an
/// extension of ours, SlnRms ("sln_rms"): single-level with the RMS of the level-1 details instead of the MAD. The MAD
/// sees only the gaps of a sparse pulse train (a pulse counter without dither at a constant rate), so "sln" would
/// treat the quantization pulses as signal and keep them; the RMS counts them (docs/wavelet_split.md).
enum class NoiseScaling { One, Sln, Mln, SlnRms };

ThresholdRule parseThresholdRule(const std::string& name);   ///< "sqtwolog", "rigrsure", "heursure", "minimaxi"
ThresholdMode parseThresholdMode(const std::string& name);   ///< "soft"/"s", "hard"/"h"
NoiseScaling parseNoiseScaling(const std::string& name);     ///< "one", "sln", "mln", "sln_rms"
std::string thresholdRuleName(ThresholdRule rule);
std::string thresholdModeName(ThresholdMode mode);
std::string noiseScalingName(NoiseScaling scaling);

/// MATLAB thselect for data with unit noise level: sqtwolog sqrt(2 ln n); rigrsure (Stein's unbiased risk);
/// heursure (sqtwolog when the signal-to-noise is low, else min(rigrsure, sqtwolog)); minimaxi
/// (0 for n <= 32, else 0.3936 + 0.1829 log2 n). Throws std::invalid_argument on an empty vector.
double thselect(const std::vector<double>& x, ThresholdRule rule);
/// Soft: sign(x) max(|x| - t, 0); hard: x if |x| > t else 0.
double wthresh(double x, ThresholdMode mode, double t);
/// Robust noise standard deviation of detail coefficients: median(|d|) / 0.6745 (MATLAB wnoisest).
double wnoisest(const std::vector<double>& d);

struct WdenOptions {
  std::string wavelet = "sym8";
  int level = 0;                    ///< decomposition level; <= 0 means dwt_max_level(n, F)
  ThresholdRule rule = ThresholdRule::Sqtwolog;
  ThresholdMode mode = ThresholdMode::Soft;
  NoiseScaling scaling = NoiseScaling::Sln;
  ExtensionMode extension = ExtensionMode::Symmetric;  ///< MATLAB's default dwtmode 'sym'
  /// removed = input - denoised instead of waverec of the removed coefficients (equal to rounding: the transform
  /// reconstructs perfectly to ~1e-15 of the input); saves two record-sized arrays on long records.
  bool removed_by_difference = false;
};

struct WdenResult {
  std::vector<double> denoised;        ///< waverec of the thresholded coefficients
  std::vector<double> removed;         ///< waverec of (coefficients - thresholded); denoised + removed = input
  int level = 0;
  std::vector<double> thresholds;      ///< per level 1..level (index 0 = level 1), already scaled by the noise
  std::vector<double> noise_sigma;     ///< per level, the scaling s_k used (1 for "one")
  std::vector<double> kept_fraction;   ///< per level, fraction of detail coefficients kept (non-zero after thr.)
};

/// Wavelet denoising as MATLAB wden(x, rule, sorh, scal, level, wname): multilevel DWT, details of levels
/// 1..level thresholded (approximation kept), threshold thselect * s_k. For sqtwolog and minimaxi the threshold
/// uses the total coefficient count (as wden does); rigrsure/heursure use each level's coefficients / s_k.
/// Both parts are returned; the removed part is reconstructed from the removed coefficients (not x - denoised).
WdenResult wden(const std::vector<double>& x, const WdenOptions& options = {});

/// Time-domain check of a removed (quantization) rate component: its integral, angle[i] = tau0 * sum_{k<=i}
/// removed[k], i.e. the quantization angle error, which must stay bounded and zero-mean.
std::vector<double> removedAngle(const std::vector<double>& removed, double tau0);

/// Statistics of such an angle error. The integration constant (the error at the first sample, within +-q/2 for
/// a pulse counter of weight q) is unknown, so spread and bound are taken about the mean.
struct AngleErrorStats {
  double mean = 0;     ///< mean of the angle (minus the unknown first-sample error) [rad]
  double std = 0;      ///< standard deviation about the mean [rad] (white quantization error: ~ Q)
  double max_abs = 0;  ///< max |angle - mean| (pulse counter: <= ~q = Q sqrt(12))
  double end = 0;      ///< final value of the angle
  /// |mean(second half) - mean(first half)| / std: ~0 for a bounded zero-mean error, O(1) or larger when the
  /// integral wanders (e.g. it carries random-walk angle).
  double half_mean_ratio = 0;
};
AngleErrorStats angleErrorStats(const std::vector<double>& angle);
/// The same on angle[0, n) (e.g. an interior part of a longer series, without copying it).
AngleErrorStats angleErrorStats(const double* angle, size_t n);

namespace wavelet_detail {
struct FilterEntry {
  const char* name;
  int vanishing_moments_psi;
  std::vector<double> rec_lo;
};
/// The generated table (src/core/wavelet_filters.cpp).
const std::vector<FilterEntry>& filterTable();
}  // namespace wavelet_detail

}  // namespace gyro_allan
