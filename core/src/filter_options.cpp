#include "dynfilter/core/filter_options.hpp"

#include "dynfilter/core/filter_output.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace dynfilter {
namespace {
void require(bool ok, const char* name, const char* rule) {
  if (!ok) throw std::invalid_argument(std::string("filter option ") + name + " " + rule);
}
bool nonNegative(double x) { return std::isfinite(x) && x >= 0.0; }
bool positive(double x) { return std::isfinite(x) && x > 0.0; }
}  // namespace

void FilterOptions::validate() const {
  require(positive(dt_s) && dt_s <= 0.1, "dt_s", "must be in (0, 0.1] s");
  const JointFeedbackGains& f = feedback;
  for (double g : {f.base_linear_kp, f.base_linear_kd, f.base_angular_kp, f.base_angular_kd,
                   f.joint_kp, f.joint_kd})
    require(nonNegative(g), "feedback.*", "gains must be finite and >= 0");
  require(nonNegative(task.kp_linear) && nonNegative(task.kd_linear) &&
              nonNegative(task.kp_angular) && nonNegative(task.kd_angular),
          "task.k*", "gains must be finite and >= 0");
  require(positive(task.joint_weight), "task.joint_weight", "must be > 0");
  require(task.p_BP.allFinite(), "task.p_BP", "must be finite");
  require(contacts.max_links >= 1 && contacts.max_links <= 64, "contacts.max_links",
          "must be in [1, 64]");
  require(nonNegative(contacts.stabilization_kp) && nonNegative(contacts.stabilization_kd),
          "contacts.stabilization_k*", "must be finite and >= 0");
  require(positive(contacts.merge_distance_m), "contacts.merge_distance_m", "must be > 0");
  require(std::isfinite(contacts.release_force_n), "contacts.release_force_n", "must be finite");
  require(contacts.release_ticks >= 1, "contacts.release_ticks", "must be >= 1");
  require(nonNegative(contacts.reengage_depth_m), "contacts.reengage_depth_m", "must be >= 0");
  require(nonNegative(contacts.initial_penetration_tolerance_m),
          "contacts.initial_penetration_tolerance_m", "must be >= 0");
  require(positive(solver.accel_weight), "solver.accel_weight", "must be > 0");
  require(positive(solver.force_weight), "solver.force_weight", "must be > 0");
  require(positive(solver.sr_damping), "solver.sr_damping", "must be > 0");
  require(positive(divergence.max_base_error_m), "divergence.max_base_error_m", "must be > 0");
  require(positive(divergence.max_base_rotation_rad), "divergence.max_base_rotation_rad",
          "must be > 0");
  require(positive(divergence.max_joint_error_rad), "divergence.max_joint_error_rad", "must be > 0");
  require(positive(divergence.max_base_residual_rel), "divergence.max_base_residual_rel",
          "must be > 0");
  require(divergence.max_degraded_ticks >= 1, "divergence.max_degraded_ticks", "must be >= 1");
  require(positive(leash.max_offset_m), "leash.max_offset_m", "must be > 0");
  require(positive(leash.max_heading_rad), "leash.max_heading_rad", "must be > 0");
  require(mode == FilterMode::kPaper || mode == FilterMode::kQp, "mode", "must be paper or qp");
  require(positive(qp.accel_weight), "qp.accel_weight", "must be > 0");
  require(positive(qp.force_weight), "qp.force_weight", "must be > 0");
  require(nonNegative(qp.torque_weight), "qp.torque_weight", "must be >= 0");
  require(nonNegative(qp.min_normal_force_n), "qp.min_normal_force_n", "must be >= 0");
  require(qp.friction_facets >= 3 && qp.friction_facets <= 16, "qp.friction_facets",
          "must be in [3, 16]");
  require(nonNegative(qp.cop_margin_m), "qp.cop_margin_m", "must be >= 0");
  require(positive(qp.liftoff_clearance_m), "qp.liftoff_clearance_m", "must be > 0");
  require(nonNegative(qp.release_transition_s), "qp.release_transition_s", "must be >= 0");
  require(positive(qp.joint_limit_horizon_s) && qp.joint_limit_horizon_s >= dt_s,
          "qp.joint_limit_horizon_s", "must be >= dt_s");
  require(positive(qp.joint_limit_max_decel), "qp.joint_limit_max_decel", "must be > 0");
  require(positive(qp.solver.eps_abs), "qp.solver.eps_abs", "must be > 0");
  require(qp.solver.max_iterations >= 1, "qp.solver.max_iterations", "must be >= 1");
  require(nonNegative(balance.com_weight) && nonNegative(balance.dcm_gain) &&
              nonNegative(balance.height_kp) && nonNegative(balance.height_kd) &&
              nonNegative(balance.angular_momentum_damping) &&
              nonNegative(balance.angular_momentum_weight) && nonNegative(balance.sole_weight) &&
              nonNegative(balance.sole_kp) && nonNegative(balance.sole_kd),
          "balance.*", "weights and gains must be finite and >= 0");
  require(nonNegative(balance.preview_s), "balance.preview_s", "must be >= 0 s");
  require(balance.preview_capacity >= 2 && balance.preview_capacity <= 100000,
          "balance.preview_capacity", "must be in [2, 100000]");
  require(nonNegative(balance.sole_margin_m), "balance.sole_margin_m", "must be >= 0 m");
  require(nonNegative(balance.flat_landing_max_tilt_rad) && balance.flat_landing_max_tilt_rad < 1.5,
          "balance.flat_landing_max_tilt_rad", "must be in [0, 1.5) rad");
  require(nonNegative(balance.roll_tilt_rad) && balance.roll_tilt_rad < 1.0, "balance.roll_tilt_rad",
          "must be in [0, 1) rad");
  require(positive(balance.stance_height_m), "balance.stance_height_m", "must be > 0");
  require(positive(balance.stance_speed_mps), "balance.stance_speed_mps", "must be > 0");
  for (const SoleOptions& sole : balance.soles)
    require(!sole.body.empty() && sole.n_B.allFinite() && sole.n_B.norm() > 1e-9,
            "balance.soles", "each needs a body and a non-zero sole normal");
}

bool parseFilterMode(const std::string& text, FilterMode& mode) {
  if (text == "paper") {
    mode = FilterMode::kPaper;
    return true;
  }
  if (text == "qp") {
    mode = FilterMode::kQp;
    return true;
  }
  return false;
}

const char* toString(ReseedReason reason) {
  switch (reason) {
    case ReseedReason::kNone: return "";
    case ReseedReason::kNonFinite: return "non-finite solve";
    case ReseedReason::kBasePosition: return "base position error";
    case ReseedReason::kBaseRotation: return "base rotation error";
    case ReseedReason::kJoint: return "joint error";
    case ReseedReason::kResidual: return "Eq. 12 residual";
    case ReseedReason::kDegradedSolve: return "degraded solve";
  }
  return "unknown";
}

const char* toString(FilterMode mode) { return mode == FilterMode::kQp ? "qp" : "paper"; }

}  // namespace dynfilter
