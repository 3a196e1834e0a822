#pragma once
// How dynfilter-sim runs an engine as the robot standing on its own feet, with the filter
// closing the loop on its measured state (README, "Standing balance, closed loop"). Shared
// with tests/filter/closed_loop_test.cpp, which checks these settings.
//
// DART (6.12: Bullet collision, boxed-LCP contacts): with one 1 ms step per tick and its
// default contact constraint (CFM 1e-5) the feet rock — one-tick base-acceleration jumps
// of ~10 m/s² at constant torque — and the robot falls within 1 s. Each of two changes
// alone keeps it standing and squatting with the filter (measured on the 4 s squat, QP
// mode: base within 0.4 mm, joints within 2.0e-3 rad, as on ODE): a softer contact (CFM
// 1e-3; 1e-4, 3e-4 and 1e-2 all fell), or four 0.25 ms substeps per tick (two fell). The
// softer contact is the choice: four DART steps a tick cost too much for 1 kHz on a shared
// core (over LCM the simulator then missed ticks and the robot fell after ~10 s; with one
// step and CFM 1e-3: 0 missed ticks, no failed filter tick). ODE's engine needs neither.
#include <string>

#include <dart/constraint/ContactConstraint.hpp>

namespace dynfilter::processes {

struct RobotEngineSettings {
  int substeps = 1;  ///< engine steps per control tick (each dt / substeps)
};

inline constexpr double kDartRobotContactCfm = 1e-3;

/// The settings for @p backend ("dart" or "ode") as the robot. For DART also applies its
/// contact softness, which DART keeps process-wide (ContactConstraint's static CFM).
inline RobotEngineSettings useAsRobot(const std::string& backend) {
  RobotEngineSettings s;
  if (backend == "dart")
    dart::constraint::ContactConstraint::setConstraintForceMixing(kDartRobotContactCfm);
  return s;
}

}  // namespace dynfilter::processes
