#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <unsupported/Eigen/MatrixFunctions>

#include "dynfilter/core/lie_group.hpp"

namespace dynfilter {
namespace {

Vector6d randomTwist(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  Vector6d t;
  for (int i = 0; i < 6; ++i) t[i] = u(rng);
  return t;
}

TEST(LieGroup, ExpSO3MatchesAngleAxisAndIsARotation) {
  const Eigen::Vector3d omega(0.3, -1.1, 0.7);
  const Eigen::Matrix3d R = expSO3(omega);
  const Eigen::Matrix3d expected =
      Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
  EXPECT_LT((R - expected).norm(), 1e-14);
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
}

TEST(LieGroup, LogSO3InvertsExpIncludingSmallAndNearPiAngles) {
  for (double angle : {0.0, 1e-9, 1e-5, 0.3, 2.0, M_PI - 1e-6}) {
    const Eigen::Vector3d omega = angle * Eigen::Vector3d(0.2, -0.5, 0.84).normalized();
    EXPECT_LT((logSO3(expSO3(omega)) - omega).norm(), 1e-9) << "angle " << angle;
  }
}

TEST(LieGroup, ExpSE3OfPureTranslationAndPureRotation) {
  Vector6d t = Vector6d::Zero();
  t.head<3>() = Eigen::Vector3d(1.0, 2.0, 3.0);
  EXPECT_LT((expSE3(t).translation() - Eigen::Vector3d(1, 2, 3)).norm(), 1e-15);
  // A rotation of π/2 about z with linear velocity x traces a quarter circle of radius 2/π.
  t.setZero();
  t[0] = 1.0;
  t[5] = M_PI / 2;
  const Eigen::Isometry3d X = expSE3(t);
  EXPECT_LT((X.translation() - Eigen::Vector3d(2 / M_PI, 2 / M_PI, 0)).norm(), 1e-14);
}

TEST(LieGroup, LogSE3InvertsExpSE3OnRandomTwists) {
  std::mt19937 rng(7);
  for (int i = 0; i < 200; ++i) {
    const Vector6d t = randomTwist(rng, i < 100 ? 1.0 : 1e-5);
    EXPECT_LT((logSE3(expSE3(t)) - t).norm(), 1e-12) << t.transpose();
  }
}

TEST(LieGroup, ExpSE3MatchesTheMatrixExponentialOnBothSidesOfTheSeriesSwitch) {
  // Reference: the 4x4 matrix exponential of the twist, exp([[ω]×, v; 0, 0]).
  Vector6d t;
  t << 0.4, -0.2, 0.9, 0.0, 0.0, 0.0;
  for (double angle : {0.0, 1e-7, 0.99e-2, 1.01e-2, 0.5, 3.0}) {
    t.tail<3>() = angle * Eigen::Vector3d(1, 2, 2) / 3.0;
    Eigen::Matrix4d hat = Eigen::Matrix4d::Zero();
    hat.topLeftCorner<3, 3>() = skew(t.tail<3>());
    hat.topRightCorner<3, 1>() = t.head<3>();
    const Eigen::Matrix4d reference = hat.exp();
    EXPECT_LT((expSE3(t).matrix() - reference).norm(), 1e-14) << "angle " << angle;
  }
}

TEST(LieGroup, IntegrateThenDifferenceRoundTripsFloatingBase) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int nj = 5;
  for (int trial = 0; trial < 100; ++trial) {
    Eigen::VectorXd q(7 + nj), v(6 + nj), q1(7 + nj), dv(6 + nj);
    q.head<3>() << u(rng), u(rng), u(rng);
    q.segment<4>(3) = Eigen::Vector4d(u(rng), u(rng), u(rng), u(rng)).normalized();
    for (int j = 0; j < nj; ++j) q[7 + j] = u(rng);
    for (int i = 0; i < 6 + nj; ++i) v[i] = 2.0 * u(rng);
    integrateConfiguration(true, q, v, 0.7, q1);
    EXPECT_NEAR(q1.segment<4>(3).norm(), 1.0, 1e-14);
    differenceConfiguration(true, q, q1, dv);
    EXPECT_LT((dv - 0.7 * v).norm(), 1e-11);
  }
}

TEST(LieGroup, IntegrateMayAliasItsInput) {
  Eigen::VectorXd q(8), v(7), expected(8);
  q << 0.1, 0.2, 0.3, 1, 0, 0, 0, 0.5;
  v << 1, 0, 0, 0, 0, 1, 2;
  integrateConfiguration(true, q, v, 0.1, expected);
  integrateConfiguration(true, q, v, 0.1, q);
  EXPECT_LT((q - expected).norm(), 1e-15);
}

TEST(LieGroup, BaseVelocityIsExpressedInTheBaseFrame) {
  // Base yawed by 90°: a body-frame forward velocity moves the base along world +y.
  Eigen::VectorXd q(7), v = Eigen::VectorXd::Zero(6), q1(7);
  const Eigen::Quaterniond yaw(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  q << 0, 0, 0, yaw.w(), yaw.x(), yaw.y(), yaw.z();
  v[0] = 1.0;
  integrateConfiguration(true, q, v, 0.01, q1);
  EXPECT_LT((q1.head<3>() - Eigen::Vector3d(0, 0.01, 0)).norm(), 1e-15);
}

TEST(LieGroup, IntegrateMatchesFiniteStepsOfTheKinematicODE) {
  // d/dt p = R v_B, d/dt R = R [ω_B]: many tiny Euler steps converge to the exact exp.
  Eigen::VectorXd q(7), v(6), q_exact(7);
  q << 0.3, -0.1, 0.8, 0.9, 0.1, -0.3, 0.2;
  q.segment<4>(3).normalize();
  v << 0.5, -0.4, 0.2, 1.2, -0.7, 0.9;
  integrateConfiguration(true, q, v, 1.0, q_exact);
  Eigen::Isometry3d X = basePoseFromConfiguration(q);
  const int n = 100000;
  for (int k = 0; k < n; ++k) {
    X.translation() += X.linear() * v.head<3>() / n;
    X.linear() = X.linear() * expSO3(v.tail<3>() / n);
  }
  EXPECT_LT((X.translation() - q_exact.head<3>()).norm(), 1e-4);
  EXPECT_LT((X.linear() - basePoseFromConfiguration(q_exact).linear()).norm(), 1e-9);
}

TEST(LieGroup, FixedBaseIsVectorSpace) {
  Eigen::VectorXd q(3), v(3), q1(3), dv(3);
  q << 1, 2, 3;
  v << 0.5, -1, 2;
  integrateConfiguration(false, q, v, 0.2, q1);
  EXPECT_LT((q1 - (q + 0.2 * v)).norm(), 1e-15);
  differenceConfiguration(false, q, q1, dv);
  EXPECT_LT((dv - 0.2 * v).norm(), 1e-15);
}

TEST(LieGroup, TiltAndHeadingSplitATurnAboutVerticalFromALean) {
  const auto Rz = [](double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix(); };
  const auto Rx = [](double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix(); };
  const auto Ry = [](double a) { return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitY()).toRotationMatrix(); };
  const Eigen::Matrix3d A = Rz(0.4);
  // A turn about world z: no tilt, the whole angle is heading (wrapped into (−π, π]).
  for (const double turn : {0.0, 0.7, -1.3, 3.0}) {
    const TiltHeading d = tiltAndHeading(A, Rz(turn) * A);
    EXPECT_NEAR(d.tilt_rad, 0.0, 1e-7) << turn;
    EXPECT_NEAR(d.heading_rad, turn, 1e-12) << turn;
  }
  EXPECT_NEAR(tiltAndHeading(A, Rz(M_PI + 0.2) * A).heading_rad, -M_PI + 0.2, 1e-12);
  EXPECT_NEAR(tiltAndHeading(Rz(0.1), Rz(0.1 + M_PI)).heading_rad, M_PI, 1e-12);
  // A lean about the body's own x or y axis: tilt = the lean, heading 0.
  for (const double lean : {0.2, 0.7, -0.6}) {
    const TiltHeading dx = tiltAndHeading(A, A * Rx(lean));
    const TiltHeading dy = tiltAndHeading(A, A * Ry(lean));
    EXPECT_NEAR(dx.tilt_rad, std::abs(lean), 1e-12) << lean;
    EXPECT_NEAR(dx.heading_rad, 0.0, 1e-12) << lean;
    EXPECT_NEAR(dy.tilt_rad, std::abs(lean), 1e-12) << lean;
    EXPECT_NEAR(dy.heading_rad, 0.0, 1e-12) << lean;
  }
  // A lean after a turn keeps both parts; tilt never exceeds the rotation's angle.
  const TiltHeading both = tiltAndHeading(A, Rz(0.8) * A * Ry(0.5));
  EXPECT_NEAR(both.tilt_rad, 0.5, 1e-12);
  EXPECT_NEAR(both.heading_rad, 0.8, 1e-12);
  std::mt19937 rng(7);
  for (int k = 0; k < 200; ++k) {
    const Eigen::Matrix3d B = expSO3(randomTwist(rng, 1.5).tail<3>());
    const Eigen::Matrix3d C = expSO3(randomTwist(rng, 1.5).tail<3>()) * B;
    EXPECT_LE(tiltAndHeading(B, C).tilt_rad, logSO3(B.transpose() * C).norm() + 1e-12);
  }
  // A base whose x axis points straight down: its heading is read from its y axis.
  const Eigen::Matrix3d down = Ry(M_PI / 2);  // x to −z, y stays +y
  EXPECT_NEAR(tiltAndHeading(Eigen::Matrix3d::Identity(), down).heading_rad, 0.0, 1e-12);
  EXPECT_NEAR(tiltAndHeading(Rz(0.3), Rz(0.3) * down).heading_rad, 0.0, 1e-12);
}

}  // namespace
}  // namespace dynfilter

#include "dynfilter/core/reference_frame.hpp"

namespace dynfilter {
namespace {

TEST(ReferenceInterpolation, MidpointOfABaseScrewAndLinearJoints) {
  ReferenceFrame a(8, 7), b(8, 7), out(8, 7);
  a.time_s = 1.0;
  b.time_s = 1.5;
  a.q << 0, 0, 1, 1, 0, 0, 0, 0.2;
  // b: a quarter turn about z with a translation along x.
  const Eigen::Quaterniond yaw(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  b.q << 1, 0, 1, yaw.w(), yaw.x(), yaw.y(), yaw.z(), 0.6;
  a.v.setConstant(1.0);
  b.v.setConstant(3.0);
  interpolateReference(true, a, b, 1.25, out);
  EXPECT_DOUBLE_EQ(out.time_s, 1.25);
  EXPECT_NEAR(out.q[7], 0.4, 1e-15);
  EXPECT_NEAR(out.v[2], 2.0, 1e-15);
  // Half the rotation (45°), and the midpoint of the screw motion.
  const Eigen::Isometry3d X = basePoseFromConfiguration(out.q);
  EXPECT_NEAR(Eigen::AngleAxisd(X.linear()).angle(), M_PI / 4, 1e-12);
  const Eigen::Isometry3d X_a = basePoseFromConfiguration(a.q);
  const Eigen::Isometry3d expected =
      X_a * expSE3(0.5 * logSE3(X_a.inverse() * basePoseFromConfiguration(b.q)));
  EXPECT_LT((X.matrix() - expected.matrix()).norm(), 1e-12);
  EXPECT_GT(std::abs(X.translation().y()), 0.1);  // a screw, not a straight line
  // Clamped outside [a, b].
  interpolateReference(true, a, b, 9.0, out);
  EXPECT_LT((out.q - b.q).norm(), 1e-12);
}

}  // namespace
}  // namespace dynfilter
