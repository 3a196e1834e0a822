// The attached filter as a controller in the user's own simulation: the figure squats on
// its own feet while the user's world steps with its own contact solver, and the
// controller's per-tick path allocates nothing.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "dynfilter/ode/attached_filter.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"
#include "figure_world.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

struct SquatResult {
  double max_base_error_m = 0.0, max_tilt_rad = 0.0, max_joint_error_rad = 0.0;
  std::uint32_t status_union = 0;
  int ticks = 0;
};

SquatResult squatOnOde(FilterMode mode, double seconds) {
  FigureWorld user(test::humanFigurePath());
  FilterOptions options;
  options.mode = mode;
  ode_backend::AttachedFilter filter(user.robot, options, proxqp::factory());
  const ModelInfo& info = filter.model().info();
  const auto motion = io::readReferenceMotion(test::sourcePath("data/squat_reference.csv"), info);
  const auto& frames = motion.frames;
  filter.placeAt(frames.front());
  SquatResult r;
  ReferenceFrame ref(info.nq, info.nv);
  Eigen::VectorXd error(info.nv), q(info.nq), v(info.nv);
  std::size_t k = 0;
  const double t_end = std::min(frames.front().time_s + seconds, frames.back().time_s);
  for (double t = frames.front().time_s; t <= t_end; t += options.dt_s, ++r.ticks) {
    while (k + 2 < frames.size() && frames[k + 1].time_s <= t) ++k;
    interpolateReference(true, frames[k], frames[k + 1], t, ref);
    const FilterOutput& out = filter.step(ref);
    r.status_union |= out.status;
    user.step(options.dt_s);
    EXPECT_TRUE(filter.model().readBodyState(q, v));
    differenceConfiguration(true, ref.q, q, error);
    r.max_base_error_m = std::max(r.max_base_error_m, error.head<3>().norm());
    r.max_tilt_rad = std::max(r.max_tilt_rad, error.segment<2>(3).norm());
    r.max_joint_error_rad = std::max(r.max_joint_error_rad, error.tail(info.nj).cwiseAbs().maxCoeff());
    if (std::getenv("ATTACH_DEBUG") && r.ticks % 50 == 0)
      std::printf("t %.3f base %.4f tilt %.4f joint %.4f contacts %d status %u tau %.1f z %.4f\n", t,
                  error.head<3>().norm(), error.segment<2>(3).norm(),
                  error.tail(info.nj).cwiseAbs().maxCoeff(), out.num_contacts, out.status,
                  out.tau_J.cwiseAbs().maxCoeff(), q[2]);
  }
  return r;
}

class AttachedOnOde : public testing::TestWithParam<FilterMode> {};

TEST_P(AttachedOnOde, TheFigureSquatsWithTheUsersContactSolverEveryTick) {
  const SquatResult r = squatOnOde(GetParam(), 4.0);
  RecordProperty("max_base_error_m", std::to_string(r.max_base_error_m));
  RecordProperty("max_tilt_rad", std::to_string(r.max_tilt_rad));
  RecordProperty("max_joint_error_rad", std::to_string(r.max_joint_error_rad));
  EXPECT_GE(r.ticks, 4000);
  EXPECT_LT(r.max_base_error_m, 0.01);
  EXPECT_LT(r.max_tilt_rad, 0.01);
  EXPECT_LT(r.max_joint_error_rad, 0.01);
  EXPECT_EQ(r.status_union & (kStatusReseeded | kStatusNonFinite | kStatusQpFallback), 0u)
      << r.status_union;
}

INSTANTIATE_TEST_SUITE_P(Modes, AttachedOnOde, testing::Values(FilterMode::kPaper, FilterMode::kQp),
                         [](const testing::TestParamInfo<FilterMode>& p) {
                           return std::string(toString(p.param));
                         });

}  // namespace
}  // namespace dynfilter
