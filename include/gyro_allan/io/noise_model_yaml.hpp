// noise_model.yaml: the GMWM state-space bias model per gyro axis (continuous parameters, Phi/Qd at the data rate and
// at a requested filter rate, the flicker-to-Gauss-Markov approximation and the closed-loop check); docs/outputs.md documents it.
#pragma once

#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "gyro_allan/analysis.hpp"

namespace gyro_allan {

/// The reported model of one axis (a.has_gmwm): reportedNoiseModel (gmwm.hpp) with the IEEE fit's reported
/// bias instability for the flicker comparison. noise_model.yaml and the nodelet's ~noise_model are both filled from it.
ReportedNoiseModel axisNoiseModel(const AxisAnalysis& a, double filter_rate_hz);

/// The tree (axes without a GMWM stage are skipped; an axis whose stage failed carries `error`).
/// filter_rate_hz <= 0: only the data rate's discrete model.
YAML::Node noiseModelNode(const std::vector<AxisAnalysis>& axes, double filter_rate_hz,
                          const std::vector<std::string>& sources);
/// YAML text of noiseModelNode with a one-line header comment.
std::string noiseModelYaml(const std::vector<AxisAnalysis>& axes, double filter_rate_hz,
                           const std::vector<std::string>& sources);
/// Human lines per axis: chosen model and the closed-loop check (GMWM model against the IEEE model).
std::string gmwmSummary(const std::vector<AxisAnalysis>& axes);

}  // namespace gyro_allan
