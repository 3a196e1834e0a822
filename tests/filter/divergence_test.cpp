// The divergence guard (issue 9): each bound of DivergenceOptions is forced to trip, and
// the filter must re-seed from the reference, say why, and keep its output finite.
#include <algorithm>
#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/reference_motions.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

class Divergence : public testing::Test {
 protected:
  void SetUp() override {
    model_ = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
    frames_ = test::simulateStandingSway(*model_, 0.3, 1e-3);
  }
  // Steps @p filter through the first @p n frames; none of them may re-seed.
  void settle(DynamicsFilter& filter, int n) {
    filter.reset(frames_.front());
    for (int k = 0; k < n; ++k) {
      const FilterOutput& out = filter.step(frames_[static_cast<std::size_t>(k)]);
      ASSERT_EQ(out.status & kStatusReseeded, 0u) << "tick " << k << ": " << toString(out.reseed_reason);
    }
  }
  std::unique_ptr<IDynamicsModel> model_;
  std::vector<ReferenceFrame> frames_;
};

TEST_F(Divergence, BasePositionJumpReseedsOntoTheReference) {
  DynamicsFilter filter(*model_, FilterOptions{});
  settle(filter, 50);
  ReferenceFrame jumped = frames_[50];
  jumped.q[0] += 0.8;  // beyond max_base_error_m = 0.5
  const FilterOutput& out = filter.step(jumped);
  EXPECT_TRUE(out.status & kStatusReseeded);
  EXPECT_EQ(out.reseed_reason, ReseedReason::kBasePosition);
  EXPECT_EQ(out.counters.reseeds, 1u);
  // The state now is the reference's (the base x exactly; z may be lifted out of the floor).
  EXPECT_DOUBLE_EQ(filter.q()[0], jumped.q[0]);
  EXPECT_TRUE(out.q.allFinite() && out.tau_J.allFinite());
  // Next tick tracks from there: no further re-seed.
  ReferenceFrame next = frames_[51];
  next.q[0] += 0.8;
  EXPECT_EQ(filter.step(next).status & kStatusReseeded, 0u);
}

TEST_F(Divergence, BaseRotationJumpReseeds) {
  DynamicsFilter filter(*model_, FilterOptions{});
  settle(filter, 20);
  ReferenceFrame turned = frames_[20];
  const Eigen::Quaterniond q0(turned.q[3], turned.q[4], turned.q[5], turned.q[6]);
  const Eigen::Quaterniond q1 = Eigen::Quaterniond(Eigen::AngleAxisd(1.3, Eigen::Vector3d::UnitZ())) * q0;
  turned.q.segment<4>(3) << q1.w(), q1.x(), q1.y(), q1.z();  // 1.3 rad > 1.0 rad
  const FilterOutput& out = filter.step(turned);
  EXPECT_TRUE(out.status & kStatusReseeded);
  EXPECT_EQ(out.reseed_reason, ReseedReason::kBaseRotation);
}

TEST_F(Divergence, JointJumpReseedsAndASmallerOneDoesNot) {
  DynamicsFilter filter(*model_, FilterOptions{});
  settle(filter, 20);
  const int knee = model_->info().configurationIndex(model_->info().findJoint("l_knee"));
  ReferenceFrame bent = frames_[20];
  bent.q[knee] += 1.5;  // < max_joint_error_rad = 2.0: tracked, not re-seeded
  EXPECT_EQ(filter.step(bent).status & kStatusReseeded, 0u);
  bent = frames_[21];
  bent.q[knee] += 2.5;
  const FilterOutput& out = filter.step(bent);
  EXPECT_TRUE(out.status & kStatusReseeded);
  EXPECT_EQ(out.reseed_reason, ReseedReason::kJoint);
}

TEST_F(Divergence, ResidualBeyondTheBoundIsNotPublished) {
  FilterOptions options;
  DynamicsFilter reference_filter(*model_, options);
  settle(reference_filter, 10);
  const double residual = reference_filter.output().base_residual_n;  // ~1e-12 N
  ASSERT_GT(residual, 0.0);

  // A bound below what the solve achieves: every tick's answer is refused.
  options.divergence.max_base_residual_rel = 1e-30;
  DynamicsFilter filter(*model_, options);
  filter.reset(frames_.front());
  const Eigen::VectorXd q_before = filter.output().q;  // nothing published yet
  const FilterOutput& out = filter.step(frames_[1]);
  EXPECT_TRUE(out.status & kStatusReseeded);
  EXPECT_FALSE(out.status & kStatusNonFinite);
  EXPECT_EQ(out.reseed_reason, ReseedReason::kResidual);
  EXPECT_EQ(out.q, q_before) << "the refused tick's state must not be published";
}

// A QP engine that never solves: the filter falls back every tick, a degraded solve.
class NeverSolves final : public IQpSolver {
 public:
  QpSolveInfo solve(const DenseQp&, Eigen::Ref<Eigen::VectorXd> x) override {
    x.setZero();
    QpSolveInfo info;
    info.status = QpSolveStatus::kPrimalInfeasible;
    return info;
  }
  void resetWarmStart() override {}
  const char* name() const override { return "never-solves"; }
};

TEST_F(Divergence, ADegradedSolveForTooLongReseeds) {
  FilterOptions options;
  options.mode = FilterMode::kQp;
  options.divergence.max_degraded_ticks = 5;
  DynamicsFilter filter(*model_, options, [](int, int, int, const QpSolverSettings&) {
    return std::unique_ptr<IQpSolver>(new NeverSolves());
  });
  filter.reset(frames_.front());
  for (int k = 1; k <= 4; ++k) {
    const FilterOutput& out = filter.step(frames_[static_cast<std::size_t>(k)]);
    EXPECT_TRUE(out.status & kStatusQpFallback) << k;
    EXPECT_EQ(out.status & kStatusReseeded, 0u) << k;
  }
  const FilterOutput& out = filter.step(frames_[5]);
  EXPECT_TRUE(out.status & kStatusReseeded);
  EXPECT_EQ(out.reseed_reason, ReseedReason::kDegradedSolve);
  EXPECT_EQ(out.counters.qp_fallbacks, 5u);
  // The count starts over after the re-seed.
  EXPECT_EQ(filter.step(frames_[6]).status & kStatusReseeded, 0u);
}

TEST(DivergenceOptions, InvalidBoundsAreRejectedByName) {
  FilterOptions options;
  options.divergence.max_degraded_ticks = 0;
  try {
    options.validate();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("divergence.max_degraded_ticks"), std::string::npos) << e.what();
  }
}

// The reference leash (LeashOptions): a reference that walks off at 2 m/s and turns at
// 4 rad/s while the figure stands re-seeds the plain filter; with the leash the reference is
// moved back to the figure, never further than the bounds along the ground and in heading
// (on every tick, to rounding), and nothing re-seeds.
TEST_F(Divergence, TheLeashFollowsADriftAndATurnInsteadOfReseeding) {
  std::vector<ReferenceFrame> drifting = frames_;
  test::walkOffAndTurn(drifting, 2.0, 4.0);
  {
    DynamicsFilter plain(*model_, FilterOptions{});
    plain.reset(drifting.front());
    for (const ReferenceFrame& f : drifting) plain.step(f);
    EXPECT_GT(plain.output().counters.reseeds, 0u) << "the drift must trip the guard without the leash";
  }
  FilterOptions options;
  options.leash.enabled = true;
  DynamicsFilter filter(*model_, options);
  filter.reset(drifting.front());
  double largest_offset = 0.0, largest_heading = 0.0;
  for (const ReferenceFrame& f : drifting) {
    const FilterOutput& out = filter.step(f);
    ASSERT_EQ(out.status & kStatusReseeded, 0u) << "t = " << f.time_s << ": " << toString(out.reseed_reason);
    Eigen::VectorXd tracked = f.q;  // the reference this tick tracked
    moveBase(out.X_reference_offset, tracked);
    largest_offset = std::max(largest_offset, (tracked.head<2>() - out.q.head<2>()).norm());
    const Eigen::Matrix3d R_filter = Eigen::Quaterniond(out.q[3], out.q[4], out.q[5], out.q[6]).toRotationMatrix();
    const Eigen::Matrix3d R_tracked = Eigen::Quaterniond(tracked[3], tracked[4], tracked[5], tracked[6]).toRotationMatrix();
    largest_heading = std::max(largest_heading, std::abs(tiltAndHeading(R_filter, R_tracked).heading_rad));
  }
  EXPECT_NEAR(largest_offset, options.leash.max_offset_m, 1e-9);
  EXPECT_NEAR(largest_heading, options.leash.max_heading_rad, 1e-9);
  EXPECT_GT(filter.output().counters.leash_ticks, 100u);
  // A reset starts the leash over: the reference is tracked as received again.
  const std::uint64_t leash_ticks = filter.output().counters.leash_ticks;
  filter.reset(drifting.back());
  EXPECT_TRUE(filter.output().X_reference_offset.isApprox(Eigen::Isometry3d::Identity(), 0.0));
  filter.step(drifting.back());
  EXPECT_EQ(filter.output().counters.leash_ticks, leash_ticks);
  EXPECT_TRUE(filter.output().X_reference_offset.isApprox(Eigen::Isometry3d::Identity(), 0.0));
}

}  // namespace
}  // namespace dynfilter
