#pragma once
/// @file
/// The dynamics filter as a controller inside a user's own ODE simulation.
///
/// ```cpp
/// dynfilter::ode_backend::OdeRobotRefs robot{"figure", world, space, bodies, joints};
/// dynfilter::ode_backend::AttachedFilter filter(robot, options, proxqp::factory());
/// for (;;) {
///   filter.step(reference_at(t));     // reads the bodies, adds the joint torques
///   dSpaceCollide(space, ...);         // the user's own contacts ...
///   dWorldStep(world, dt);             // ... and step
/// }
/// ```
/// Each step() reads the bodies' state, starts the filter's tick from it
/// (DynamicsFilter::setMeasuredState), runs one tick toward the reference, puts the bodies
/// back exactly as they were, and adds the tick's joint torques through ODE's joint API
/// (OdeBodyModel::addJointTorques), clamped to OdeJointRef::tau_max. The user's
/// dWorldStep then applies them. The filter works on the user's bodies: no second copy.

#include <array>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/core/qp_solver.hpp"
#include "dynfilter/core/reference_frame.hpp"
#include "dynfilter/ode/body_model.hpp"

namespace dynfilter::ode_backend {

class AttachedFilter {
 public:
  /// Attaches to @p robot (attachOdeModel). The filter ticks once per world step of
  /// options.dt_s. FilterMode::kQp needs @p qp_solver. Throws what attachOdeModel and
  /// DynamicsFilter throw.
  AttachedFilter(const OdeRobotRefs& robot, const FilterOptions& options,
                 const QpSolverFactory& qp_solver = {});

  /// Starts the filter on @p reference and moves the robot there: the reference's state,
  /// raised along world z out of any penetration of the environment (DynamicsFilter::
  /// reset). Optional — step() alone starts the filter on its first reference and leaves
  /// the robot where it is. Throws InvalidStateError on an invalid frame.
  void placeAt(const ReferenceFrame& reference);

  /// The same over a model made beforehand (attachOdeModel or any OdeBodyModel).
  AttachedFilter(std::unique_ptr<OdeBodyModel> model, const FilterOptions& options,
                 const QpSolverFactory& qp_solver = {});

  /// One filter tick; call it once per world step, before dWorldStep. @p reference is in
  /// the model's coordinates (model().info()). The first call starts the filter on
  /// @p reference; every call starts the tick from the bodies' current state. Adds the
  /// tick's τ_J (none when the bodies' state is not finite). Never throws; no heap
  /// allocation in this class's code.
  const FilterOutput& step(const ReferenceFrame& reference);

  /// The joint torques added by the last step() (dim nj).
  const Eigen::VectorXd& appliedTorques() const { return tau_applied_; }
  OdeBodyModel& model() { return *model_; }
  const OdeBodyModel& model() const { return *model_; }
  DynamicsFilter& filter() { return *filter_; }
  const DynamicsFilter& filter() const { return *filter_; }

 private:
  struct BodyState {
    std::array<dReal, 3> p{}, v{}, w{};
    std::array<dReal, 4> quat{};
  };
  std::unique_ptr<OdeBodyModel> model_;
  std::unique_ptr<DynamicsFilter> filter_;
  bool started_ = false;
  std::vector<BodyState> saved_;
  Eigen::VectorXd tau_applied_;
  Eigen::VectorXd q_measured_, v_measured_;  // the state the tick started from
};

}  // namespace dynfilter::ode_backend
