// The balance layer on the CMU walk's first steps, in the QP mode with the defaults, as
// dynfilter-offline runs it: no re-seed, no violated limit, Eq. 12 on every tick. The clean-up
// of the whole clip (a few minutes under the sanitizers, where tools/run-tests.sh leaves it to
// the Release run) runs once for both windows; the executable asks ctest to start it first
// (tests/CMakeLists.txt, COST). The raw retargeting of the same steps (no clean-up: seconds
// under the sanitizers) checks the per-tick invariants on a reference the figure cannot follow.
// The cleaned run's own output, filtered again, shows how far the filter is from giving a
// consistent motion back unchanged.
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/kinematic_tree.hpp"
#include "dynfilter/io/offline_run.hpp"
#include "dynfilter/io/reference_cleanup.hpp"
#include "dynfilter/io/retarget.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"
#include "dynfilter/qp_engines/qp_engines.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

// The walk's first @p seconds as dynfilter-bvh2ref writes them: retargeted, then cleaned up
// (its default) unless @p cleanup is false (--no-cleanup).
std::vector<ReferenceFrame> walkStart(IDynamicsModel& model, double seconds, bool cleanup) {
  const io::RetargetMapping mapping =
      io::readRetargetMapping(test::sourcePath("data/mocap/cmu/mappings/131_01.yaml"));
  io::BvhReadOptions read_options;
  read_options.length_scale = mapping.length_scale;
  const io::BvhMotion bvh =
      io::readBvh(test::sourcePath("data/mocap/cmu/131_01_start_walk_stop.bvh"), read_options);
  const io::ReferenceMotion retargeted = io::retargetBvh(bvh, mapping, model).motion;
  std::vector<ReferenceFrame> frames =
      cleanup ? io::cleanupReference(retargeted, model, mapping.cleanup, proxqp::factory()).motion.frames
              : retargeted.frames;
  std::size_t n = 0;
  while (n < frames.size() && frames[n].time_s <= seconds + 1e-9) ++n;
  frames.resize(n);
  return frames;
}

struct WalkWindow {
  std::uint64_t reseeds = 0;
  std::uint32_t status_union = 0, violated_union = 0;
  double max_base_residual_n = 0.0, weight_n = 0.0, legs_rms = 0.0, base_rms = 0.0;
  double max_penetration_m = 0.0;
  bool balance = false;
};

// The CMU walk's first @p seconds in the QP mode with the defaults, run by dynfilter-offline's
// own loop (io::runOffline: 480 Hz, the clip's future in the preview). windows[0] holds the
// ticks to @p split_s, windows[1] all of them: one run (the clean-up of the whole clip is what
// takes the time, a few minutes under the sanitizers) checks both. With @p filtered, the
// filtered state of every tick to @p filtered_s is appended to it as a frame (q and v after
// the tick, its v̇, at the tick's time: what dynfilter-offline --every-tick writes).
std::array<WalkWindow, 2> runWalk(double seconds, double split_s, bool cleanup,
                                  std::vector<ReferenceFrame>* filtered = nullptr,
                                  double filtered_s = 0.0) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const ModelInfo& info = model->info();
  const std::vector<JointGroup> groups = jointGroupsOf(*model);
  io::ReferenceMotion motion;
  motion.frames = walkStart(*model, seconds, cleanup);
  const double period = motion.frames[1].time_s - motion.frames[0].time_s;
  io::OfflineRunOptions run;
  run.tick_hz = 4.0 / period;
  run.preview_s = 2.0;  // offline: the clip's future
  std::array<WalkWindow, 2> windows;
  std::array<double, 2> legs_sq{}, base_sq{};
  std::array<long, 2> legs_n{}, ticks{};
  io::runOffline(*model, test::qpDefaults(period / 4.0), motion, run, qp_engines::factory(QpSolverSettings{}.engine),
                 [&](const io::OfflineTick& tick) {
                   const FilterOutput& out = *tick.output;
                   if (filtered != nullptr && tick.time_s <= filtered_s + 1e-9) {
                     ReferenceFrame& f = filtered->emplace_back(info.nq, info.nv);
                     f.time_s = tick.time_s;
                     f.q = out.q;
                     f.v = out.v;
                     f.vdot = out.vdot;
                   }
                   for (int k = tick.time_s <= split_s + 1e-9 ? 0 : 1; k < 2; ++k) {
                     WalkWindow& w = windows[static_cast<std::size_t>(k)];
                     ++ticks[k];
                     w.status_union |= out.status;
                     w.violated_union |= out.qp_violated;
                     w.max_base_residual_n = std::max(w.max_base_residual_n, out.base_residual_n);
                     w.max_penetration_m = std::max(w.max_penetration_m, out.max_penetration_m);
                     base_sq[k] += out.tracking_error.head<3>().squaredNorm();
                     for (int j = 0; j < info.nj; ++j) {
                       if (groups[static_cast<std::size_t>(j)] != JointGroup::kLeg) continue;
                       legs_sq[k] += std::pow(out.tracking_error[info.velocityIndex(j)], 2);
                       ++legs_n[k];
                     }
                     if (out.status & kStatusReseeded) ++w.reseeds;
                     w.balance = tick.filter->balance() != nullptr;
                   }
                 });
  for (std::size_t k = 0; k < 2; ++k) {
    WalkWindow& w = windows[k];
    w.legs_rms = std::sqrt(legs_sq[k] / legs_n[k]);
    w.base_rms = std::sqrt(base_sq[k] / ticks[k]);
    w.weight_n = info.total_mass * kStandardGravity;
  }
  return windows;
}

// The stance before the first step (to 1.0 s), then through the first steps (to 1.85 s;
// dynfilter-offline with main's filter re-seeded at 1.47 s on this clip once).
TEST(Balance, TheCmuWalksStanceAndFirstStepsWithTheDefaultsNeedNoReseed) {
  std::vector<ReferenceFrame> filtered;
  const std::array<WalkWindow, 2> windows = runWalk(1.85, 1.0, /*cleanup=*/true, &filtered, 1.2);
  {
    SCOPED_TRACE("stance, 0-1.0 s");
    const WalkWindow& w = windows[0];
    RecordProperty("stance_legs_rms_rad", std::to_string(w.legs_rms));
    RecordProperty("stance_base_rms_m", std::to_string(w.base_rms));
    EXPECT_TRUE(w.balance);
    EXPECT_EQ(w.reseeds, 0u);
    EXPECT_EQ(w.status_union & (kStatusReseeded | kStatusQpFallback | kStatusQpRelaxed |
                                kStatusReferenceInfeasible | kStatusNonFinite),
              0u)
        << "status union " << w.status_union;
    EXPECT_EQ(w.violated_union, 0u) << "no constraint family violated (pulling, friction, CoP, torque)";
    EXPECT_LE(w.max_base_residual_n, 1e-8 * w.weight_n);
    // Measured per tick on the cleaned reference, the preview holding the clip to 1.85 s:
    // legs 0.023 rad, base 0.007 m (DART, defaults; with the preview cut at 1.0 s, 0.030 rad
    // and 0.046 m); the targets are 0.08 rad and 5 cm.
    EXPECT_LE(w.legs_rms, 0.08);
    EXPECT_LE(w.base_rms, 0.05);
  }
  {
    SCOPED_TRACE("first steps, 0-1.85 s");
    // Tracking is loose here (legs 0.31 rad, base 0.11 m measured on the raw retargeting)
    // and some ticks need a QP relaxation: not the targets. Checked: this window
    // also passes with the contact schedule reverted to the 2 cm lift-off rule, so it does
    // not single out that mechanism.
    const WalkWindow& w = windows[1];
    RecordProperty("max_penetration_m", std::to_string(w.max_penetration_m));
    EXPECT_EQ(w.reseeds, 0u);
    EXPECT_EQ(w.status_union & (kStatusReseeded | kStatusQpFallback | kStatusNonFinite), 0u)
        << "status union " << w.status_union;
    EXPECT_LE(w.max_base_residual_n, 1e-8 * w.weight_n);
    EXPECT_LE(w.base_rms, 0.15);
    // No body sinks into the floor by more than the 2 mm. Before released pairs
    // re-engaged as they moved into the ground, the left sole landing at 1.0 s sank 5.1 mm and
    // a right toe scuff at 1.13 s 5.8 mm (and held there for 0.1 s).
    EXPECT_LE(w.max_penetration_m, 0.002);
  }
  {
    // A motion that is already consistent — the filter's own output, every tick with its q, v
    // and v̇ — should come back nearly unchanged; it does not yet (docs/balance.md §42). 0-1.2 s
    // holds the first lift-off: from 0.775 s the reference's heel rises while the filter holds
    // the sole flat until its tilt passes balance.roll_tilt_rad (0.1), and the left knee lags by
    // up to 0.12 rad. Measured (DART, Release): legs 0.060 rad RMS, 0.004 before the lift-off;
    // 0.031 / 0.016 with roll_tilt_rad 0.05 / 0.02 (not the default: the G1's walk and the
    // jump's landings sink with it). The bound guards what holds today.
    SCOPED_TRACE("the filter's own output filtered again, 0-1.2 s");
    ASSERT_GE(filtered.size(), 2u);
    auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
    const ModelInfo& info = model->info();
    const std::vector<JointGroup> groups = jointGroupsOf(*model);
    io::ReferenceMotion motion;
    motion.frames = filtered;
    const double dt = filtered[1].time_s - filtered[0].time_s;
    io::OfflineRunOptions run;
    run.tick_hz = 1.0 / dt;
    double legs_sq = 0.0;
    long legs_n = 0;
    std::uint64_t reseeds = 0;
    io::runOffline(*model, test::qpDefaults(dt), motion, run, qp_engines::factory(QpSolverSettings{}.engine),
                   [&](const io::OfflineTick& tick) {
                     if (tick.output->status & kStatusReseeded) ++reseeds;
                     for (int j = 0; j < info.nj; ++j) {
                       if (groups[static_cast<std::size_t>(j)] != JointGroup::kLeg) continue;
                       legs_sq += std::pow(tick.output->tracking_error[info.velocityIndex(j)], 2);
                       ++legs_n;
                     }
                   });
    const double legs_rms = std::sqrt(legs_sq / static_cast<double>(legs_n));
    RecordProperty("refiltered_legs_rms_rad", std::to_string(legs_rms));
    EXPECT_EQ(reseeds, 0u);
    EXPECT_LE(legs_rms, 0.075);
  }
}

// The same steps on the raw retargeting: feet that skate and sink, joints beyond their
// limits. The figure cannot follow it everywhere (relaxed ticks, a re-seed may come), but
// every tick still satisfies Eq. 12 with an unactuated base, and nothing non-finite leaves.
TEST(Balance, TheRawCmuWalksFirstStepsGiveConsistentTicks) {
  const std::array<WalkWindow, 2> windows = runWalk(1.85, 1.0, /*cleanup=*/false);
  const WalkWindow& w = windows[1];
  RecordProperty("reseeds", std::to_string(w.reseeds));
  RecordProperty("legs_rms_rad", std::to_string(w.legs_rms));
  RecordProperty("max_base_residual_n", std::to_string(w.max_base_residual_n));
  // Measured (DART, Release): one re-seed, relaxed ticks, largest base-row residual 2.2e-8 N
  // against a bound of 6e-6 N; 0.24 s of CPU (the clean-up's QPs are what the test above waits for).
  EXPECT_TRUE(w.balance);
  EXPECT_EQ(w.status_union & kStatusNonFinite, 0u) << "status union " << w.status_union;
  EXPECT_LE(w.max_base_residual_n, 1e-8 * w.weight_n);
}

}  // namespace
}  // namespace dynfilter
