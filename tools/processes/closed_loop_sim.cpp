#include "closed_loop_sim.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <dart/constraint/ContactConstraint.hpp>

#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/qp_engines/qp_engines.hpp"
#include "robot_engine.hpp"

namespace dynfilter::processes {

ClosedLoopResult runClosedLoop(const urdf::RobotDescription& robot_description, const ClosedLoopSetup& setup,
                               const std::vector<realtime::Clip>& clips, std::FILE* log) {
  if (!(setup.seconds > 0.0) || setup.replay_start_s < 0.0 || setup.gap_s < 0.0 || setup.gap_every_s < 0.0)
    throw std::invalid_argument("closed loop: seconds must be > 0, start and gaps >= 0");
  // DART keeps its contact softness process-wide: restored when the run ends.
  const double dart_cfm = dart::constraint::ContactConstraint::getConstraintForceMixing();
  struct RestoreCfm {
    double cfm;
    ~RestoreCfm() { dart::constraint::ContactConstraint::setConstraintForceMixing(cfm); }
  } restore{dart_cfm};
  const RobotEngineSettings engine = useAsRobot(setup.robot_engine);
  auto plan = makeModel("dart", robot_description, ModelOptions{});
  auto robot = makeModel(setup.robot_engine, robot_description, ModelOptions{});
  const ModelInfo& info = plan->info();
  if (!info.floating_base) throw std::invalid_argument("closed loop: the robot stands on its feet (floating base)");

  realtime::RealtimeOptions rt_options = setup.realtime;
  rt_options.use_measured_state = true;
  ReferenceFrame hold(info.nq, info.nv);
  hold.q = info.neutralConfiguration();
  hold.q[2] = standingBaseHeight(*plan, hold.q);
  realtime::RealtimeFilter rt(*plan, setup.filter, rt_options, hold, qp_engines::factory(setup.filter.qp.solver.engine));
  robot->setState(hold.q, Eigen::VectorXd::Zero(info.nv));

  realtime::ReplayPlayer player(clips, setup.replay, true);
  player.switchTo(0, 0.0);
  const double frame_period = 1.0 / player.frameRate();
  ReferenceFrame frame(info.nq, info.nv);
  std::int64_t sequence = 0;
  double next_send = setup.replay_start_s;

  ClosedLoopResult r;
  const double dt = 1e-3;
  const int ticks = static_cast<int>(std::lround((setup.replay_start_s + setup.seconds) / dt));
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(info.nj);
  Eigen::VectorXd v_before = Eigen::VectorXd::Zero(info.nv), accel_mismatch = Eigen::VectorXd::Zero(info.nv);
  struct HeldState {
    Eigen::VectorXd q, v;
    double t;
  };
  std::vector<HeldState> held_states;
  // Local time t falls in one of the sender's descheduled gaps.
  const auto inGap = [&setup](double t) {
    const double since = t - setup.replay_start_s - setup.gap_first_s;
    return setup.gap_every_s > 0.0 && since >= 0.0 && std::fmod(since, setup.gap_every_s) < setup.gap_s;
  };
  for (int k = 0; k <= ticks; ++k) {
    const double now = k * dt;
    for (; next_send <= now + 1e-9; next_send += frame_period) {
      if (inGap(next_send)) continue;  // descheduled: the ticker skips the period
      player.frameAt(next_send - setup.replay_start_s, frame);
      frame.time_s = next_send;
      rt.addReference(frame, now, ++sequence);
      ++r.frames_sent;
    }
    const bool robot_stalled = setup.gap_stalls_robot && inGap(now);
    const double since_replay = now - setup.replay_start_s;
    const bool states_held = setup.state_delay_s > 0.0 && since_replay >= setup.state_delay_at_s &&
                             since_replay < setup.state_delay_at_s + setup.state_delay_s;
    if (states_held) {
      held_states.push_back({robot->q(), robot->v(), now});
    } else {
      for (const HeldState& h : held_states) rt.addMeasuredState(h.q, h.v, h.t, now);
      held_states.clear();
      if (!robot_stalled) rt.addMeasuredState(robot->q(), robot->v(), now, now);
    }
    const FilterOutput& out = rt.tick(now);
    r.status_union |= rt.status();
    if (out.status & kStatusReseeded)
      ++r.reseed_ticks_by_reason[static_cast<std::size_t>(std::clamp(static_cast<int>(out.reseed_reason), 0, 6))];
    tau = rt.command();
    if (log != nullptr) v_before = robot->v();
    if (!robot_stalled) {
      try {
        for (int s = 0; s < engine.substeps; ++s) robot->simulateStep(tau, dt / engine.substeps);
      } catch (const std::runtime_error& e) {  // the engine keeps its last state and refuses to go on
        r.engine_refused_at_s = now - setup.replay_start_s;
        r.engine_error = e.what();
        break;
      }
    }
    ++r.ticks;
    const double z = robot->q()[2];
    const Eigen::Vector4d quat = robot->q().segment<4>(3);
    const double tilt = 2.0 * std::asin(std::min(1.0, std::hypot(quat[1], quat[2])));
    if (z < r.min_base_z_m) {
      r.min_base_z_m = z;
      r.min_base_z_time_s = now - setup.replay_start_s;
    }
    r.max_tilt_rad = std::max(r.max_tilt_rad, tilt);
    if (r.fell_at_s < 0.0 && z < setup.fallen_below_m) r.fell_at_s = now - setup.replay_start_s;
    if (log != nullptr) {
      int worst = 0;
      const double worst_error = out.tracking_error.tail(info.nj).cwiseAbs().maxCoeff(&worst);
      std::fprintf(log, "%.3f %.4f %.4f %d %.4f %u %d %s %.4f", now, z, tilt, rt.stale() ? 1 : 0,
                   rt.lastReference().time_s, rt.status(), static_cast<int>(out.reseed_reason),
                   info.joint_names[static_cast<std::size_t>(worst)].c_str(), worst_error);
      if (const BalanceState* b = rt.filter().balance())
        std::fprintf(log, " %.4f %.4f %.4f %.4f %.4f %.4f %.3f %.3f %.3f %d", b->dcm.x(), b->dcm.y(),
                     b->dcm_desired.x(), b->dcm_desired.y(), b->cop_command.x(), b->cop_command.y(),
                     b->com_accel_desired.x(), b->com_accel_desired.y(), b->com_accel_desired.z(),
                     b->preview_samples);
      // The model's mismatch: the robot's acceleration over the step minus the filter's v̇.
      accel_mismatch = (robot->v() - v_before) / dt - out.vdot;
      int mismatch_joint = 0;
      const double joint_mismatch = accel_mismatch.tail(info.nj).cwiseAbs().maxCoeff(&mismatch_joint);
      std::fprintf(log, " %.3f %.3f %s %.3f", accel_mismatch.head<3>().norm(), accel_mismatch.segment<3>(3).norm(),
                   info.joint_names[static_cast<std::size_t>(mismatch_joint)].c_str(), joint_mismatch);
      std::fputc('\n', log);
    }
  }
  r.reseeds = rt.counters().reseeds;
  return r;
}

}  // namespace dynfilter::processes
