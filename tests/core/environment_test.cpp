#include <cmath>

#include <gtest/gtest.h>

#include "dynfilter/core/environment.hpp"

namespace dynfilter {
namespace {

TEST(Environment, SlopedGroundDescendsAlongHeading) {
  const double slope = 5.0 * M_PI / 180.0;
  const GroundPlane g = GroundPlane::sloped(slope, 0.0, 0.0);
  EXPECT_NEAR(g.n_W.norm(), 1.0, 1e-15);
  // One metre forward, the surface is tan(5°) lower.
  EXPECT_NEAR(g.signedDistance(Eigen::Vector3d(1.0, 0.0, -std::tan(slope))), 0.0, 1e-15);
  EXPECT_NEAR(g.signedDistance(Eigen::Vector3d(0.0, 3.0, 0.0)), 0.0, 1e-15);
  const GroundPlane side = GroundPlane::sloped(slope, M_PI / 2, 0.5);
  EXPECT_NEAR(side.signedDistance(Eigen::Vector3d(0.0, 1.0, 0.5 - std::tan(slope))), 0.0, 1e-15);
}

TEST(Environment, ValidateRejectsBadEntries) {
  Environment env;
  EXPECT_NO_THROW(env.validate());
  env.ground.n_W = Eigen::Vector3d(0, 0, 2);
  EXPECT_THROW(env.validate(), std::invalid_argument);
  env.ground = GroundPlane();
  env.boxes.push_back({"step", Eigen::Vector3d(0.3, -0.1, 0.2), Eigen::Isometry3d::Identity(), 1});
  try {
    env.validate();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("\"step\""), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dynfilter
