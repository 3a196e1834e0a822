// Hull-against-ground contacts from the hull's vertices (core/ground_contacts.hpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/core/ground_contacts.hpp"
#include "dynfilter/core/lie_group.hpp"

namespace dynfilter {
namespace {

// The 8 corners of a box of full edge lengths @p size centred at the origin.
Eigen::Matrix3Xd boxCorners(const Eigen::Vector3d& size) {
  Eigen::Matrix3Xd p(3, 8);
  for (int i = 0; i < 8; ++i)
    p.col(i) = 0.5 * size.cwiseProduct(Eigen::Vector3d(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1));
  return p;
}

// An elliptic prism (semi-axes a, b, height h) with @p n vertices per ring.
Eigen::Matrix3Xd ellipticPrism(double a, double b, double h, int n) {
  Eigen::Matrix3Xd p(3, 2 * n);
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * M_PI * i / n;
    p.col(i) << a * std::cos(t), b * std::sin(t), -0.5 * h;
    p.col(n + i) << a * std::cos(t), b * std::sin(t), 0.5 * h;
  }
  return p;
}

Eigen::Isometry3d pose(const Eigen::Vector3d& p, const Eigen::Vector3d& rotation_vector) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = expSO3(rotation_vector);
  X.translation() = p;
  return X;
}

TEST(HullContacts, ABoxLyingOneMillimetreDeepTouchesAtItsFourBottomCorners) {
  const BodyHull hull = BodyHull::make(3, pose({0.01, 0, 0.02}, {0, 0, 0.3}), boxCorners({0.2, 0.1, 0.04}));
  // Body at z such that the hull's bottom face is 1 mm below z = 0.
  const Eigen::Isometry3d X_WB = pose({0.5, -0.2, -0.02 + 0.02 - 0.001}, {0, 0, 0.7});
  ContactList out;
  ASSERT_EQ(appendHullGroundContacts(hull, X_WB, GroundPlane{}, out), 4);
  for (const ContactCandidate& c : out) {
    EXPECT_EQ(c.body, 3);
    EXPECT_EQ(c.object, kGroundObject);
    EXPECT_NEAR(c.depth_m, 1e-3, 1e-12);
    EXPECT_NEAR(c.p_WC.z(), -1e-3, 1e-12);
    EXPECT_LT((c.n_W - Eigen::Vector3d::UnitZ()).norm(), 1e-15);
    EXPECT_LT((X_WB * c.p_BC - c.p_WC).norm(), 1e-12);
    const Eigen::Vector3d p_S = hull.X_BS.inverse() * c.p_BC;  // a bottom corner
    EXPECT_NEAR(std::abs(p_S.x()), 0.1, 1e-12);
    EXPECT_NEAR(std::abs(p_S.y()), 0.05, 1e-12);
    EXPECT_NEAR(p_S.z(), -0.02, 1e-12);
  }
  // Four different corners.
  for (std::size_t i = 0; i < out.size(); ++i)
    for (std::size_t j = 0; j < i; ++j) EXPECT_GT((out[i].p_BC - out[j].p_BC).norm(), 0.05);
}

TEST(HullContacts, ATiltedBoxTouchesOnlyWithTheVerticesBelowTheSurface) {
  const BodyHull hull = BodyHull::make(0, Eigen::Isometry3d::Identity(), boxCorners({0.2, 0.1, 0.04}));
  // Rolled about x by 0.1 rad: the bottom edge at y = −0.05 is lowest.
  Eigen::Isometry3d X_WB = pose(Eigen::Vector3d::Zero(), {0.1, 0, 0});
  const double lowest = (X_WB * Eigen::Vector3d(0, -0.05, -0.02)).z();
  const double next = (X_WB * Eigen::Vector3d(0, 0.05, -0.02)).z();
  X_WB.translation().z() = -lowest - 0.5 * (next - lowest);  // between the two bottom edges
  ContactList out;
  ASSERT_EQ(appendHullGroundContacts(hull, X_WB, GroundPlane{}, out), 2);
  for (const ContactCandidate& c : out) {
    EXPECT_NEAR(c.p_BC.y(), -0.05, 1e-12);
    EXPECT_NEAR(c.p_BC.z(), -0.02, 1e-12);
    EXPECT_NEAR(c.depth_m, -c.p_WC.z(), 1e-15);
    EXPECT_GT(c.depth_m, 0.0);
  }
  EXPECT_NEAR(std::abs(out[0].p_BC.x() - out[1].p_BC.x()), 0.2, 1e-12);
}

TEST(HullContacts, AHullAboveTheGroundHasNone) {
  const BodyHull hull = BodyHull::make(0, Eigen::Isometry3d::Identity(), boxCorners({0.2, 0.1, 0.04}));
  ContactList out;
  EXPECT_EQ(appendHullGroundContacts(hull, pose({0, 0, 0.0201}, {0, 0, 0}), GroundPlane{}, out), 0);
  // Tilted, the lowest corner 0.1 mm above: within the bounding sphere's reach, so the
  // vertex test decides.
  Eigen::Isometry3d tilted = pose(Eigen::Vector3d::Zero(), {0.2, 0.1, 0});
  tilted.translation().z() = 1e-4 - (tilted * hull.p_SV).row(2).minCoeff();
  EXPECT_EQ(appendHullGroundContacts(hull, tilted, GroundPlane{}, out), 0);
  tilted.translation().z() -= 2e-4;
  EXPECT_EQ(appendHullGroundContacts(hull, tilted, GroundPlane{}, out), 1);
  EXPECT_EQ(out.size(), 1u);
}

TEST(HullContacts, ADenseSoleKeepsAtMostEightPointsAndItsBoundingRectangle) {
  // 2 × 96 vertices; the flat bottom ring 0.5 mm below a slope of 10°, yawed.
  const BodyHull hull = BodyHull::make(1, Eigen::Isometry3d::Identity(), ellipticPrism(0.12, 0.05, 0.03, 96));
  const GroundPlane ground = GroundPlane::sloped(10.0 * M_PI / 180.0, 0.4, 0.1);
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
  // Sole frame: z along the ground's normal, x the slope's tangent turned by 0.9 rad.
  const Eigen::Vector3d n = ground.n_W;
  const Eigen::Vector3d t = contactTangent(n, Eigen::Vector3d(std::cos(0.9), std::sin(0.9), 0));
  X_WB.linear().col(0) = t;
  X_WB.linear().col(1) = n.cross(t);
  X_WB.linear().col(2) = n;
  const Eigen::Vector3d p_on = Eigen::Vector3d(0.3, 0.2, 0) - n * ground.signedDistance({0.3, 0.2, 0});
  X_WB.translation() = p_on + n * (0.015 - 0.0005);
  ContactList out;
  const int added = appendHullGroundContacts(hull, X_WB, ground, out);
  EXPECT_EQ(added, kMaxHullGroundContacts);
  // Brute force: the bottom ring's bounding rectangle along the body's x and y.
  double x_lo = INFINITY, x_hi = -INFINITY, y_lo = INFINITY, y_hi = -INFINITY;
  for (Eigen::Index i = 0; i < hull.p_SV.cols(); ++i) {
    const Eigen::Vector3d p_W = X_WB * hull.p_SV.col(i);
    if (ground.signedDistance(p_W) > 0) continue;
    x_lo = std::min(x_lo, t.dot(p_W));
    x_hi = std::max(x_hi, t.dot(p_W));
    y_lo = std::min(y_lo, n.cross(t).dot(p_W));
    y_hi = std::max(y_hi, n.cross(t).dot(p_W));
  }
  double a_lo = INFINITY, a_hi = -INFINITY, b_lo = INFINITY, b_hi = -INFINITY;
  for (const ContactCandidate& c : out) {
    EXPECT_NEAR(c.depth_m, 0.0005, 1e-12);
    EXPECT_NEAR(ground.signedDistance(c.p_WC), -c.depth_m, 1e-15);
    EXPECT_LT((c.n_W - n).norm(), 1e-15);
    a_lo = std::min(a_lo, t.dot(c.p_WC));
    a_hi = std::max(a_hi, t.dot(c.p_WC));
    b_lo = std::min(b_lo, n.cross(t).dot(c.p_WC));
    b_hi = std::max(b_hi, n.cross(t).dot(c.p_WC));
  }
  EXPECT_NEAR(a_lo, x_lo, 1e-12);
  EXPECT_NEAR(a_hi, x_hi, 1e-12);
  EXPECT_NEAR(b_lo, y_lo, 1e-12);
  EXPECT_NEAR(b_hi, y_hi, 1e-12);
  EXPECT_NEAR(a_hi - a_lo, 0.24, 1e-12);
  EXPECT_NEAR(b_hi - b_lo, 0.10, 1e-12);
}

TEST(HullContacts, RoundOffInThePoseDoesNotChangeWhichVerticesAreChosen) {
  // A box flat on the ground has two extreme corners along each of its axes; two engines'
  // poses differ in the last bits. The chosen vertices must not.
  const BodyHull hull = BodyHull::make(0, Eigen::Isometry3d::Identity(), boxCorners({0.2, 0.1, 0.04}));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> noise(-1e-14, 1e-14);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Isometry3d X_WB = pose({0.1, 0.2, 0.0199}, {0, 0, 0.05 * trial});
    const Eigen::Isometry3d X_noisy =
        pose(X_WB.translation() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)),
             logSO3(X_WB.linear()) + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    ContactList a, b;
    appendHullGroundContacts(hull, X_WB, GroundPlane{}, a);
    appendHullGroundContacts(hull, X_noisy, GroundPlane{}, b);
    ASSERT_EQ(a.size(), 4u) << "trial " << trial;
    ASSERT_EQ(b.size(), 4u) << "trial " << trial;
    for (const ContactCandidate& x : a) {
      double nearest = INFINITY;
      for (const ContactCandidate& y : b) nearest = std::min(nearest, (x.p_BC - y.p_BC).norm());
      EXPECT_LT(nearest, 1e-12) << "trial " << trial;
    }
  }
}

TEST(HullContacts, AFullListCountsTheOverflow) {
  const BodyHull hull = BodyHull::make(0, Eigen::Isometry3d::Identity(), boxCorners({0.2, 0.1, 0.04}));
  ContactList out(3);
  EXPECT_EQ(appendHullGroundContacts(hull, pose({0, 0, 0.019}, {0, 0, 0}), GroundPlane{}, out), 3);
  EXPECT_EQ(out.overflow(), 1u);
}

TEST(HullContacts, AnEmptyOrNonFiniteHullIsRefused) {
  EXPECT_THROW(BodyHull::make(0, Eigen::Isometry3d::Identity(), Eigen::Matrix3Xd(3, 0)),
               std::invalid_argument);
  Eigen::Matrix3Xd bad = boxCorners({1, 1, 1});
  bad(1, 4) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(BodyHull::make(0, Eigen::Isometry3d::Identity(), bad), std::invalid_argument);
}

TEST(CylinderContacts, AnUprightCylinderOneMillimetreDeepTouchesAtEightPointsOfItsBottomRim) {
  const BodyCylinder cylinder{4, pose({0, 0, -0.1}, {0, 0, 0}), 0.05, 0.2};
  const Eigen::Isometry3d X_WB = pose({0.3, 0.1, 0.2 - 0.001}, {0, 0, 0.6});
  ContactList out;
  ASSERT_EQ(appendCylinderGroundContacts(cylinder, X_WB, GroundPlane{}, out), 8);
  for (std::size_t k = 0; k < out.size(); ++k) {
    const ContactCandidate& c = out[k];
    EXPECT_EQ(c.body, 4);
    EXPECT_NEAR(c.depth_m, 1e-3, 1e-12);
    EXPECT_NEAR(c.p_BC.z(), -0.2, 1e-12);
    EXPECT_NEAR(c.p_BC.head<2>().norm(), 0.05, 1e-12);
    // Along the body's x turned by k · 45°.
    const double a = static_cast<double>(k) * M_PI / 4;
    EXPECT_LT((c.p_BC.head<2>() / 0.05 - Eigen::Vector2d(std::cos(a), std::sin(a))).norm(), 1e-9);
    EXPECT_LT((X_WB * c.p_BC - c.p_WC).norm(), 1e-12);
  }
}

TEST(CylinderContacts, ACylinderOnItsSideTouchesAlongItsLowestLineAtItsTrueDepth) {
  // Axis along the body's x; 1 mm deep: the arc below each rim is 2√(2 r d) wide.
  const double r = 0.05, depth = 1e-3;
  const BodyCylinder cylinder{0, pose(Eigen::Vector3d::Zero(), {0, M_PI / 2, 0}), r, 0.3};
  const Eigen::Isometry3d X_WB = pose({0, 0, r - depth}, {0, 0, 0.2});
  ContactList out;
  const int added = appendCylinderGroundContacts(cylinder, X_WB, GroundPlane{}, out);
  ASSERT_GE(added, 4);
  double deepest = 0.0, y_lo = INFINITY, y_hi = -INFINITY, x_lo = INFINITY, x_hi = -INFINITY;
  for (const ContactCandidate& c : out) {
    EXPECT_GE(c.depth_m, 0.0);
    EXPECT_LE(c.depth_m, depth + 1e-12);
    EXPECT_NEAR(c.p_BC.y() * c.p_BC.y() + c.p_BC.z() * c.p_BC.z(), r * r, 1e-12);  // on a rim
    deepest = std::max(deepest, c.depth_m);
    x_lo = std::min(x_lo, c.p_BC.x());
    x_hi = std::max(x_hi, c.p_BC.x());
    y_lo = std::min(y_lo, c.p_BC.y());
    y_hi = std::max(y_hi, c.p_BC.y());
  }
  EXPECT_NEAR(deepest, depth, 1e-12);
  EXPECT_NEAR(x_hi - x_lo, 0.3, 1e-12);  // both rims
  const double half_chord = std::sqrt(r * r - (r - depth) * (r - depth));
  EXPECT_NEAR(y_hi, half_chord, 1e-12);
  EXPECT_NEAR(y_lo, -half_chord, 1e-12);
}

TEST(CylinderContacts, ATiltedCylinderTouchesAtTheArcOfItsLowerRimOnly) {
  // Tilted by 0.3 rad about the body's x, its lowest rim point 2 mm deep: every point lies
  // on that rim, within the arc below the plane, the deepest one included.
  const double r = 0.04, half = 0.1;
  const BodyCylinder cylinder{1, Eigen::Isometry3d::Identity(), r, 2 * half};
  Eigen::Isometry3d X_WB = pose(Eigen::Vector3d::Zero(), {0.3, 0, 0});
  const double lowest = -half * std::cos(0.3) - r * std::sin(0.3);
  X_WB.translation().z() = -lowest - 0.002;
  ContactList out;
  ASSERT_GE(appendCylinderGroundContacts(cylinder, X_WB, GroundPlane{}, out), 3);
  double deepest = 0.0;
  for (const ContactCandidate& c : out) {
    EXPECT_NEAR(c.p_BC.z(), -half, 1e-12);
    EXPECT_NEAR(c.p_BC.head<2>().norm(), r, 1e-12);
    EXPECT_GE(c.depth_m, 0.0);
    EXPECT_NEAR(c.depth_m, -c.p_WC.z(), 1e-15);
    deepest = std::max(deepest, c.depth_m);
  }
  EXPECT_NEAR(deepest, 0.002, 1e-12);
  // Lifted clear: none.
  X_WB.translation().z() += 0.0021;
  out.clear();
  EXPECT_EQ(appendCylinderGroundContacts(cylinder, X_WB, GroundPlane{}, out), 0);
}

}  // namespace
}  // namespace dynfilter
