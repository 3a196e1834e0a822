#pragma once
/// @file
/// The filter's configuration file (YAML): FilterOptions and the Environment.
///
/// The layout mirrors the structs' field names (snake_case), every key optional with the
/// struct's default; tools/config/default.yaml lists every key with its default and unit:
///
/// ```yaml
/// dt_s: 0.001
/// feedback: {base_linear_kp, base_linear_kd, base_angular_kp, base_angular_kd, joint_kp, joint_kd}
/// task: {enabled, body, p_BP: [x, y, z], kp_linear, kd_linear, kp_angular, kd_angular, joint_weight}
/// contacts: {max_links, stabilization_kp, stabilization_kd, merge_distance_m,
///            release_force_n, release_ticks, reengage_depth_m, plastic_impact}
/// solver: {accel_weight, force_weight, sr_damping}
/// divergence: {max_base_error_m: 0.5}
/// environment:
///   ground: {slope_deg, heading_deg, height_m, friction}   # or: ground: none
///   boxes: [{name, size_m: [x, y, z], position_m: [x, y, z], rpy_deg: [r, p, y], friction}]
/// ```
///
/// The ground is GroundPlane::sloped(slope, heading, height, friction) with the angles in
/// degrees. A box's orientation R_WO = Rz(yaw) Ry(pitch) Rx(roll) (URDF's rpy, fixed axes
/// x, then y, then z), its position the centre in world (m); size_m are full edge lengths.

#include <string>

#include "dynfilter/core/environment.hpp"
#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/io/input_error.hpp"

namespace dynfilter::io {

struct FilterConfig {
  FilterOptions filter;
  Environment environment;
};

/// Reads and validates a configuration file.
/// @throws InputError `<file>:<line>:<column>: <key path>: <reason>` on a YAML syntax error,
///         an unknown or duplicate key (e.g. `feedback.joint_kpp`), a wrong type or vector
///         length, or a value rejected by FilterOptions::validate / Environment::validate
///         (located at the offending key when it can be identified); `<file>: ...` when
///         the file cannot be read.
FilterConfig loadFilterConfig(const std::string& yaml_path);

/// Same for YAML text in memory; @p source_label stands for the file name in errors.
FilterConfig parseFilterConfig(const std::string& yaml_text, const std::string& source_label);

}  // namespace dynfilter::io
