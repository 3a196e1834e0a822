// The reference leash's rigid motion (core/reference_leash.hpp) on closed forms: the
// reference ends exactly at the bounds, the ground is kept, nothing moves within bounds.
#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/reference_leash.hpp"

namespace dynfilter {
namespace {

// A floating-base configuration with two joints: base at p, turned by yaw about z then
// pitched by pitch about its own y.
Eigen::VectorXd configuration(const Eigen::Vector3d& p, double yaw, double pitch = 0.0) {
  Eigen::VectorXd q(9);
  const Eigen::Quaterniond r(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()));
  q << p, r.w(), r.x(), r.y(), r.z(), 0.3, -0.7;
  return q;
}

Eigen::Matrix3d rotationOf(const Eigen::VectorXd& q) {
  return Eigen::Quaterniond(q[3], q[4], q[5], q[6]).toRotationMatrix();
}

LeashOptions enabled() {
  LeashOptions options;
  options.enabled = true;
  return options;
}

TEST(ReferenceLeash, DisabledOrWithinBoundsMovesNothing) {
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  const Eigen::VectorXd filter = configuration({0.0, 0.0, 0.9}, 0.2);
  EXPECT_TRUE(leashMotion(LeashOptions{}, z, filter, configuration({2.0, 0.0, 0.9}, 2.0)).isApprox(
      Eigen::Isometry3d::Identity(), 0.0));
  // 9 cm along the ground (and 30 cm up, which the leash never follows), 0.16 rad of heading.
  const Eigen::Isometry3d X = leashMotion(enabled(), z, filter, configuration({0.09, 0.0, 1.2}, 0.36));
  EXPECT_TRUE(X.isApprox(Eigen::Isometry3d::Identity(), 0.0));
}

TEST(ReferenceLeash, AnOffsetAlongTheGroundShrinksToItsBound) {
  const Eigen::VectorXd filter = configuration({0.0, 0.0, 0.9}, 0.0);
  Eigen::VectorXd reference = configuration({0.3, 0.4, 1.2}, 0.0);
  const Eigen::Isometry3d X = leashMotion(enabled(), Eigen::Vector3d::UnitZ(), filter, reference);
  // 0.5 m along the ground → 0.1 m: a shift by −0.4 m along the offset, none up, no turn.
  EXPECT_TRUE(X.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-15));
  EXPECT_LT((X.translation() - Eigen::Vector3d(-0.24, -0.32, 0.0)).norm(), 1e-15);
  moveBase(X, reference);
  EXPECT_LT((reference.head<3>() - Eigen::Vector3d(0.06, 0.08, 1.2)).norm(), 1e-15);
  EXPECT_EQ(reference.tail(2), Eigen::Vector2d(0.3, -0.7)) << "joints are not moved";
}

TEST(ReferenceLeash, AHeadingLagShrinksToItsBoundAboutTheReferencesBase) {
  const Eigen::VectorXd filter = configuration({1.0, 2.0, 0.9}, 0.4);
  Eigen::VectorXd reference = configuration({1.05, 2.0, 0.95}, 0.4 + 0.9, 0.2);
  const Eigen::Isometry3d X = leashMotion(enabled(), Eigen::Vector3d::UnitZ(), filter, reference);
  const Eigen::Vector3d p_before = reference.head<3>();
  moveBase(X, reference);
  EXPECT_LT((reference.head<3>() - p_before).norm(), 1e-15) << "the turn is about the reference's base";
  const TiltHeading after = tiltAndHeading(rotationOf(filter), rotationOf(reference));
  EXPECT_NEAR(after.heading_rad, 0.17, 1e-12);
  EXPECT_NEAR(after.tilt_rad, 0.2, 1e-12) << "a lean is not followed";
  // The other way round.
  Eigen::VectorXd behind = configuration({1.0, 2.0, 0.9}, 0.4 - 1.3);
  moveBase(leashMotion(enabled(), Eigen::Vector3d::UnitZ(), filter, behind), behind);
  EXPECT_NEAR(tiltAndHeading(rotationOf(filter), rotationOf(behind)).heading_rad, -0.17, 1e-12);
}

TEST(ReferenceLeash, OnASlopeTheMotionKeepsTheGroundAndBothBoundsHold) {
  const Eigen::Vector3d n = Eigen::Vector3d(std::sin(0.17), 0.05, std::cos(0.17)).normalized();
  const Eigen::VectorXd filter = configuration({0.2, -0.1, 0.9}, -0.3);
  Eigen::VectorXd reference = configuration({1.0, 0.5, 0.7}, 0.8);
  LeashOptions options = enabled();
  options.max_offset_m = 0.15;
  options.max_heading_rad = 0.25;
  const Eigen::Isometry3d X = leashMotion(options, n, filter, reference);
  EXPECT_LT((X.linear() * n - n).norm(), 1e-14) << "turns about the ground's normal";
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(3.0, -1.0, 2.0),
                                  Eigen::Vector3d(-2.0, 4.0, -0.5)})
    EXPECT_NEAR(n.dot(X * p), n.dot(p), 1e-13) << "every point keeps its height above the ground";
  moveBase(X, reference);
  Eigen::Vector3d offset = reference.head<3>() - filter.head<3>();
  offset -= n * n.dot(offset);
  EXPECT_NEAR(offset.norm(), 0.15, 1e-12);
  // The heading is measured about world z; the turn about the tilted normal leaves a
  // remainder of second order in the slope.
  EXPECT_NEAR(std::abs(tiltAndHeading(rotationOf(filter), rotationOf(reference)).heading_rad), 0.25, 0.02);
}

}  // namespace
}  // namespace dynfilter
