// Internal helpers shared by allan.cpp and edf.cpp (deviation kinds, per-segment sums, noise identification).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace gyro_allan {

enum class DevKind { Adev, Oadev, Mdev, Tdev, Hdev, Ohdev, Totdev, Mtotdev, Ttotdev };

/// A contiguous phase record (no gaps).
struct PhaseSpan {
  const double* x = nullptr;
  int64_t n = 0;
};

/// Sum of squared differences and their count, pooled over segments.
struct SegmentSums {
  long double sumsq = 0;
  int64_t terms = 0;
};

DevKind devKindFromName(const std::string& name);
int64_t deviationMaxFactor(DevKind kind, int64_t n_phase);
/// Adds the segment's squared differences (and their count) at factor m.
void accumulateSegment(DevKind kind, const double* x, int64_t n, int64_t m, SegmentSums* s);
double varianceFromSums(DevKind kind, const SegmentSums& s, int64_t m, double tau0);

/// Power-law noise exponent alpha in [-2, 2] at averaging factor m (lag-1 ACF method, Riley & Greenhall);
/// returns kNoAlpha when too few points remain (caller then reuses the neighbouring point's alpha).
constexpr int kNoAlpha = 99;
int identifyNoiseAlpha(DevKind kind, const std::vector<PhaseSpan>& phases, int64_t m);

/// Greenhall-Riley EDF of a d-th difference variance (d = 2 Allan, 3 Hadamard) of n phase points at factor m.
double greenhallEdf(int alpha, int d, int64_t m, int64_t n, bool overlapping, bool modified);

/// Phase-point count of a single gap-free record that would give n_terms terms at factor m.
int64_t equivalentPhasePoints(DevKind kind, int64_t n_terms, int64_t m);

}  // namespace gyro_allan
