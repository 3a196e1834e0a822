#pragma once
/// @file
/// Retargeting BVH motion capture onto any floating-base URDF model: a mapping file says
/// which BVH joint drives which model link, and retargetBvh() turns the clip into a
/// ReferenceMotion of the model. No link or joint name is known to the code: the joint
/// groups come from the model's kinematic tree (kinematicTreeOf, core) between mapped links.
///
/// Common to both modes (per frame):
///  - World rotations of the BVH joints (bvhForwardKinematics), converted to the model's
///    axes (Z up, X forward, Y left) by R_conv (rows: the BVH's forward, left and up axes).
///  - Every mapped segment s gets the world rotation R_s = R_conv · R_bvh(j_s) · C_s. The
///    calibration C_s = R_conv⁻¹ · A_s is fixed per clip from the BVH rest pose (all
///    rotations zero): A_s is the minimal rotation taking the model's bone direction of s
///    at q = 0 (`figure_bone`, link frame; default −z, a limb hanging down) onto the BVH's
///    rest bone (the offset from j_s to its bone end, converted). So a BVH whose rest
///    posture already has the model's bone directions maps its rest posture to q = 0, and a
///    T-pose rest maps to arms raised sideways. With `align: false` A_s = I (the BVH rest
///    orientation of the joint counts as the model's q = 0 orientation).
///    In the IK mode (whose targets are world orientations) C_s also carries the link's
///    own orientation at q = 0: a URDF whose link frames are turned at q = 0 (iCub's)
///    retargets as one whose frames are aligned. The chain mode decomposes R_P⁻¹ R_C into
///    axes of P's frame and needs frames aligned at q = 0.
///  - Hinge twist: the minimal rotation leaves a thigh's or upper arm's twist about its
///    bone arbitrary, so the BVH's knee / elbow may bend out of the model's hinge plane. A
///    segment with `flexion: [x, y, z]` (link frame: the direction into which its one mapped
///    child segment's bone deflects when the hinge flexes, e.g. knee −x, elbow +x) gets the
///    twist of A_s chosen so that the mean direction in which the child bone deflects from
///    the segment's bone over the whole clip becomes that direction; kept from the rest
///    pose when the mean deflection is below 10° or with `hinge_twist: false`.
///  - Soles (`flat_soles`, default true): a segment whose link the model stands on at its
///    neutral configuration (its sole touches the ground there) gets C_s turned by the
///    minimal rotation that levels the sole on average over the clip's stance frames —
///    where its BVH joint is within 3 cm of its lowest height and slower than 0.3 m/s (at
///    least 10 frames, else left as is). A skeleton's rest pose does not say where its feet
///    are flat: the CMU skeletons' retargeted soles stood rolled by 15–30°, which the
///    clean-up then had to take out of the legs. Reported in RetargetResult::soles.
///  - Base: position = mean of the BVH joints listed in `root.position` (e.g. the two hip
///    centres; default the root joint), converted, plus a vertical offset so that the
///    lowest point of the model over the first `ground_frames` frames touches the model's
///    environment (standingBaseHeight).
///
/// `mode: chain` (default; the per-chain decomposition): each mapped segment C and its
/// nearest mapped ancestor P form a joint group, the moving joints between them (at most
/// three, with axis-aligned axes in P's frame at q = 0). The relative rotation
/// R_P⁻¹ R_C is decomposed into the group's chain of axes: three axes by the Tait–Bryan
/// decomposition in chain order (intrinsic), two axes by the three-axis decomposition
/// completed with the missing axis (dropped) last or in the middle, whichever reproduces
/// the child's bone direction better, one axis by the least-squares angle about it.
/// Angles in [−π, π]; of the two three-axis solutions (α, β, γ) and (α + π, π − β, γ + π)
/// the one inside the joint limits is taken, or when both (or neither) are, the one nearer
/// to the previous frame (this keeps a shoulder on its limited branch through its Euler
/// singularity). Base orientation = that of the root segment.
///
/// `mode: ik`: per frame, targets for the mapped links — the point `offset_xyz` of link s
/// (link frame) at the BVH joint j_s's position, relative to the base position and scaled
/// to the robot (`ik.scale`; 0: auto, the ratio of the model's leg length to the BVH's:
/// the vertical distance from the base position point to the lowest mapped link at q = 0,
/// over the same distance between the corresponding BVH joints in the rest pose), and the
/// orientation R_s · R_offset (`offset_rpy`) — are met in the weighted least-squares sense
/// (`position_weight`, `orientation_weight`) within the joint limits by PoseIk (damped
/// least squares with bounds, warm-started from the previous frame), with the model's
/// Jacobians. The root link's target is the base pose itself. With `ik.scaling: limbs`
/// (default) the positions are placed limb by limb instead: a link's target is its limb's
/// anchor on the robot (the target of the mapped link above it when the BVH joint above
/// is that link's, else the robot's joint where the limb starts, e.g. the hip or shoulder
/// joint, as solved) plus the capture's bone from the BVH joint above, scaled by the ratio
/// of the robot's limb length to the capture's (at q = 0 and in the rest pose), so that a
/// robot of other proportions gets its limbs' directions; placed and solved twice per frame
/// (io/src/limb_scaling.hpp). Per-target errors and limb ratios are
/// reported (RetargetResult::targets). Stance feet are put on the ground by the clean-up
/// (reference_cleanup.hpp), which dynfilter-bvh2ref runs by default.
///
/// Joints of the model between no two mapped links are unmapped: an error unless
/// `allow_unmapped: true` (they are then held at their neutral value, 0 clamped into the
/// limits). Joints outside the model's limits are reported (JointLimitReport), and clamped
/// only with clamp_to_limits. Velocities and accelerations by estimateDerivatives().

#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/io/bvh.hpp"
#include "dynfilter/io/input_error.hpp"
#include "dynfilter/io/reference_cleanup.hpp"
#include "dynfilter/io/reference_motion.hpp"

namespace dynfilter::io {

/// One model link driven by one BVH joint.
struct RetargetSegment {
  std::string link;      ///< model link, e.g. "l_thigh"
  std::string bvh;       ///< BVH joint whose world rotation drives it, e.g. "LeftUpLeg"
  std::string bone_end;  ///< BVH joint (or "<name>_end" End Site) at the far end of the
                         ///< bone; empty: first descendant (first-child chain) with a
                         ///< nonzero OFFSET
  bool align = true;     ///< calibrate the rest bone direction (see file comment)
  bool hinge_twist = true;  ///< with has_flexion: twist about the bone from the hinge plane
                            ///< seen in the clip (see file comment)
  /// The model's bone direction at q = 0 (link frame, unit).
  Eigen::Vector3d figure_bone = -Eigen::Vector3d::UnitZ();
  bool has_flexion = false;
  /// Hinge: direction (link frame, unit) of the child segment's bone deflection on flexion.
  Eigen::Vector3d flexion = Eigen::Vector3d::Zero();
  /// IK: the point of the link at the BVH joint (link frame, m).
  Eigen::Vector3d offset_xyz = Eigen::Vector3d::Zero();
  /// IK: orientation target R_s · R_offset (R_offset from `offset_rpy`, URDF rpy, rad).
  Eigen::Matrix3d R_offset = Eigen::Matrix3d::Identity();
  double position_weight = 1.0;     ///< IK: weight of the position error (1/m)
  double orientation_weight = 0.0;  ///< IK: weight of the orientation error (1/rad)
  int line = 0;          ///< 1-based line in the mapping file
};

enum class RetargetMode { kChain, kIk };

/// IK mode settings (mapping key `ik`).
struct RetargetIkOptions {
  double scale = 0.0;          ///< BVH → robot length ratio; 0: auto (see file comment)
  /// `scaling: limbs` (default): each position target placed from its limb's anchor on the
  /// robot along the capture's bone scaled by the limb's length ratio (see file comment);
  /// `scaling: uniform`: the capture's positions scaled by `scale` about the world origin.
  bool limb_scaling = true;
  int max_iterations = 50;     ///< per frame
  double posture_weight = 0.01;  ///< pull of every joint towards its neutral value (1/rad)
};

/// A mapping file (YAML), e.g.
///
///     length_scale: 0.056444444
///     skip_frames: 1
///     up_axis: +y
///     bvh_forward: +z
///     root: {bvh: Hips, link: pelvis, position: [LeftUpLeg, RightUpLeg]}
///     segments:
///       - {link: l_thigh, bvh: LeftUpLeg, flexion: [-1, 0, 0]}
///       - {link: l_foot, bvh: LeftFoot, align: false, figure_bone: [1, 0, 0]}
///
/// Optional keys: `mode` (chain or ik), `ik: {scale, scaling, max_iterations, posture_weight}`,
/// `allow_unmapped` (false), `flat_soles` (true), `ground_frames` (default 30), `smoothing_window` (7),
/// `clamp_to_limits` (false), `cleanup` (ReferenceCleanupOptions, reference_cleanup.hpp);
/// `root.offset_xyz` (IK: the point of the root link at the base position); per segment
/// `bone_end`, `align`, `figure_bone: [x, y, z]`, `flexion: [x, y, z]`, `hinge_twist`,
/// `offset_xyz: [x, y, z]`, `offset_rpy: [r, p, y]`, `position_weight`,
/// `orientation_weight`.
struct RetargetMapping {
  std::string source;
  double length_scale = 1.0;  ///< BvhReadOptions::length_scale
  int skip_frames = 0;        ///< leading BVH frames dropped (T-pose, blend-in)
  std::string up_axis = "+y";      ///< the BVH axis that points up: ±x, ±y, ±z
  std::string bvh_forward = "+z";  ///< the BVH axis the figure's +X (forward) is
  std::string root_bvh = "Hips";
  std::string root_link = "pelvis";
  std::vector<std::string> root_position;  ///< BVH joints averaged for the base position
  Eigen::Vector3d root_offset_xyz = Eigen::Vector3d::Zero();  ///< IK (root link frame, m)
  std::vector<RetargetSegment> segments;
  RetargetMode mode = RetargetMode::kChain;
  RetargetIkOptions ik;
  bool allow_unmapped = false;
  ReferenceCleanupOptions cleanup;  ///< `cleanup` section (used by dynfilter-bvh2ref)
  int ground_frames = 30;     ///< frames over which the lowest point is put on the ground
  int smoothing_window = 7;   ///< for estimateDerivatives
  bool clamp_to_limits = false;
  /// Soles level in stance (see file comment); `flat_soles: false` keeps the rest-pose
  /// calibration of the feet.
  bool flat_soles = true;

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
  double excess_rms_rad = 0.0;    ///< RMS over frames of the distance beyond a limit
};

/// How well one IK target was met over the clip.
struct TargetReport {
  std::string link;
  double position_rms_m = 0.0, position_max_m = 0.0;
  double orientation_rms_rad = 0.0, orientation_max_rad = 0.0;
  bool has_position = false, has_orientation = false;
  bool limb_scaled = false;   ///< its position target placed by limb scaling
  double limb_ratio = 0.0;    ///< robot / capture limb length (also when out of range: kept uniform)
  std::string limb_from;      ///< BVH joint at the limb's anchor
};

/// The stance calibration of one sole segment (RetargetMapping::flat_soles).
struct SoleCalibration {
  std::string link;
  int stance_frames = 0;   ///< frames with its BVH joint low and still
  bool levelled = false;   ///< enough of them (≥ 10) to turn the calibration
  double angle_rad = 0.0;  ///< how far its calibration was turned
};

struct RetargetResult {
  ReferenceMotion motion;
  std::vector<JointLimitReport> limits;  ///< one per model joint, model order
  double ground_offset_m = 0.0;  ///< added to the converted BVH height of the base
  Eigen::Matrix3d axis_conversion = Eigen::Matrix3d::Identity();
  int first_bvh_frame = 0;   ///< BVH frame of output frame 0 (skip_frames, or a window's start)
  bool clamped = false;      ///< values were clamped into the limits
  std::vector<std::string> unmapped_joints;  ///< joints between no two mapped links
  std::vector<TargetReport> targets;  ///< IK mode: one per mapped link with a target
  double ik_scale = 1.0;              ///< IK mode: the length scale used
  std::vector<SoleCalibration> soles;  ///< with flat_soles: one per mapped sole link
};

/// Retargets @p bvh (read with mapping.length_scale, all frames kept) onto @p model (any
/// floating-base model; its kinematics are used in both modes). Changes the model's state.
/// @throws InputError naming the mapping file and line on a BVH joint or model link that
///         does not exist, on a link that is not below the root link, on joints left
///         unmapped (naming them) without allow_unmapped, and in chain mode on a group of
///         more than three joints or with axes that are not axis-aligned (use mode: ik);
///         std::invalid_argument when fewer than 2 frames remain.
RetargetResult retargetBvh(const BvhMotion& bvh, const RetargetMapping& mapping,
                           IDynamicsModel& model);

/// retargetBvh() of the window [@p start_s, @p end_s] (s) of @p bvh as a clip of its own:
/// bvhWindow() from the mapping's skip_frames, which the window replaces. What is calibrated
/// over a clip (ground offset, sole levelling) comes from the window's frames;
/// first_bvh_frame is the window's first frame in @p bvh. The default window, [0, ∞), is
/// retargetBvh() itself.
/// @throws as bvhWindow() and retargetBvh().
RetargetResult retargetBvhWindow(const BvhMotion& bvh, const RetargetMapping& mapping,
                                 IDynamicsModel& model, double start_s = 0.0,
                                 double end_s = std::numeric_limits<double>::infinity());

/// readBvh(path, {mapping.length_scale}) then retargetBvhWindow().
RetargetResult retargetBvhFile(const std::string& bvh_path, const RetargetMapping& mapping,
                               IDynamicsModel& model, double start_s = 0.0,
                               double end_s = std::numeric_limits<double>::infinity());

/// Writes a reference motion CSV (README "Reference motion file"): time, base pose and
/// joint positions, %.17g. @throws InputError when the file cannot be written.
void writeReferenceMotionCsv(const std::string& path, const ModelInfo& info,
                             const ReferenceMotion& motion);

/// Human-readable limit report: one line per joint outside its limits, then a summary.
std::string formatLimitReport(const RetargetResult& result);

/// Human-readable IK target report: per link position / orientation RMS and max.
std::string formatTargetReport(const RetargetResult& result);

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
