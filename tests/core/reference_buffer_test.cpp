#include <gtest/gtest.h>

#include "dynfilter/core/reference_buffer.hpp"

namespace dynfilter {
namespace {

ReferenceFrame frame(double t, double joint) {
  ReferenceFrame f(8, 7);
  f.time_s = t;
  f.q << 0, 0, 1, 1, 0, 0, 0, joint;
  f.v.setConstant(joint);
  f.vdot.setConstant(2 * joint);
  return f;
}

TEST(ReferenceBuffer, InterpolatesBetweenFramesAndHoldsAfterTheNewest) {
  ReferenceBuffer buffer(8, 7, true, 4);
  ReferenceFrame out(8, 7);
  EXPECT_FALSE(buffer.sample(0.0, out));
  ASSERT_TRUE(buffer.push(frame(1.0, 0.0)));
  ASSERT_TRUE(buffer.push(frame(1.1, 1.0)));
  ASSERT_TRUE(buffer.sample(1.025, out));
  EXPECT_NEAR(out.q[7], 0.25, 1e-12);
  EXPECT_NEAR(out.v[0], 0.25, 1e-12);
  // After the newest frame: its pose, no motion (hold, no extrapolation).
  ASSERT_TRUE(buffer.sample(5.0, out));
  EXPECT_DOUBLE_EQ(out.q[7], 1.0);
  EXPECT_EQ(out.v.norm(), 0.0);
  // Before the oldest: the oldest pose, at rest.
  ASSERT_TRUE(buffer.sample(0.0, out));
  EXPECT_DOUBLE_EQ(out.q[7], 0.0);
  EXPECT_EQ(out.v.norm() + out.vdot.norm(), 0.0);
}

TEST(ReferenceBuffer, RejectsTimeGoingBackwardsAndDropsTheOldestWhenFull) {
  ReferenceBuffer buffer(8, 7, true, 3);
  for (int k = 0; k < 5; ++k) ASSERT_TRUE(buffer.push(frame(0.1 * k, k)));
  EXPECT_FALSE(buffer.push(frame(0.35, 9.0)));  // before the newest (0.4)
  EXPECT_FALSE(buffer.push(frame(0.4, 9.0)));   // same time
  EXPECT_EQ(buffer.size(), 3);
  EXPECT_NEAR(buffer.oldestTime(), 0.2, 1e-15);
  ReferenceFrame out(8, 7);
  ASSERT_TRUE(buffer.sample(0.35, out));
  EXPECT_NEAR(out.q[7], 3.5, 1e-12);
}

}  // namespace
}  // namespace dynfilter
