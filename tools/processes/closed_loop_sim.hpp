#pragma once
// The LCM closed loop (dynfilter --mode qp --use-measured-state, dynfilter-sim
// --servo-error-rad 0, dynfilter-replay) in one process and deterministic: the transport
// is replaced by a schedule. Used by dynfilter-closed-loop and tests/realtime.
//
// Timeline (local clock = the sender's, 1 ms ticks): the filter holds the standing pose;
// the robot (ODE's or DART's engine, robot_engine.hpp) starts standing there; from
// replay_start_s the player sends frames at the clip's rate, stamped when sent; a sender
// that is descheduled (gap_s every gap_every_s) skips frames as dynfilter-replay's ticker
// does. Every tick: frames received so far enter the filter, then the robot's state, then
// the filter ticks and the robot applies the command for one step (the next state answers
// it), as over LCM.
#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/realtime/realtime_filter.hpp"
#include "dynfilter/realtime/replay_player.hpp"
#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter::processes {

struct ClosedLoopSetup {
  std::string robot_engine = "ode";  ///< "ode" or "dart" (the plan runs on DART)
  FilterOptions filter;              ///< mode etc. (the dynfilter process: its config)
  realtime::RealtimeOptions realtime;  ///< use_measured_state is set
  realtime::ReplayOptions replay;
  double replay_start_s = 0.5;  ///< local time of the first frame sent
  double seconds = 4.0;         ///< simulated after the replay starts
  /// The sender is descheduled for gap_s every gap_every_s from gap_first_s after the
  /// replay starts (0: never).
  double gap_every_s = 0.0, gap_s = 0.0, gap_first_s = 0.0;
  /// The robot's process stalls with the sender (its CPU frozen, as a virtual CPU can be):
  /// during a gap the robot neither steps nor sends its state; the filter ticks on.
  bool gap_stalls_robot = false;
  /// The robot's states are held back for state_delay_s from state_delay_at_s after the
  /// replay starts (the robot steps on with the filter's commands) and then arrive together,
  /// as a socket's backlog does after its reader was descheduled (0: never).
  double state_delay_s = 0.0, state_delay_at_s = 0.0;
  /// Base height (m) below which the robot counts as fallen.
  double fallen_below_m = 0.5;
};

struct ClosedLoopResult {
  int ticks = 0;
  double min_base_z_m = 1e9, min_base_z_time_s = 0.0;
  double max_tilt_rad = 0.0;     ///< base tilt from upright (rad)
  double fell_at_s = -1.0;       ///< first time (s after the replay start) below fallen_below_m
  /// Time (s after the replay start) at which the robot's engine refused a step (a diverged
  /// simulation: runaway velocity); the run ends there. Negative when it never did.
  double engine_refused_at_s = -1.0;
  std::string engine_error;      ///< the engine's message then
  std::uint64_t reseeds = 0;
  /// Re-seeding ticks by ReseedReason (index = the enum's value, 0 unused).
  std::array<std::uint64_t, 7> reseed_ticks_by_reason{};
  std::uint32_t status_union = 0;
  std::uint64_t frames_sent = 0;
};

/// Runs the loop. @p log (may be null) gets one line a tick: time (s, local), base z (m),
/// tilt (rad), stale, reference time (s, sender), status, reseed reason, worst joint and
/// its tracking error (rad), with the balance layer dcm, dcm_desired, cop_command (x y
/// each, m), c̈_d (x y z, m/s²), preview samples, and last the model's mismatch: the robot's
/// acceleration over the step minus the filter's v̇, as |base linear| (m/s²), |base
/// angular| (rad/s²), the joint with the largest |difference| and that value (rad/s² or
/// m/s²). Throws on a bad setup.
ClosedLoopResult runClosedLoop(const urdf::RobotDescription& robot, const ClosedLoopSetup& setup,
                               const std::vector<realtime::Clip>& clips, std::FILE* log = nullptr);

}  // namespace dynfilter::processes
