#pragma once
/// @file
/// A motion made on level ground, carried onto a sloped plane (dynfilter-offline
/// --slope-deg): every frame's base and every foot rise or sink with the plane beneath them
/// — a vertical shear of the world, z' = z + h(x, y) − h(base at the first frame), h the
/// plane's height — and the feet turn with the plane (the rotation taking world up to its
/// normal), so that a sole flat on level ground lies flat on the slope and a swing foot keeps
/// its clearance above the ground beneath it. The legs reach the feet by PoseIk, every other
/// coordinate held at the sheared reference with the legs weighted 0.05 and the base 1 (it
/// gives way where a leg cannot reach: a stance leg straight on a downhill). Feet: the
/// bodies the model stands on at its neutral configuration on level ground (no link names).
///
/// Before, only the base moved with the plane: on a 10° slope a foot 30 cm ahead of the
/// base stayed 5 cm off the ground beneath it and every sole stayed level, its heel or toe
/// 2 cm into the slope.

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/environment.hpp"
#include "dynfilter/io/reference_motion.hpp"

namespace dynfilter::io {

struct TerrainFollowReport {
  int feet = 0;
  double foot_position_error_max_m = 0.0;       ///< largest IK miss of a foot target (m)
  double foot_orientation_error_max_rad = 0.0;  ///< largest IK miss of a foot orientation (rad)
  double joint_change_rms_rad = 0.0;            ///< the legs' change over all joints and frames
  double base_change_max_m = 0.0;  ///< largest move of the base from the sheared reference (m)
};

/// Carries @p motion (floating base, made on level ground) onto @p plane in place and
/// estimates its derivatives again. @p model: the robot on level ground (its environment is
/// not used; its state changes).
/// @throws std::invalid_argument if the model has no floating base or no body touches the
///         ground at its neutral configuration.
TerrainFollowReport followTerrain(ReferenceMotion& motion, IDynamicsModel& model, const GroundPlane& plane);

}  // namespace dynfilter::io
