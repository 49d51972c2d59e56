// Warnings for the user as data: a kind that readers act on and a text for humans.
#pragma once

#include <string>
#include <vector>

namespace gyro_allan {

/// What a warning (PipelineResult::warnings) is about; readers act on the kind, the text is for humans.
enum class WarningKind {
  Stamps,       ///< timing: gaps, drops, jitter (timing.hpp StampReport)
  Motion,       ///< the sensor moved: only the static stretch analysed
  Shocks,       ///< impulsive samples kept (--keep-spikes)
  Saturation,   ///< runs of identical extreme values
  Spikes,       ///< spikes removed by the analysis (spikes.hpp)
  MeanRate,     ///< a mean rate no gyro at rest reads
  BadFit,       ///< an axis's verdict is bad
  Accelerometer ///< the accelerometer was not analysed, or its own stamps' warnings
};

struct Warning {
  WarningKind kind = WarningKind::Stamps;
  std::string text;
  bool operator==(const Warning& o) const { return kind == o.kind && text == o.text; }
};

/// The texts of `w`, in order (report.yaml, the ROS message).
inline std::vector<std::string> warningTexts(const std::vector<Warning>& w) {
  std::vector<std::string> t;
  t.reserve(w.size());
  for (const Warning& x : w) t.push_back(x.text);
  return t;
}

}  // namespace gyro_allan
