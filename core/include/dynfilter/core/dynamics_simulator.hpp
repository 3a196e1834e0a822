#pragma once
/// @file
/// The simulator mode (Eq. 14): the filter's machinery with the torques given. Contacts
/// are the same virtual links (collision, Baumgarte stabilisation, plastic impact,
/// release on pulling force); the integrator is the filter's semi-implicit Euler.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "dynfilter/core/constrained_dynamics.hpp"
#include "dynfilter/core/contact.hpp"
#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/core/filter_output.hpp"
#include "dynfilter/core/virtual_links.hpp"

namespace dynfilter {

class DynamicsSimulator {
 public:
  /// Uses @p model (which must outlive the simulator); contact options as in the filter.
  DynamicsSimulator(IDynamicsModel& model, const ContactOptions& contacts, double dt_s);

  /// Sets the state and forgets the contacts. Throws InvalidStateError on a bad state.
  void reset(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v);

  /// One step with joint torques @p tau_J held over dt. Returns status bits. The
  /// acceleration and contact forces of the step are available afterwards; q(), v() are
  /// the state after it. No heap allocation.
  std::uint32_t step(const Eigen::Ref<const Eigen::VectorXd>& tau_J);

  const Eigen::VectorXd& q() const { return q_; }
  const Eigen::VectorXd& v() const { return v_; }
  /// The state at which the last step's Eq. 14 was solved (after any impact), and v̇.
  const Eigen::VectorXd& stepStartQ() const { return q_start_; }
  const Eigen::VectorXd& stepStartV() const { return v_start_; }
  const Eigen::VectorXd& vdot() const { return vdot_; }
  const VirtualLinkSet& links() const { return links_; }
  int numContactRows() const { return num_rows_; }
  /// Constraint forces τ_C of the last step (first numContactRows() entries).
  const Eigen::VectorXd& contactForces() const { return tau_C_; }
  /// Per-link wrenches of the last step (first numContacts() entries).
  const std::vector<ContactOutput>& contacts() const { return contacts_; }
  int numContacts() const { return num_contacts_; }

 private:
  IDynamicsModel& model_;
  double dt_s_;
  bool floating_;
  double release_force_n_;
  VirtualLinkSet links_;
  ContactList candidates_;
  ConstrainedDynamics constrained_;
  Eigen::VectorXd q_, v_, q_start_, v_start_, vdot_, b_, u_C_, tau_C_;
  Eigen::MatrixXd A_, H_C_;
  std::vector<ContactOutput> contacts_;
  int num_rows_ = 0;
  int num_contacts_ = 0;
};

}  // namespace dynfilter
