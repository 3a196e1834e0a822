#pragma once
/// @file
/// Eigen aliases shared by all of dynfilter. Spatial 6-vectors are ordered
/// [linear; angular] everywhere (twists, accelerations, wrenches, Jacobian rows).

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace dynfilter {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix6Xd = Eigen::Matrix<double, 6, Eigen::Dynamic>;

/// Standard gravity, the magnitude the models use when nothing else is configured (m/s²).
inline constexpr double kStandardGravity = 9.81;
/// Gravity in the world frame used when nothing else is configured (m/s²).
inline const Eigen::Vector3d kStandardGravity_W{0.0, 0.0, -kStandardGravity};

}  // namespace dynfilter
