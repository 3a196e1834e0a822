#pragma once
/// @file
/// The DART backend on a URDF: builds a dart::dynamics::Skeleton from the description, a
/// static skeleton for the environment and a world with DART's Bullet collision, and
/// returns the SkeletonModel over them (skeleton_model.hpp): the same model a user gets by
/// attaching to their own skeleton. Bodies are the URDF links (fixed-joint links are
/// frames on their carrier body), joints the URDF's moving joints in file order.

#include <memory>
#include <string>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/model_options.hpp"
#include "dynfilter/dart/skeleton_model.hpp"
#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter::dart_backend {

/// Builds a DART model of @p robot. Validates the description first (validateForDynamics)
/// so that nothing malformed reaches DART, whose assertions abort the process.
/// Throws ModelError or std::invalid_argument on a bad description or options; never
/// returns null.
std::unique_ptr<IDynamicsModel> makeDartModel(const urdf::RobotDescription& robot,
                                              const ModelOptions& options = {},
                                              DartMassMatrix mass_matrix = DartMassMatrix::kBodySum);

/// Loads @p urdf_path and builds its DART model.
std::unique_ptr<IDynamicsModel> loadDartModel(const std::string& urdf_path,
                                              const ModelOptions& options = {},
                                              DartMassMatrix mass_matrix = DartMassMatrix::kBodySum);

}  // namespace dynfilter::dart_backend
