// libFuzzer target: dwt/idwt, wavedec/waverec, swt/iswt and wden on arbitrary signals, wavelets, modes and levels.
// Allowed outcomes: a result (perfect reconstruction for finite input) or std::invalid_argument.
#include <cmath>
#include <stdexcept>
#include <vector>

#include "fuzz_input.hpp"
#include "gyro_allan/wavelet.hpp"

using namespace gyro_allan;

namespace {
void checkClose(const std::vector<double>& x, const std::vector<double>& y, double scale) {
  if (y.size() < x.size()) __builtin_trap();
  for (size_t i = 0; i < x.size(); ++i)
    if (std::fabs(x[i] - y[i]) > 1e-6 * (scale + 1e-300)) __builtin_trap();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  gyro_allan_fuzz::Bytes b(data, size);
  const auto& names = waveletNames();
  const Wavelet w(names[b.u8() % names.size()]);
  static const ExtensionMode modes[] = {ExtensionMode::Symmetric, ExtensionMode::Periodization, ExtensionMode::Zero,
                                        ExtensionMode::Periodic};
  const ExtensionMode mode = modes[b.u8() % 4];
  const int level = static_cast<int>(b.u8() % 12) - 1;
  const uint8_t what = b.u8();
  const double scale = std::ldexp(1.0, (b.u8() % 40) - 20);
  std::vector<double> x;
  while (b.left() >= 2 && x.size() < 4096) x.push_back(b.i16() * scale);
  double amax = 0;
  for (double v : x) amax = std::max(amax, std::fabs(v));
  try {
    switch (what % 4) {
      case 0: {
        const DwtCoeffs c = dwt(x, w, mode);
        checkClose(x, idwt(c.cA, c.cD, w, mode), amax * x.size());
        break;
      }
      case 1: checkClose(x, waverec(wavedec(x, w, mode, level), w, mode), amax * x.size()); break;
      case 2: checkClose(x, iswt(swt(x, w, level), w), amax * x.size()); break;
      default: {
        WdenOptions o;
        o.wavelet = w.name;
        o.level = level;
        o.rule = static_cast<ThresholdRule>((what >> 2) % 4);
        o.mode = (what & 16) ? ThresholdMode::Hard : ThresholdMode::Soft;
        o.scaling = static_cast<NoiseScaling>((what >> 5) % 4);
        o.extension = mode;
        const WdenResult r = wden(x, o);
        if (r.denoised.size() != x.size() || r.removed.size() != x.size()) __builtin_trap();
        for (size_t i = 0; i < x.size(); ++i)
          if (std::fabs(r.denoised[i] + r.removed[i] - x[i]) > 1e-6 * (amax * x.size() + 1e-300)) __builtin_trap();
      }
    }
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
