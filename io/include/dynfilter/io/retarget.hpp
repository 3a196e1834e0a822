#pragma once
/// @file
/// Retargeting BVH motion capture onto the human figure (models/human_figure.urdf): a
/// mapping file says which BVH joint drives which figure link, and retargetBvh() turns the
/// clip into a ReferenceMotion of the figure.
///
/// Method (per frame):
///  - World rotations of the BVH joints (bvhForwardKinematics), converted to the figure's
///    axes (Z up, X forward, Y left) by R_conv (rows: the BVH's forward, left and up axes).
///  - Every mapped segment s gets the world rotation R_s = R_conv · R_bvh(j_s) · C_s. The
///    calibration C_s = R_conv⁻¹ · A_s is fixed per clip from the BVH rest pose (all
///    rotations zero): A_s is the minimal rotation taking the figure's bone direction of s
///    at q = 0 (−z for limbs, +x for the foot, +z for torso and head) onto the BVH's rest
///    bone (the offset from j_s to its bone end, converted). So a BVH whose rest posture
///    already has the figure's bone directions maps its rest posture to q = 0, and a T-pose
///    rest maps to arms raised sideways. With `align: false` A_s = I (the BVH rest
///    orientation of the joint counts as the figure's q = 0 orientation).
///  - Hinge twist: the minimal rotation leaves a thigh's or upper arm's twist about its
///    bone arbitrary, so the BVH's knee / elbow may bend out of the figure's hinge plane.
///    With `hinge_twist` (default) the twist of A_s is chosen instead so that the mean
///    direction in which the child bone (shank, forearm) deflects from the parent's bone
///    over the whole clip becomes the figure's flexion direction (knee −x, elbow +x); kept
///    from the rest pose when the mean deflection is below 10°.
///  - Each joint group of the figure (waist, neck, hips, knees, ankles, shoulders, elbow +
///    forearm yaw, wrists) gets the relative rotation R_parent⁻¹ R_child of its two
///    segments, decomposed into the group's chain of axes (read from the model): three axes
///    by the Tait–Bryan decomposition in chain order (intrinsic), two axes by the
///    three-axis decomposition completed with the missing axis (dropped) last or in the
///    middle, whichever reproduces the child's bone direction better (for elbow + forearm
///    yaw: the hinge angle of the forearm direction projected on the hinge plane, the
///    remaining twist as forearm yaw), one axis by
///    the least-squares angle about it. Angles in [−π, π]; of the two three-axis solutions
///    (α, β, γ) and (α + π, π − β, γ + π) the one nearer to the previous frame is taken.
///  - Base: position = mid-point of the BVH joints driving l_thigh and r_thigh (hip
///    centres; the root joint when they are not mapped), converted, plus a vertical offset
///    so that the lowest point of the figure over the first `ground_frames` frames touches
///    the model's environment (standingBaseHeight); orientation = that of the root segment.
///  - Joints outside the model's limits are reported (JointLimitReport), and clamped only
///    with clamp_to_limits. Velocities and accelerations by estimateDerivatives().

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/io/bvh.hpp"
#include "dynfilter/io/input_error.hpp"
#include "dynfilter/io/reference_motion.hpp"

namespace dynfilter::io {

/// One figure link driven by one BVH joint.
struct RetargetSegment {
  std::string link;      ///< figure link, e.g. "l_thigh"
  std::string bvh;       ///< BVH joint whose world rotation drives it, e.g. "LeftUpLeg"
  std::string bone_end;  ///< BVH joint (or "<name>_end" End Site) at the far end of the
                         ///< bone; empty: first descendant (first-child chain) with a
                         ///< nonzero OFFSET
  bool align = true;     ///< calibrate the rest bone direction (see file comment)
  bool hinge_twist = true;  ///< thighs and upper arms: twist about the bone from the knee /
                            ///< elbow hinge plane seen in the clip (see file comment)
  bool has_figure_bone = false;
  Eigen::Vector3d figure_bone = Eigen::Vector3d::Zero();  ///< override of the figure's
                                                          ///< bone direction (link frame)
  int line = 0;          ///< 1-based line in the mapping file
};

/// A mapping file (YAML), e.g.
///
///     length_scale: 0.056444444
///     skip_frames: 1
///     up_axis: +y
///     bvh_forward: +z
///     root: {bvh: Hips, link: pelvis}
///     segments:
///       - {link: l_thigh, bvh: LeftUpLeg}
///       - {link: l_foot, bvh: LeftFoot, align: false}
///
/// Optional keys: `ground_frames` (default 30), `smoothing_window` (7),
/// `clamp_to_limits` (false); per segment `bone_end`, `align`, `figure_bone: [x, y, z]`.
struct RetargetMapping {
  std::string source;
  double length_scale = 1.0;  ///< BvhReadOptions::length_scale
  int skip_frames = 0;        ///< leading BVH frames dropped (T-pose, blend-in)
  std::string up_axis = "+y";      ///< the BVH axis that points up: ±x, ±y, ±z
  std::string bvh_forward = "+z";  ///< the BVH axis the figure's +X (forward) is
  std::string root_bvh = "Hips";
  std::string root_link = "pelvis";
  std::vector<RetargetSegment> segments;
  int ground_frames = 30;     ///< frames over which the lowest point is put on the ground
  int smoothing_window = 7;   ///< for estimateDerivatives
  bool clamp_to_limits = false;

  /// R_conv: v_figure = R_conv · v_bvh. @throws std::invalid_argument on bad axes.
  Eigen::Matrix3d axisConversion() const;
};

/// Parses a mapping. @throws InputError (file, 1-based line and column, reason).
RetargetMapping parseRetargetMapping(const std::string& yaml_text, const std::string& source);
/// Reads a mapping file. @throws InputError (line 0 when the file cannot be read).
RetargetMapping readRetargetMapping(const std::string& path);

/// Limit check of one joint over the retargeted frames.
struct JointLimitReport {
  std::string joint;
  int frames_outside = 0;
  double fraction_outside = 0.0;  ///< frames_outside / frames
  double worst_excess_rad = 0.0;  ///< largest distance beyond a limit (0 when none)
  int worst_frame = -1;           ///< output frame index of the worst excess
  double min_rad = 0.0, max_rad = 0.0;  ///< range of the retargeted angle
};

struct RetargetResult {
  ReferenceMotion motion;
  std::vector<JointLimitReport> limits;  ///< one per model joint, model order
  double ground_offset_m = 0.0;  ///< added to the converted BVH height of the base
  Eigen::Matrix3d axis_conversion = Eigen::Matrix3d::Identity();
  int first_bvh_frame = 0;   ///< BVH frame of output frame 0 (= skip_frames)
  bool clamped = false;      ///< values were clamped into the limits
  std::vector<std::string> unmapped_joints;  ///< joints left at 0 (segment not mapped)
};

/// Retargets @p bvh (read with mapping.length_scale, all frames kept) onto @p model (the
/// human figure or a model with its link and joint names). Changes the model's state.
/// @throws InputError naming the mapping file and line on a BVH joint or figure link that
///         does not exist; std::invalid_argument when fewer than 2 frames remain.
RetargetResult retargetBvh(const BvhMotion& bvh, const RetargetMapping& mapping,
                           IDynamicsModel& model);

/// readBvh(path, {mapping.length_scale}) then retargetBvh().
RetargetResult retargetBvhFile(const std::string& bvh_path, const RetargetMapping& mapping,
                               IDynamicsModel& model);

/// Writes a reference motion CSV (README "Reference motion file"): time, base pose and
/// joint positions, %.17g. @throws InputError when the file cannot be written.
void writeReferenceMotionCsv(const std::string& path, const ModelInfo& info,
                             const ReferenceMotion& motion);

/// Human-readable limit report: one line per joint outside its limits, then a summary.
std::string formatLimitReport(const RetargetResult& result);

/// Angles θ of R = R_{a0}(θ0) · R_{a1}(θ1) · R_{a2}(θ2) for 1 to 3 distinct axis-aligned
/// unit axes (±x, ±y, ±z). Three axes: Tait–Bryan, middle angle in [−π/2, π/2]. Two axes:
/// the three-axis decomposition with the missing axis c inserted at @p missing_at (2: last,
/// (a0, a1, c); 1: middle, (a0, c, a1)) and its angle dropped; exact when R has no
/// component about c. One axis: the least-squares angle about it.
/// @throws std::invalid_argument on axes that are not axis-aligned or repeat.
std::vector<double> decomposeRotation(const Eigen::Matrix3d& R,
                                      const std::vector<Eigen::Vector3d>& axes,
                                      int missing_at = 2);

}  // namespace dynfilter::io
