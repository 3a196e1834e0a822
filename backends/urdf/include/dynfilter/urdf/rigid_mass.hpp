#pragma once
/// @file
/// Mass properties of rigidly attached links, summed in one frame F: what a backend gives
/// a body that lumps links welded by fixed joints, and what the loader's checks sum over
/// subtrees.

#include <Eigen/Geometry>

#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter::urdf {

/// Σ of link inertials expressed in a common frame F. Links with mass ≤ 0 add nothing.
struct RigidMass {
  double mass_kg = 0.0;
  Eigen::Vector3d first_moment_F = Eigen::Vector3d::Zero();  ///< Σ m p_FCom (kg m)
  Eigen::Matrix3d I_Fo_F = Eigen::Matrix3d::Zero();          ///< about F's origin, F axes (kg m²)

  /// Adds a link whose frame L has the pose @p X_FL in F.
  void add(const InertialDesc& inertial, const Eigen::Isometry3d& X_FL);
  /// Adds another sum taken in the same frame F.
  void add(const RigidMass& other);

  /// Centre of mass in F (m); zero when massless.
  Eigen::Vector3d p_FCom() const;
  /// Rotational inertia about the centre of mass, F axes, symmetric (kg m²); zero when massless.
  Eigen::Matrix3d I_Com_F() const;
};

}  // namespace dynfilter::urdf
