// The filter attached to a user's own ODE world: bodies and joints the user built from the
// URDF with their own code (examples/ode_attach/figure_world.cpp) must give the same A, b,
// J and J̇·v as the URDF-built backends, and ball and fixed joints must be handled.
#include <gtest/gtest.h>

#include "attach_support.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "figure_world.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

TEST(AttachOde, UserBodiesAgreeWithTheUrdfBackendsOnTheHumanFigure) {
  FigureWorld user(test::humanFigurePath());
  auto attached = ode_backend::attachOdeModel(user.robot);
  const auto robot = urdf::loadUrdfFile(test::humanFigurePath());
  auto dart = test::makeModel("dart", robot, ModelOptions{});
  auto ode = test::makeModel("ode", robot, ModelOptions{});
  EXPECT_TRUE(attached->info().floating_base);
  EXPECT_EQ(attached->nv(), dart->nv());
  EXPECT_NEAR(attached->info().total_mass, dart->info().total_mass, 1e-9);
  const double vs_dart = worstGap(*dart, *attached, 20, 3);
  const double vs_ode = worstGap(*ode, *attached, 20, 4);
  RecordProperty("worst_vs_dart", test::scientific(vs_dart));
  RecordProperty("worst_vs_ode", test::scientific(vs_ode));
  EXPECT_LT(vs_dart, kTolerance);
  EXPECT_LT(vs_ode, kTolerance);
}

}  // namespace
}  // namespace dynfilter
