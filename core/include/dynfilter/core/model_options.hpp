#pragma once
/// @file
/// Options every backend accepts when it builds a model.

#include <Eigen/Core>

#include "dynfilter/core/environment.hpp"
#include "dynfilter/core/types.hpp"

namespace dynfilter {

struct ModelOptions {
  /// A free-floating base (6 unactuated coordinates) or a base welded to the world.
  bool floating_base = true;
  /// Gravity in world (m/s²).
  Eigen::Vector3d gravity_W = kStandardGravity_W;
  /// What the robot collides with.
  Environment environment;
  /// Whether the engine's own simulator (simulateStep) stops joints at their position
  /// limits. The analytic queries (A, b, Jacobians, forwardDynamics) never apply limits.
  bool enforce_joint_limits_in_simulation = false;
};

}  // namespace dynfilter
