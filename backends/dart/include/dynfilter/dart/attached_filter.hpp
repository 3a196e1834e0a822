#pragma once
/// @file
/// The dynamics filter as a controller inside a user's own DART simulation.
///
/// ```cpp
/// auto world = dart::simulation::World::create();      // the user's world ...
/// world->addSkeleton(robot);                              // ... their robot and ground
/// dynfilter::dart_backend::AttachedFilter filter(robot, world, options, proxqp::factory());
/// for (;;) {
///   filter.step(reference_at(world->getTime()));          // reads the state, sets forces
///   world->step();
/// }
/// ```
/// Each step() reads the skeleton's state, starts the filter's tick from it (closing the
/// loop on what the world simulates, DynamicsFilter::setMeasuredState), runs one tick
/// toward the reference, puts the skeleton's state back as it was, and sets the joint
/// forces through DART's own API (Skeleton::setForces), clamped to the DoF force limits.
/// The world's step then applies them. The robot is not loaded a second time: the filter
/// queries the user's skeleton (skeleton_model.hpp).

#include <memory>

#include <Eigen/Core>
#include <dart/dynamics/Skeleton.hpp>
#include <dart/simulation/World.hpp>

#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/core/qp_solver.hpp"
#include "dynfilter/core/reference_frame.hpp"
#include "dynfilter/dart/skeleton_model.hpp"

namespace dynfilter::dart_backend {

class AttachedFilter {
 public:
  /// Attaches to @p skeleton in @p world (attachDartModel). @p options.dt_s must equal the
  /// world's time step: the filter ticks once per world step. FilterMode::kQp needs
  /// @p qp_solver. Throws what attachDartModel and DynamicsFilter throw, and
  /// std::invalid_argument on a time step mismatch.
  AttachedFilter(const dart::dynamics::SkeletonPtr& skeleton,
                 const dart::simulation::WorldPtr& world, const FilterOptions& options,
                 const QpSolverFactory& qp_solver = {}, const AttachOptions& attach = {});

  /// Starts the filter on @p reference and moves the robot there: the reference's state,
  /// raised along world z out of any penetration of the environment (DynamicsFilter::
  /// reset). Optional — step() alone starts the filter on its first reference and leaves
  /// the robot where it is. Throws InvalidStateError on an invalid frame.
  void placeAt(const ReferenceFrame& reference);

  /// The same over a model made beforehand (attachDartModel, or any SkeletonModel whose
  /// skeleton is in a world of time step @p options.dt_s).
  AttachedFilter(std::unique_ptr<SkeletonModel> model, const FilterOptions& options,
                 const QpSolverFactory& qp_solver = {});

  /// One filter tick; call it once per world step, before world->step(). @p reference is
  /// in the model's coordinates (model().info(): DART's DoF order and names). The first
  /// call starts the filter (its contacts and feedback) on @p reference; every call
  /// starts the tick from the skeleton's current state. Sets the skeleton's joint forces
  /// to the tick's τ_J (zero when the tick's answer is not to be used: a non-finite state
  /// read from the skeleton). Never throws; no heap allocation in this class's code (the
  /// world's collision detector may allocate inside DART).
  const FilterOutput& step(const ReferenceFrame& reference);

  /// The joint torques set by the last step() (dim nj, clamped to the force limits).
  const Eigen::VectorXd& appliedTorques() const { return tau_applied_; }
  SkeletonModel& model() { return *model_; }
  const SkeletonModel& model() const { return *model_; }
  DynamicsFilter& filter() { return *filter_; }
  const DynamicsFilter& filter() const { return *filter_; }

 private:
  void saveSkeletonState();
  void restoreSkeletonState();

  std::unique_ptr<SkeletonModel> model_;
  std::unique_ptr<DynamicsFilter> filter_;
  bool started_ = false;
  // The skeleton's own state around a tick (positions, velocities, accelerations).
  Eigen::VectorXd saved_q_, saved_v_, saved_a_;
  Eigen::VectorXd tau_applied_;
  Eigen::VectorXd q_measured_, v_measured_;  // the state the tick started from
};

}  // namespace dynfilter::dart_backend
