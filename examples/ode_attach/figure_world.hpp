#pragma once
// The user's side of examples/ode_attach: an ODE world with a ground plane and a robot
// built from a URDF the user parses themselves (urdfdom) — one ODE body per link at its
// centre of mass with the link's axes, a hinge per revolute joint (slider per prismatic,
// fixed per fixed joint), the link's boxes, spheres and cylinders as geoms. The robot's
// bodies and joints are named for the filter in `robot`.
#include <string>
#include <vector>

#include <ode/ode.h>

#include "dynfilter/ode/body_model.hpp"

class FigureWorld {
 public:
  /// Builds the robot of @p urdf_path standing at its zero pose, base link at the origin.
  explicit FigureWorld(const std::string& urdf_path);
  ~FigureWorld();
  FigureWorld(const FigureWorld&) = delete;
  FigureWorld& operator=(const FigureWorld&) = delete;

  /// The user's own simulation step: contacts between the robot and the ground (contact
  /// joints, μ = 0.8), then dWorldStep.
  void step(double dt_s);

  dWorldID world = nullptr;
  dSpaceID space = nullptr;
  dynfilter::ode_backend::OdeRobotRefs robot;  ///< bodies and joints, named

 private:
  static void nearCallback(void* data, dGeomID g1, dGeomID g2);
  dJointGroupID contacts_ = nullptr;
};
