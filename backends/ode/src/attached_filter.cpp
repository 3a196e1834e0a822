#include "dynfilter/ode/attached_filter.hpp"

#include <algorithm>
#include <stdexcept>
#include <utility>

namespace dynfilter::ode_backend {

AttachedFilter::AttachedFilter(const OdeRobotRefs& robot, const FilterOptions& options,
                               const QpSolverFactory& qp_solver)
    : AttachedFilter(attachOdeModel(robot), options, qp_solver) {}

AttachedFilter::AttachedFilter(std::unique_ptr<OdeBodyModel> model, const FilterOptions& options,
                               const QpSolverFactory& qp_solver)
    : model_(model != nullptr ? std::move(model)
                              : throw std::invalid_argument("AttachedFilter: null model")),
      filter_(std::make_unique<DynamicsFilter>(*model_, options, qp_solver)),
      saved_(model_->bodies().size()),
      tau_applied_(Eigen::VectorXd::Zero(model_->nj())),
      q_measured_(model_->q()),
      v_measured_(model_->v()) {}

const FilterOutput& AttachedFilter::step(const ReferenceFrame& reference) {
  const auto& bodies = model_->bodies();
  for (std::size_t k = 0; k < bodies.size(); ++k) {
    BodyState& s = saved_[k];
    std::copy_n(dBodyGetPosition(bodies[k]), 3, s.p.begin());
    std::copy_n(dBodyGetQuaternion(bodies[k]), 4, s.quat.begin());
    std::copy_n(dBodyGetLinearVel(bodies[k]), 3, s.v.begin());
    std::copy_n(dBodyGetAngularVel(bodies[k]), 3, s.w.begin());
  }
  bool measured = model_->readBodyState(q_measured_, v_measured_);
  if (measured)
    measured = stepOnMeasuredState(*filter_, model_->info(), started_, q_measured_, v_measured_,
                                   reference, tau_applied_);
  else
    tau_applied_.setZero();
  // A ball joint's torque mapping depends on θ: the model back at the measured state.
  if (measured) model_->setState(q_measured_, v_measured_);
  for (std::size_t k = 0; k < bodies.size(); ++k) {
    const BodyState& s = saved_[k];
    dBodySetPosition(bodies[k], s.p[0], s.p[1], s.p[2]);
    dBodySetQuaternion(bodies[k], s.quat.data());
    dBodySetLinearVel(bodies[k], s.v[0], s.v[1], s.v[2]);
    dBodySetAngularVel(bodies[k], s.w[0], s.w[1], s.w[2]);
  }
  model_->addJointTorques(tau_applied_);
  return filter_->output();
}

void AttachedFilter::placeAt(const ReferenceFrame& reference) {
  filter_->reset(reference);
  model_->setState(filter_->q(), filter_->v());
  started_ = true;
}

}  // namespace dynfilter::ode_backend
