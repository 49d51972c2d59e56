// Conversion of the core's reported GMWM noise model of one axis (gmwm.hpp ReportedNoiseModel) to the ~noise_model
// per-axis message (gyro_allan/AxisNoiseModel), field by field as noise_model.yaml prints it; ROS-master free.
#pragma once

#include <string>

#include <gyro_allan/AxisNoiseModel.h>

#include "gyro_allan/gmwm.hpp"

namespace gyro_allan {

/// One axis of ~noise_model from the reported model (axisNoiseModel, io/noise_model_yaml.hpp, fills r for the YAML
/// too). ok false: only axis, ok and error are set. A continuous term not in the model stays 0 (sigma 0). Phi and Qd
/// are flattened row-major: element (i, j) at i * dimension + j.
AxisNoiseModel toAxisNoiseModel(const std::string& axis, const ReportedNoiseModel& r);

}  // namespace gyro_allan
