#pragma once
// Joint axes read from a model's own kinematics, and whether several of them meet: how the
// retargeting finds a limb's pivot (a hip's or shoulder's axes meet there) without names.
#include <vector>

#include <Eigen/Core>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/kinematic_tree.hpp"

namespace dynfilter::io::detail {

/// Axes closer than this to their common point meet (m).
inline constexpr double kAxesMeet_m = 0.02;

/// A joint's axis (world): direction (unit) and a point on it.
struct AxisLine {
  Eigen::Vector3d u, a;
};

/// The axis of revolute joint @p j at configuration @p q, read from the motion of its child
/// body under a small turn (false for a prismatic joint). Leaves the model at @p q.
bool jointAxis(IDynamicsModel& model, const KinematicTree& tree, int j, const Eigen::VectorXd& q,
               AxisLine& line);
/// Distance of @p p_W from the line (m).
double distanceToLine(const AxisLine& line, const Eigen::Vector3d& p_W);
/// Whether @p lines (one or more) meet: their least-squares point lies within kAxesMeet_m
/// of each (two or more lines, not all parallel). @p point_W: that point (a point of a
/// single line).
bool axesMeet(const std::vector<AxisLine>& lines, Eigen::Vector3d& point_W);

}  // namespace dynfilter::io::detail
