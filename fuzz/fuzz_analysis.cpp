// libFuzzer target: sanitize + analyzeAxis with stamps, samples and options decoded from the input. Allowed outcomes:
// a result or std::invalid_argument; the stamp counts must always add up (nothing lost).
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "fuzz_input.hpp"
#include "gyro_allan/analysis.hpp"
#include "gyro_allan/timing.hpp"

using namespace gyro_allan;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  gyro_allan_fuzz::Bytes b(data, size);
  const uint8_t flags = b.u8();
  const int naxes = 1 + b.u8() % 3;
  SanitizeOptions so;
  so.gap_factor = 1.01 + b.u8() / 16.0;
  const uint8_t r = b.u8();
  so.nominal_rate_hz = (r & 1) ? 0.0 : std::ldexp(1.0 + (r >> 1), (b.u8() % 24) - 4);
  AnalysisOptions opt;
  static const char* grids[] = {"octave", "decade", "all", "log", "log:3", "log:40"};
  std::string err;
  if (!parseTauGrid(grids[b.u8() % 6], &opt.deviation.grid, &err)) __builtin_trap();
  static const char* devs[] = {"oadev", "adev", "mdev", "hdev", "ohdev", "tdev", "totdev"};
  opt.deviations = {devs[b.u8() % 7]};
  opt.input = (flags & 2) ? InputKind::Angle : InputKind::Rate;
  opt.deviation.confidence = (flags & 4) ? 0.95 : 0.683;

  // Samples: raw doubles (NaN/Inf/huge) or int16 values on a scale with jittered, sometimes broken stamps.
  const bool raw = flags & 1;
  const double scale = std::ldexp(1.0, (b.u8() % 40) - 30);
  std::vector<double> t;
  std::array<std::vector<double>, 3> v;
  double stamp = 1.0;
  while (b.left() > 0 && t.size() < 20000) {
    if (raw) {
      t.push_back(b.raw());
      for (int a = 0; a < naxes; ++a) v[a].push_back(b.raw());
    } else {
      const uint8_t s = b.u8();
      stamp += (s < 240) ? 0.01 : (s - 239) * 0.01 * ((s & 1) ? -1 : 3);  // mostly 100 Hz, some jumps back/forward
      t.push_back(s == 255 ? 0.0 : stamp);
      for (int a = 0; a < naxes; ++a) v[a].push_back(b.i16() * scale);
    }
  }
  std::vector<const std::vector<double>*> axes;
  for (int a = 0; a < naxes; ++a) axes.push_back(&v[a]);
  SanitizedSeries ss;
  try {
    ss = sanitize(t, axes, so);
  } catch (const std::invalid_argument&) {
    return 0;
  }
  const StampReport& rep = ss.report;
  // Nothing lost: every input sample is kept or counted under exactly one reason.
  if (rep.input != static_cast<int64_t>(t.size())) __builtin_trap();
  if (rep.kept + rep.non_finite + rep.zero_stamp + rep.out_of_order + rep.duplicate + rep.too_close + rep.short_segment !=
      rep.input)
    __builtin_trap();
  if (rep.kept != static_cast<int64_t>(ss.t.size())) __builtin_trap();
  size_t in_segments = 0;
  for (const auto& s : ss.segments) {
    if (s.begin >= s.end || s.end > ss.t.size()) __builtin_trap();
    in_segments += s.size();
  }
  if (in_segments != ss.t.size()) __builtin_trap();
  if (!(rep.nominal_period_s > 0) || !std::isfinite(rep.nominal_period_s)) return 0;
  for (int a = 0; a < naxes; ++a) {
    try {
      const AxisAnalysis res = analyzeAxis("x", ss.segmentValues(a), rep.nominal_period_s, opt);
      for (const auto& p : res.oadev.points)
        if (!(p.tau > 0)) __builtin_trap();
    } catch (const std::invalid_argument&) {
    }
  }
  return 0;
}
