#pragma once
/// @file
/// Eq. 12 re-evaluated on a filtered motion by any model (the cross-check: a motion
/// filtered with one backend, checked with the other).

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/io/filtered_motion_reader.hpp"

namespace dynfilter::io {

/// Per frame, r = A v̇ + b − Σ_c J_cᵀ w_c − [0; τ_J] at the frame's (q, v), J_c the
/// world-aligned Jacobian of the contact point p_WC on its body.
struct FilteredMotionResiduals {
  Eigen::VectorXd base_n;   ///< dim frames: max |r| over the six base rows (N, N m); 0 fixed base
  Eigen::VectorXd all;      ///< dim frames: max |r| over all rows
  double worst_base_n = 0.0;
  std::size_t worst_base_frame = 0;  ///< frame of worst_base_n
  double worst_all = 0.0;
  double body_weight_n = 0.0;  ///< total mass × 9.81 (N)
};

/// Evaluates every frame of @p frames on @p model (whose state it changes).
/// @throws std::invalid_argument on a frame whose sizes or contact bodies do not fit the model.
FilteredMotionResiduals evaluateFilteredMotion(IDynamicsModel& model,
                                               const std::vector<FilteredFrame>& frames);

}  // namespace dynfilter::io
