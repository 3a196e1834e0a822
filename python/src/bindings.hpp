#pragma once
// Shared pieces of the dynfilter._dynfilter extension module (pybind11).

#include <memory>
#include <string>

#include <pybind11/pybind11.h>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/environment.hpp"
#include "dynfilter/io/config.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter::python {

namespace py = pybind11;

/// A robot model: its parsed URDF and the backend that computes with it. The engine
/// instance here (level ground) answers kinematic and dynamic queries and retargets; every
/// filter builds its own instance with its configuration's environment.
struct Model {
  std::string urdf_path;
  std::string backend;
  bool floating_base = true;
  urdf::RobotDescription robot;
  std::unique_ptr<IDynamicsModel> engine;

  /// A new engine instance of the same robot in @p environment.
  std::unique_ptr<IDynamicsModel> make(const Environment& environment) const;
};

/// A reference motion in the model's coordinates (io::ReferenceMotion).
struct Reference {
  io::ReferenceMotion motion;
  int nq = 0, nv = 0;
};

void bindModel(py::module_& m);
void bindMotion(py::module_& m);
void bindFilter(py::module_& m);

}  // namespace dynfilter::python
