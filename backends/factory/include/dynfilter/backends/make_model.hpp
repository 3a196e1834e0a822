#pragma once
/// @file
/// Backend selection by name: the one place where "dart" and "ode" become models.

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/model_options.hpp"
#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter {

/// Names accepted by makeModel: {"dart", "ode"}.
const std::vector<std::string>& availableBackends();

/// Builds @p robot with the named backend. Throws std::invalid_argument naming the
/// unknown backend and listing the known ones, or the backend's own error (ModelError,
/// std::invalid_argument) when it cannot build the model. Never returns null.
std::unique_ptr<IDynamicsModel> makeModel(std::string_view backend,
                                          const urdf::RobotDescription& robot,
                                          const ModelOptions& options = {});

/// Loads @p urdf_path and builds it with the named backend.
std::unique_ptr<IDynamicsModel> loadModel(std::string_view backend, const std::string& urdf_path,
                                          const ModelOptions& options = {});

}  // namespace dynfilter
