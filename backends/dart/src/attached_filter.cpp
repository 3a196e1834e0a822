#include "dynfilter/dart/attached_filter.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace dynfilter::dart_backend {

AttachedFilter::AttachedFilter(const dart::dynamics::SkeletonPtr& skeleton,
                               const dart::simulation::WorldPtr& world,
                               const FilterOptions& options, const QpSolverFactory& qp_solver,
                               const AttachOptions& attach)
    : AttachedFilter(attachDartModel(skeleton, world, attach), options, qp_solver) {}

AttachedFilter::AttachedFilter(std::unique_ptr<SkeletonModel> model, const FilterOptions& options,
                               const QpSolverFactory& qp_solver)
    : model_(std::move(model)) {
  if (model_ == nullptr) throw std::invalid_argument("AttachedFilter: null model");
  const auto& world = model_->world();
  if (std::abs(world->getTimeStep() - options.dt_s) > 1e-12 * options.dt_s)
    throw std::invalid_argument("AttachedFilter: the world's time step (" +
                                std::to_string(world->getTimeStep()) +
                                " s) differs from the filter's dt_s (" +
                                std::to_string(options.dt_s) + " s)");
  filter_ = std::make_unique<DynamicsFilter>(*model_, options, qp_solver);
  const auto n = static_cast<Eigen::Index>(model_->skeleton()->getNumDofs());
  saved_q_.resize(n);
  saved_v_.resize(n);
  saved_a_.resize(n);
  tau_applied_ = Eigen::VectorXd::Zero(model_->nj());
  q_measured_ = model_->q();
  v_measured_ = model_->v();
}

void AttachedFilter::saveSkeletonState() {
  const auto& skeleton = *model_->skeleton();
  for (Eigen::Index i = 0; i < saved_q_.size(); ++i) {
    const auto dof = static_cast<std::size_t>(i);
    saved_q_[i] = skeleton.getPosition(dof);
    saved_v_[i] = skeleton.getVelocity(dof);
    saved_a_[i] = skeleton.getAcceleration(dof);
  }
}

void AttachedFilter::restoreSkeletonState() {
  auto& skeleton = *model_->skeleton();
  skeleton.setPositions(saved_q_);
  skeleton.setVelocities(saved_v_);
  for (Eigen::Index i = 0; i < saved_a_.size(); ++i)  // setAccelerations allocates
    skeleton.setAcceleration(static_cast<std::size_t>(i), saved_a_[i]);
}

const FilterOutput& AttachedFilter::step(const ReferenceFrame& reference) {
  saveSkeletonState();
  bool measured = model_->readSkeletonState(q_measured_, v_measured_);
  if (measured)
    measured = stepOnMeasuredState(*filter_, model_->info(), started_, q_measured_, v_measured_,
                                   reference, tau_applied_);
  else
    tau_applied_.setZero();
  // A ball joint's torque mapping depends on θ: the model back at the measured state.
  if (measured) model_->setState(q_measured_, v_measured_);
  restoreSkeletonState();
  model_->setSkeletonForces(tau_applied_);
  return filter_->output();
}

void AttachedFilter::placeAt(const ReferenceFrame& reference) {
  filter_->reset(reference);
  model_->setState(filter_->q(), filter_->v());
  started_ = true;
}

}  // namespace dynfilter::dart_backend
