#pragma once
/// @file
/// The reference leash (beyond the paper): instead of re-seeding an upright figure that
/// lags the reference's path or heading, the reference is moved towards the figure by a
/// rigid motion that keeps the ground where it is — a turn about the ground's normal and
/// a shift along the ground — just enough to bring the base's errors back within bounds.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/core/lie_group.hpp"  // moveBase, to apply the motion

namespace dynfilter {

/// The rigid motion X_WW' (world) that brings the reference's base within the leash of the
/// filter's base: first a turn about @p n_W (unit ground normal) through the reference's
/// base origin by the heading error beyond `max_heading_rad` (heading as in
/// tiltAndHeading), then a shift perpendicular to @p n_W by the base offset along the
/// ground beyond `max_offset_m`. Identity when both are within bounds or the leash is
/// disabled. A lean is never followed: a falling figure still meets the divergence guard's
/// orientation bound. @p q_filter and @p q_reference: floating-base configurations (nq ≥ 7, unit
/// quaternions). No allocation.
Eigen::Isometry3d leashMotion(const LeashOptions& options, const Eigen::Vector3d& n_W,
                              const Eigen::Ref<const Eigen::VectorXd>& q_filter,
                              const Eigen::Ref<const Eigen::VectorXd>& q_reference);

}  // namespace dynfilter
