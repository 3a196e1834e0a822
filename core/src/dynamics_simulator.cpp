#include "dynfilter/core/dynamics_simulator.hpp"

#include "dynfilter/core/filter_output.hpp"
#include "dynfilter/core/lie_group.hpp"

namespace dynfilter {

DynamicsSimulator::DynamicsSimulator(IDynamicsModel& model, const ContactOptions& contacts,
                                     double dt_s)
    : model_(model),
      dt_s_(dt_s),
      floating_(model.info().floating_base),
      release_force_n_(contacts.release_force_n),
      links_(contacts, model.nv()),
      candidates_(64),
      constrained_(model.nv(), floating_ ? kFloatingBaseNv : 0, 6 * contacts.max_links),
      contacts_(static_cast<std::size_t>(contacts.max_links)) {
  const int nv = model.nv(), rows = 6 * contacts.max_links;
  q_ = model.info().neutralConfiguration();
  q_start_ = q_;
  v_.setZero(nv);
  v_start_.setZero(nv);
  vdot_.setZero(nv);
  b_.setZero(nv);
  u_C_.setZero(rows);
  tau_C_.setZero(rows);
  A_.setZero(nv, nv);
  H_C_.setZero(rows, nv);
}

void DynamicsSimulator::reset(const Eigen::Ref<const Eigen::VectorXd>& q,
                              const Eigen::Ref<const Eigen::VectorXd>& v) {
  model_.info().requireValidState(q, v);
  q_ = q;
  v_ = v;
  links_.clear();
}

std::uint32_t DynamicsSimulator::step(const Eigen::Ref<const Eigen::VectorXd>& tau_J) {
  std::uint32_t status = kStatusOk;
  model_.setState(q_, v_);
  model_.detectContacts(candidates_);
  const int created = links_.update(model_, candidates_, status);
  num_rows_ = links_.numRows();
  auto H_C = H_C_.topRows(num_rows_);
  auto u_C = u_C_.head(num_rows_);
  auto tau_C = tau_C_.head(num_rows_);
  model_.massMatrix(A_);
  if (created > 0 && num_rows_ > 0) {
    links_.assemble(model_, H_C, u_C);
    if (constrained_.plasticImpact(A_, H_C, v_, tau_C)) {
      model_.setState(q_, v_);
      status |= kStatusImpact;
    }
  }
  model_.bias(b_);
  links_.assemble(model_, H_C, u_C);
  if (!constrained_.forward(A_, b_, H_C, u_C, tau_J, vdot_, tau_C)) status |= kStatusRankDeficient;
  q_start_ = q_;
  v_start_ = v_;
  v_.noalias() += dt_s_ * vdot_;
  integrateConfiguration(floating_, q_, v_, dt_s_, q_);
  num_contacts_ = links_.finishTick(model_, tau_C, contacts_, true, release_force_n_,
                                    dt_s_, 0.0);
  return status;
}

}  // namespace dynfilter
