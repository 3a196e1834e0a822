#include "dynfilter/urdf/rigid_mass.hpp"

namespace dynfilter::urdf {
namespace {

// m (|c|² 1 − c cᵀ): a point mass's inertia about the origin, c from the origin.
Eigen::Matrix3d pointInertia(double mass_kg, const Eigen::Vector3d& c) {
  return mass_kg * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
}

}  // namespace

void RigidMass::add(const InertialDesc& inertial, const Eigen::Isometry3d& X_FL) {
  if (!(inertial.mass_kg > 0.0)) return;
  const Eigen::Vector3d p_FCom = X_FL * inertial.p_LCom;
  const Eigen::Matrix3d R_FL = X_FL.linear();
  mass_kg += inertial.mass_kg;
  first_moment_F += inertial.mass_kg * p_FCom;
  I_Fo_F += R_FL * inertial.I_Com_L * R_FL.transpose() + pointInertia(inertial.mass_kg, p_FCom);
}

void RigidMass::add(const RigidMass& other) {
  mass_kg += other.mass_kg;
  first_moment_F += other.first_moment_F;
  I_Fo_F += other.I_Fo_F;
}

Eigen::Vector3d RigidMass::p_FCom() const {
  return mass_kg > 0.0 ? Eigen::Vector3d(first_moment_F / mass_kg) : Eigen::Vector3d::Zero();
}

Eigen::Matrix3d RigidMass::I_Com_F() const {
  if (!(mass_kg > 0.0)) return Eigen::Matrix3d::Zero();
  const Eigen::Matrix3d I = I_Fo_F - pointInertia(mass_kg, p_FCom());
  return 0.5 * (I + I.transpose());
}

}  // namespace dynfilter::urdf
