// urdf::RigidMass against closed forms: two point masses, a rotated box, sums in any order.
#include <gtest/gtest.h>

#include "dynfilter/urdf/rigid_mass.hpp"

namespace dynfilter::urdf {
namespace {

InertialDesc pointMass(double m, const Eigen::Vector3d& p_LCom) {
  InertialDesc in;
  in.present = true;
  in.mass_kg = m;
  in.p_LCom = p_LCom;
  return in;
}

TEST(RigidMass, TwoPointMassesGiveTheDumbbellsInertiaAboutItsCentre) {
  // 1 kg at x = 0 and 3 kg at x = 0.4 (the second via its link frame's offset): CoM at
  // x = 0.3; about it, I_yy = I_zz = 1·0.3² + 3·0.1² = 0.12 kg m², I_xx = 0.
  RigidMass sum;
  sum.add(pointMass(1.0, Eigen::Vector3d::Zero()), Eigen::Isometry3d::Identity());
  Eigen::Isometry3d X_FL = Eigen::Isometry3d::Identity();
  X_FL.translation() = Eigen::Vector3d(0.5, 0.0, 0.0);
  sum.add(pointMass(3.0, Eigen::Vector3d(-0.1, 0.0, 0.0)), X_FL);
  EXPECT_DOUBLE_EQ(sum.mass_kg, 4.0);
  EXPECT_NEAR((sum.p_FCom() - Eigen::Vector3d(0.3, 0.0, 0.0)).norm(), 0.0, 1e-15);
  const Eigen::Matrix3d expected = Eigen::Vector3d(0.0, 0.12, 0.12).asDiagonal();
  EXPECT_NEAR((sum.I_Com_F() - expected).norm(), 0.0, 1e-14);
}

TEST(RigidMass, ARotatedBoxKeepsItsPrincipalMomentsAndGainsTheParallelAxisTerm) {
  // A box's principal moments (1, 2, 3) in L, L turned 90° about z in F: F's xx and yy swap.
  InertialDesc box;
  box.mass_kg = 2.0;
  box.p_LCom = Eigen::Vector3d(0.0, 0.0, 0.25);
  box.I_Com_L = Eigen::Vector3d(1.0, 2.0, 3.0).asDiagonal();
  Eigen::Isometry3d X_FL = Eigen::Isometry3d::Identity();
  X_FL.linear() = Eigen::AngleAxisd(0.5 * M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  RigidMass sum;
  sum.add(box, X_FL);
  EXPECT_NEAR((sum.I_Com_F() - Eigen::Matrix3d(Eigen::Vector3d(2.0, 1.0, 3.0).asDiagonal())).norm(), 0.0, 1e-14);
  // About F's origin: + m d² on the axes perpendicular to d = (0, 0, 0.25).
  EXPECT_NEAR((sum.I_Fo_F - Eigen::Matrix3d(Eigen::Vector3d(2.125, 1.125, 3.0).asDiagonal())).norm(), 0.0, 1e-14);
}

TEST(RigidMass, SumsOfSumsEqualOneSumAndMasslessLinksAddNothing) {
  InertialDesc a = pointMass(0.7, Eigen::Vector3d(0.1, -0.2, 0.3));
  a.I_Com_L << 0.02, 0.001, 0.0, 0.001, 0.03, 0.002, 0.0, 0.002, 0.04;
  const InertialDesc b = pointMass(1.3, Eigen::Vector3d(-0.3, 0.05, 0.0));
  InertialDesc massless = pointMass(0.0, Eigen::Vector3d(5.0, 5.0, 5.0));
  massless.I_Com_L.setIdentity();
  Eigen::Isometry3d X_Fa = Eigen::Isometry3d::Identity(), X_Fb = Eigen::Isometry3d::Identity();
  X_Fa.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  X_Fb.translation() = Eigen::Vector3d(0.2, 0.4, -0.1);

  RigidMass together, left, right;
  together.add(a, X_Fa);
  together.add(b, X_Fb);
  left.add(a, X_Fa);
  left.add(massless, X_Fb);
  right.add(b, X_Fb);
  left.add(right);
  EXPECT_DOUBLE_EQ(left.mass_kg, together.mass_kg);
  EXPECT_NEAR((left.p_FCom() - together.p_FCom()).norm(), 0.0, 1e-15);
  EXPECT_NEAR((left.I_Com_F() - together.I_Com_F()).norm(), 0.0, 1e-15);
  EXPECT_NEAR((together.I_Com_F() - together.I_Com_F().transpose()).norm(), 0.0, 0.0);

  RigidMass none;
  none.add(massless, X_Fa);
  EXPECT_EQ(none.mass_kg, 0.0);
  EXPECT_TRUE(none.p_FCom().isZero(0.0));
  EXPECT_TRUE(none.I_Com_F().isZero(0.0));
}

}  // namespace
}  // namespace dynfilter::urdf
