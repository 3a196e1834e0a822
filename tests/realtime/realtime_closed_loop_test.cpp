// The real-time loop closed on a simulated robot, in one process and deterministic: what
// dynfilter --mode qp --use-measured-state, dynfilter-sim --servo-error-rad 0 and
// dynfilter-replay do over LCM, with the transport replaced by a schedule. The filter
// (RealtimeFilter, plan on DART) holds the standing pose until the replay starts, frames
// arrive stamped on the sender's clock at the clip's rate, and every tick starts from the
// robot's measured state; the robot (ODE's or DART's engine) applies the torques alone.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include <dart/constraint/ContactConstraint.hpp>

#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "dynfilter/io/retarget.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"
#include "dynfilter/realtime/realtime_filter.hpp"
#include "dynfilter/realtime/replay_player.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "robot_engine.hpp"
#include "support/test_support.hpp"

namespace dynfilter::realtime {
namespace {

struct LoopSetup {
  std::string engine = "ode";
  bool balance_preview = false;
  double replay_start_s = 0.5;  ///< local time the first frame is sent
  double seconds = 4.0;         ///< ticks after the replay starts
  double sender_clock_s = 0.0;  ///< sender clock − local clock
  /// Frames are delivered only every this many ticks (a loaded machine: bursts), ≥ 1.
  int delivery_every_ticks = 1;
  /// The first frames arrive this late (s) in one burst (a receiver that was descheduled).
  double first_delivery_late_s = 0.0;
  /// The sender is descheduled for gap_s every gap_every_s (frames not sent meanwhile; the
  /// clip's time runs on, as dynfilter-replay's ticker skips late periods). 0: never.
  double gap_every_s = 0.0, gap_s = 0.0, gap_first_s = 0.0;
};

struct LoopResult {
  double min_base_z_m = 1e9, min_base_z_time_s = 0.0, max_tilt_rad = 0.0;
  std::uint32_t status_union = 0;
  int ticks = 0;
  std::uint64_t reseeds = 0;
};

realtime::Clip squatClip(const ModelInfo& info) {
  return {"squat", io::readReferenceMotion(test::sourcePath("data/squat_reference.csv"), info).frames};
}

LoopResult runLoop(const LoopSetup& setup, const realtime::Clip& clip, const char* log_path = nullptr) {
  const auto description = urdf::loadUrdfFile(test::humanFigurePath());
  const processes::RobotEngineSettings engine = processes::useAsRobot(setup.engine);
  auto plan = test::makeModel("dart", description, ModelOptions{});
  auto robot = test::makeModel(setup.engine, description, ModelOptions{});
  const ModelInfo& info = plan->info();
  FilterOptions options;
  options.mode = FilterMode::kQp;
  RealtimeOptions rt_options;
  rt_options.use_measured_state = true;
  rt_options.balance_preview = setup.balance_preview;
  ReferenceFrame hold(info.nq, info.nv);
  hold.q = info.neutralConfiguration();
  hold.q[2] = standingBaseHeight(*plan, hold.q);
  RealtimeFilter rt(*plan, options, rt_options, hold, proxqp::factory());
  robot->setState(hold.q, Eigen::VectorXd::Zero(info.nv));

  ReplayOptions replay_options;
  replay_options.loop = true;
  ReplayPlayer player({clip}, replay_options, true);
  player.switchTo(0, 0.0);
  const double frame_period = 1.0 / player.frameRate();
  std::vector<ReferenceFrame> pending;  // sent, not yet delivered
  std::int64_t sequence = 0;
  double next_send = setup.replay_start_s;
  std::FILE* log = log_path ? std::fopen(log_path, "w") : nullptr;

  LoopResult r;
  const double dt = 1e-3;
  const int ticks = static_cast<int>(std::lround((setup.replay_start_s + setup.seconds) / dt));
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(info.nj);
  for (int k = 0; k <= ticks; ++k) {
    const double now = k * dt;
    while (next_send <= now + 1e-12) {
      if (setup.gap_every_s > 0.0) {
        const double since = next_send - setup.replay_start_s - setup.gap_first_s;
        if (since >= 0.0 && std::fmod(since, setup.gap_every_s) < setup.gap_s) {
          next_send += frame_period;
          continue;
        }
      }
      ReferenceFrame f(info.nq, info.nv);
      player.frameAt(next_send - setup.replay_start_s, f);
      f.time_s = next_send + setup.sender_clock_s;
      pending.push_back(f);
      next_send += frame_period;
    }
    const bool deliver = now >= setup.replay_start_s + setup.first_delivery_late_s &&
                         k % std::max(1, setup.delivery_every_ticks) == 0;
    if (deliver) {
      for (const ReferenceFrame& f : pending) rt.addReference(f, now, ++sequence);
      pending.clear();
    }
    rt.addMeasuredState(robot->q(), robot->v(), now, now);
    const FilterOutput& out = rt.tick(now);
    r.status_union |= rt.status();
    tau = rt.command();
    robot->simulateStep(tau, dt);
    ++r.ticks;
    const double z = robot->q()[2];
    if (z < r.min_base_z_m) {
      r.min_base_z_m = z;
      r.min_base_z_time_s = now;
    }
    const Eigen::Vector4d quat = robot->q().segment<4>(3);
    r.max_tilt_rad = std::max(r.max_tilt_rad, 2.0 * std::asin(std::min(1.0, std::hypot(quat[1], quat[2]))));
    if (log) {
      const BalanceState* b = rt.filter().balance();
      std::fprintf(log, "%.3f %.4f %d %.5f %d %d", now, z, rt.stale() ? 1 : 0,
                   rt.lastReference().time_s - setup.sender_clock_s, b ? b->preview_samples : -1,
                   static_cast<int>(out.status));
      if (b)
        std::fprintf(log, " %.4f %.4f %.4f %.4f %.4f %.4f %.3f %.3f %.3f %.4f %.4f", b->dcm.x(), b->dcm.y(),
                     b->dcm_desired.x(), b->dcm_desired.y(), b->cop_command.x(), b->cop_command.y(),
                     b->com_accel_desired.x(), b->com_accel_desired.y(), b->com_accel_desired.z(),
                     b->reference.c_W.z(), b->filter.c_W.z());
      std::fprintf(log, " %d %d %d\n", static_cast<int>(out.reseed_reason), out.qp_status, b ? b->active : -1);
    }
  }
  if (log) std::fclose(log);
  r.reseeds = rt.counters().reseeds;
  if (setup.engine == "dart") dart::constraint::ContactConstraint::setConstraintForceMixing(1e-5);
  (void)engine;
  return r;
}

double envDouble(const char* name, double fallback) {
  const char* s = std::getenv(name);
  return s ? std::atof(s) : fallback;
}

TEST(RealtimeClosedLoopExperiment, Run) {
  LoopSetup s;
  s.engine = std::getenv("EXP_ENGINE") ? std::getenv("EXP_ENGINE") : "ode";
  s.balance_preview = envDouble("EXP_PREVIEW", 0) != 0;
  s.seconds = envDouble("EXP_SECONDS", 4.0);
  s.delivery_every_ticks = static_cast<int>(envDouble("EXP_EVERY", 1));
  s.first_delivery_late_s = envDouble("EXP_LATE", 0.0);
  s.sender_clock_s = envDouble("EXP_CLOCK", 0.0);
  s.gap_every_s = envDouble("EXP_GAP_EVERY", 0.0);
  s.gap_s = envDouble("EXP_GAP", 0.0);
  s.gap_first_s = envDouble("EXP_GAP_FIRST", 0.0);
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  realtime::Clip clip;
  if (std::getenv("EXP_BVH")) {
    const auto mapping = io::readRetargetMapping(test::sourcePath(std::getenv("EXP_MAPPING")));
    clip = {"bvh", io::retargetBvhFile(test::sourcePath(std::getenv("EXP_BVH")), mapping, *model).motion.frames};
  } else {
    clip = squatClip(model->info());
  }
  const LoopResult r = runLoop(s, clip, std::getenv("EXP_LOG"));
  std::printf("min z %.4f at %.3f s, max tilt %.4f, reseeds %llu, status union 0x%x\n", r.min_base_z_m,
              r.min_base_z_time_s, r.max_tilt_rad, static_cast<unsigned long long>(r.reseeds), r.status_union);
}

}  // namespace
}  // namespace dynfilter::realtime
