#pragma once
// Reference motions for filter tests, made by the simulator mode (Eq. 14): physically
// consistent by construction for the model that made them.

#include <vector>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/reference_frame.hpp"

namespace dynfilter::test {

/// Pelvis height at which the human figure's soles touch level ground (models/*.json).
double humanFigureStandingHeight();

/// The human figure stands on level ground (soles 0.5 mm in) and follows, under joint PD
/// torques, a squat of up to 0.15 rad at the hips with swinging arms and a turning waist.
/// Frames are the simulator's states at dt spacing with the acceleration of Eq. 14 at each.
/// The simulation steps @p substeps times per frame: explicit joint PD on a floating
/// figure is stiff (a waist torque spins the light pelvis), so steps of 0.2 ms or less.
std::vector<ReferenceFrame> simulateStandingSway(IDynamicsModel& model, double seconds,
                                                 double dt, double squat_amplitude = 0.15,
                                                 double frequency_hz = 0.5, int substeps = 5);

/// Moves each frame's base so that the motion walks off along world x at @p speed_mps and
/// turns about the vertical through the first frame's base at @p turn_rate_radps, both from
/// the first frame's time (velocities unchanged: a reference the figure cannot follow).
void walkOffAndTurn(std::vector<ReferenceFrame>& frames, double speed_mps, double turn_rate_radps);

/// Two hinged boards (tests/models/hinged_plank.urdf, @p model) lying flat on level ground,
/// @p lying, and the same with board b raised 0.3 rad about the hinge, @p lifted: started
/// there and given @p lying, board b comes down beside board a (a landing whose two face
/// links' rows are dependent).
void hingedBoardsLyingAndLifted(IDynamicsModel& model, ReferenceFrame& lying, ReferenceFrame& lifted);

}  // namespace dynfilter::test
