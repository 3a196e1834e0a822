// dynfilter.Model: a URDF through a named backend, and its dynamics at a given state.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "dynfilter/core/kinematic_tree.hpp"
#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/core/types.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"

namespace dynfilter::python {

std::unique_ptr<IDynamicsModel> Model::make(const Environment& environment) const {
  ModelOptions options;
  options.floating_base = floating_base;
  options.environment = environment;
  return makeModel(backend, robot, options);
}

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// Sets the engine's state, checking it first (InvalidStateError naming the entry).
IDynamicsModel& at(Model& model, const VectorXd& q, const std::optional<VectorXd>& v) {
  const VectorXd v_or_zero = v ? *v : VectorXd::Zero(model.engine->nv());
  model.engine->info().requireValidState(q, v_or_zero);
  model.engine->setState(q, v_or_zero);
  return *model.engine;
}

int bodyIndex(const Model& model, const std::string& body) {
  const int index = model.engine->info().findBody(body);
  if (index < 0)
    throw std::invalid_argument("unknown body \"" + body + "\" in " + model.urdf_path);
  return index;
}

}  // namespace

void bindModel(py::module_& m) {
  m.def("available_backends", &availableBackends, "Backend names: ['dart', 'ode'].");

  py::class_<Model>(m, "Model",
                    "A robot model: a URDF computed by a backend (\"dart\" or \"ode\"). "
                    "Coordinates: q = [p_WB (m); quat_WB (w, x, y, z); joints], v = [v_B; w_B "
                    "(base frame); joint rates] for a floating base (README, Conventions).")
      .def(py::init([](const std::string& urdf_path, const std::string& backend,
                       bool floating_base, const std::vector<std::string>& package_paths,
                       const std::vector<std::string>& lock_joints) {
             auto model = std::make_unique<Model>();
             model->urdf_path = urdf_path;
             model->backend = backend;
             model->floating_base = floating_base;
             urdf::UrdfLoadOptions load;
             load.package_paths = package_paths;
             load.lock_joints = lock_joints;
             model->robot = urdf::loadUrdfFile(urdf_path, load);
             model->engine = model->make(Environment{});
             return model;
           }),
           py::arg("urdf_path"), py::arg("backend") = "dart", py::arg("floating_base") = true,
           py::arg("package_paths") = std::vector<std::string>{},
           py::arg("lock_joints") = std::vector<std::string>{},
           "Loads urdf_path with the backend. package_paths: folders searched for package:// "
           "meshes before ROS_PACKAGE_PATH and the folders above the URDF (the tools' "
           "--package-path). lock_joints: joints welded, each a name or a pattern with * and ?, "
           "optionally '=position' (rad or m; default 0) (the tools' --lock-joints). Raises "
           "ModelError ('<file>:<line>: <element>: <reason>') on a bad URDF, a mesh not found "
           "or a lock that names no joint, ValueError on an unknown backend.")
      .def_readonly("urdf_path", &Model::urdf_path)
      .def_readonly("backend", &Model::backend)
      .def_readonly("floating_base", &Model::floating_base)
      .def_property_readonly("warnings", [](const Model& mo) { return mo.robot.warnings; },
                             "Accepted oddities of the URDF (e.g. mesh collisions skipped).")
      .def_property_readonly("name", [](const Model& mo) { return mo.engine->info().name; })
      .def_property_readonly("nq", [](const Model& mo) { return mo.engine->nq(); })
      .def_property_readonly("nv", [](const Model& mo) { return mo.engine->nv(); })
      .def_property_readonly("nj", [](const Model& mo) { return mo.engine->nj(); })
      .def_property_readonly("joint_names",
                             [](const Model& mo) { return mo.engine->info().joint_names; })
      .def_property_readonly("body_names",
                             [](const Model& mo) { return mo.engine->info().body_names; })
      .def_property_readonly(
          "locked_joint_names", [](const Model& mo) { return mo.engine->info().locked_joint_names; },
          "Joints welded by lock_joints (file order); a reference's columns for them are skipped.")
      .def_property_readonly(
          "joint_groups",
          [](Model& mo) {
            std::vector<std::string> names;
            for (const JointGroup g : jointGroupsOf(*mo.engine)) names.emplace_back(toString(g));
            return names;
          },
          "(nj,) 'spine', 'legs', 'arms' or 'other' per joint, by the kinematic tree (no "
          "names): the groups the tools report tracking errors in.")
      .def_property_readonly("q_lower", [](const Model& mo) { return mo.engine->info().q_lower; },
                             "(nj,) joint lower limits (rad or m), -inf when none")
      .def_property_readonly("q_upper", [](const Model& mo) { return mo.engine->info().q_upper; })
      .def_property_readonly("v_max", [](const Model& mo) { return mo.engine->info().v_max; })
      .def_property_readonly("tau_max", [](const Model& mo) { return mo.engine->info().tau_max; },
                             "(nj,) joint effort limits (N m or N), inf when none")
      .def_property_readonly("total_mass",
                             [](const Model& mo) { return mo.engine->info().total_mass; })
      .def("neutral_configuration",
           [](const Model& mo) { return mo.engine->info().neutralConfiguration(); },
           "(nq,) base at the origin, identity orientation, joints at 0 clamped to limits.")
      .def("mass_matrix",
           [](Model& mo, const VectorXd& q) {
             MatrixXd A(mo.engine->nv(), mo.engine->nv());
             at(mo, q, std::nullopt).massMatrix(A);
             return A;
           },
           py::arg("q"), "(nv, nv) joint-space mass matrix A at q.")
      .def("bias",
           [](Model& mo, const VectorXd& q, const VectorXd& v) {
             VectorXd b(mo.engine->nv());
             at(mo, q, v).bias(b);
             return b;
           },
           py::arg("q"), py::arg("v"), "(nv,) b: A v̇ + b = τ (Coriolis, centrifugal, gravity).")
      .def("forward_dynamics",
           [](Model& mo, const VectorXd& q, const VectorXd& v, const VectorXd& tau) {
             if (tau.size() != mo.engine->nj())
               throw std::invalid_argument("tau has " + std::to_string(tau.size()) +
                                           " entries, the model " +
                                           std::to_string(mo.engine->nj()) + " joints");
             VectorXd vdot(mo.engine->nv());
             at(mo, q, v).forwardDynamics(tau, vdot);
             return vdot;
           },
           py::arg("q"), py::arg("v"), py::arg("tau"),
           "(nv,) v̇ under joint torques tau (nj,), without contacts.")
      .def("body_positions",
           [](Model& mo, const VectorXd& q) {
             IDynamicsModel& e = at(mo, q, std::nullopt);
             const int n = static_cast<int>(e.info().body_names.size());
             Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> p(n, 3);
             for (int b = 0; b < n; ++b) p.row(b) = e.bodyPose(b).translation().transpose();
             return p;
           },
           py::arg("q"), "(bodies, 3) world position of every link origin (m) at q.")
      .def("point_jacobian",
           [](Model& mo, const VectorXd& q, const std::string& body, const Eigen::Vector3d& p_BP) {
             const int index = bodyIndex(mo, body);
             Matrix6Xd J(6, mo.engine->nv());
             at(mo, q, std::nullopt).pointJacobian(index, p_BP, J);
             return Eigen::MatrixXd(J);
           },
           py::arg("q"), py::arg("body"), py::arg("p_BP") = Eigen::Vector3d::Zero(),
           "(6, nv) world-aligned Jacobian [linear; angular] of point p_BP fixed on body.")
      .def("__repr__", [](const Model& mo) {
        return "<dynfilter.Model " + mo.engine->info().name + " (" + mo.backend + ", nq " +
               std::to_string(mo.engine->nq()) + ", nv " + std::to_string(mo.engine->nv()) +
               ") from " + mo.urdf_path + ">";
      });
}

}  // namespace dynfilter::python
