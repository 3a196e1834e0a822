#pragma once
/// @file
/// The ODE backend: IDynamicsModel on Open Dynamics Engine bodies and joints built from a
/// URDF description, with contact candidates and simulation through ODE's own collision
/// detection and stepper (dWorldStep).
///
/// The backend shares no kinematics or dynamics code with the DART backend: one ODE body
/// per URDF link on a moving joint (plus the root; fixed-joint links are lumped into
/// their carrier), placed at its centre of mass with the link's axes. Forward kinematics
/// and the velocity recursion pose the ODE bodies; Jacobians, J̇·v, the mass matrix and
/// the bias are then derived from ODE's bodies (dBodyGetMass, velocities) and joints
/// (hinge anchors and axes, slider axes) in world coordinates.

#include <memory>
#include <string>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/model_options.hpp"
#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter::ode_backend {

/// Builds an ODE model of @p robot. Validates the description first (validateForDynamics)
/// and the options (environment, gravity). Throws ModelError or std::invalid_argument on a
/// bad description or options; never returns null.
std::unique_ptr<IDynamicsModel> makeOdeModel(const urdf::RobotDescription& robot,
                                             const ModelOptions& options = {});

/// Loads @p urdf_path and builds its ODE model.
std::unique_ptr<IDynamicsModel> loadOdeModel(const std::string& urdf_path,
                                             const ModelOptions& options = {});

}  // namespace dynfilter::ode_backend
