#pragma once
/// @file
/// The DART backend: IDynamicsModel on a dart::dynamics::Skeleton built from a URDF
/// description, with contact candidates and simulation through DART's Bullet collision.

#include <memory>
#include <string>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/model_options.hpp"
#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter::dart_backend {

/// Builds a DART model of @p robot. Validates the description first (validateForDynamics)
/// so that nothing malformed reaches DART, whose assertions abort the process.
/// Throws ModelError or std::invalid_argument on a bad description or options; never
/// returns null.
std::unique_ptr<IDynamicsModel> makeDartModel(const urdf::RobotDescription& robot,
                                              const ModelOptions& options = {});

/// Loads @p urdf_path and builds its DART model.
std::unique_ptr<IDynamicsModel> loadDartModel(const std::string& urdf_path,
                                              const ModelOptions& options = {});

}  // namespace dynfilter::dart_backend
