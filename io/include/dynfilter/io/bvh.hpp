#pragma once
/// @file
/// Reading motion capture in the BVH (Biovision Hierarchy) format, and its forward
/// kinematics. The reader keeps the file's skeleton, axes (Y up in the usual exports) and
/// channel layout; mapping it onto a robot model is a separate step (retargeting).
///
/// Format, as read here (keywords are case-sensitive):
///
///     HIERARCHY
///     ROOT <name>
///     {
///       OFFSET x y z
///       CHANNELS n <channel>...       (Xposition Yposition Zposition Xrotation ...)
///       JOINT <name> { OFFSET ... CHANNELS ... <JOINT or End Site blocks> }
///       End Site { OFFSET x y z }
///     }
///     MOTION
///     Frames: <count>
///     Frame Time: <seconds>
///     <count lines of channel values, in the order the CHANNELS statements appear>
///
/// Lines may end in LF or CRLF (mixed within one file too); tokens are separated by spaces
/// or tabs. A joint's name is the rest of its ROOT/JOINT line ("{" may end that line). Every
/// block has one OFFSET; a ROOT/JOINT has at most one CHANNELS (none: no channels). They may
/// come in either order, before or after the child blocks; the channel columns of the frame
/// lines follow the textual order of the CHANNELS statements (the hierarchy order in every
/// common exporter). Several ROOT blocks are accepted.
///
/// Semantics of the channels (see bvhForwardKinematics()):
///  - Rotation channels compose in the order listed: `CHANNELS 3 Zrotation Xrotation
///    Yrotation` with values (z, x, y) gives R = Rz(z) · Rx(x) · Ry(y), elementary
///    rotations about the coordinate axes, angles in degrees (intrinsic: z first, then x
///    about the rotated X axis, then y).
///  - Position channels may appear on any joint. When a joint has at least one, the
///    channel values REPLACE its OFFSET as the translation from the parent: the translation
///    is (Xposition, Yposition, Zposition) with an axis that has no channel taken as 0
///    (not as the OFFSET's value). Without position channels the OFFSET is the translation.
///  - The local transform of a joint is translation then rotation: X_parent_joint =
///    [R | t]; an End Site has the identity rotation and its OFFSET as translation.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/io/input_error.hpp"

namespace dynfilter::io {

/// One channel of a BVH joint.
enum class BvhChannel { kXposition, kYposition, kZposition, kXrotation, kYrotation, kZrotation };

/// The channel's name as written in a BVH file ("Xposition", ..., "Zrotation").
const char* bvhChannelName(BvhChannel channel);
/// Whether @p channel is one of Xposition, Yposition, Zposition.
bool isBvhPositionChannel(BvhChannel channel);

/// A joint (or End Site) of the BVH hierarchy.
struct BvhJoint {
  std::string name;  ///< as in the file; an End Site is named "<parent name>_end"
  int parent = -1;   ///< index in BvhMotion::joints, −1 for a ROOT
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< OFFSET × length_scale, parent axes
  std::vector<BvhChannel> channels;                  ///< in the order listed in the file
  bool end_site = false;  ///< an End Site block (no channels, no children)
  int first_channel = 0;  ///< column of channels[0] in BvhMotion::frames
  int line = 0;           ///< 1-based line of the ROOT / JOINT / End Site keyword

  /// Whether any of the channels is a position channel (they then replace offset).
  bool hasPositionChannels() const;
};

/// A BVH file as read.
struct BvhMotion {
  std::string source;             ///< the path it was read from
  std::vector<BvhJoint> joints;   ///< hierarchy (file) order, a parent before its children;
                                  ///< End Sites included as joints with end_site = true
  double frame_time_s = 0.0;      ///< "Frame Time:", > 0
  Eigen::MatrixXd frames;         ///< frames × channels, columns as in the file; position
                                  ///< channels × length_scale, rotations in degrees
  int skipped_frames = 0;         ///< leading frames of the file not in frames

  int frameCount() const { return static_cast<int>(frames.rows()); }
  int channelCount() const { return static_cast<int>(frames.cols()); }
  /// (frameCount() − 1) × frame_time_s: the time from the first to the last frame kept.
  double durationS() const;
  /// Index of the joint called @p name, −1 when there is none.
  int findJoint(const std::string& name) const;
};

struct BvhReadOptions {
  /// Multiplies OFFSETs and position channels, e.g. 0.01 for centimetres → metres,
  /// 0.0254 for inches → metres, 0.0254 / 0.45 for the CMU database's own unit. > 0.
  double length_scale = 1.0;
  /// Drop the file's first frame (e.g. a T-pose that is not part of the motion).
  bool skip_first_frame = false;
  /// Drop the first frame when it is a rest pose (T-pose) put in front of the motion by
  /// the conversion: its rotations are all about 0 (root-mean-square over the rotation
  /// channels at most kBvhRestPoseRmsDeg; some conversions keep a few fixed angles in
  /// their T-pose) while frame 1 is not at rest but already in the captured motion (some
  /// rotation channel differs from frame 0 by at least kBvhRestPoseJumpDeg, a step no
  /// captured joint makes in one frame). Needs ≥ 2 frames; nothing more is dropped when
  /// skip_first_frame already drops the frame. After a rest pose so dropped, the frames a
  /// conversion blends from it into the motion go too: from frame 1 on, each frame whose
  /// largest rotation step to the next exceeds kBvhBlendStepFactor × the clip's median
  /// step, within kBvhBlendMaxS (CMU's DAZ-friendly conversions blend over 4 frames).
  bool detect_t_pose = false;

  /// Throws std::invalid_argument on a length_scale that is not finite and positive.
  void validate() const;
};

/// detect_t_pose: largest root-mean-square (degrees, over all rotation channels) of a
/// rest-pose frame 0.
inline constexpr double kBvhRestPoseRmsDeg = 5.0;
/// detect_t_pose: smallest change (degrees, the shorter way round) of some rotation
/// channel from frame 0 to frame 1 for frame 0 to count as put in front of the motion.
inline constexpr double kBvhRestPoseJumpDeg = 10.0;
/// detect_t_pose: a frame after the rest pose is part of the blend into the motion while
/// its step to the next frame exceeds this many times the clip's median step.
inline constexpr double kBvhBlendStepFactor = 3.0;
/// detect_t_pose: the blend into the motion ends within this time of frame 1 (s).
inline constexpr double kBvhBlendMaxS = 0.25;

/// Reads a BVH file.
///
/// @throws InputError naming the file, the 1-based line and reason on any violation of the
///         format: missing file (line 0), missing HIERARCHY or MOTION, unknown or duplicate
///         channel, CHANNELS count not matching the names that follow, unbalanced braces, a
///         frame line with the wrong number of values, a value that is not a finite number,
///         fewer (or more) frame lines than "Frames:" says, "Frame Time:" ≤ 0. The column
///         is the 1-based value index on a frame line, the 1-based character column of the
///         offending word in the header, and 0 where no single word is at fault.
/// @throws std::invalid_argument on invalid @p options.
BvhMotion readBvh(const std::string& path, const BvhReadOptions& options = {});

/// The part of @p bvh from @p start_s to @p end_s (s, both included), on the clock of its
/// frames from @p first_frame on (that frame at 0 s, e.g. a mapping's skip_frames): the
/// frames whose times lie in the window; end_s = infinity: to the last frame. The frames
/// before the window count in skipped_frames.
/// @throws std::invalid_argument when first_frame is not a frame of @p bvh, start_s < 0 or
///         not finite, end_s ≤ start_s, or the window holds fewer than two frames; the
///         message gives the window and the clip's duration.
BvhMotion bvhWindow(const BvhMotion& bvh, int first_frame, double start_s, double end_s);

/// Global (world) pose of every joint at frame @p frame, in the BVH's own axes (Y up in the
/// usual exports), lengths after scaling: X_world[j] maps joint j's frame to the world, its
/// translation is the joint's position and its linear part the joint's rotation matrix.
/// X_world[j] = X_world[parent] · [R_j | t_j] with R_j and t_j as in the file comment.
/// @p X_world is resized to joints.size() (reused without allocating when already sized).
/// @throws std::out_of_range when @p frame is not in [0, frameCount()).
void bvhForwardKinematics(const BvhMotion& motion, int frame,
                          std::vector<Eigen::Isometry3d>& X_world);

}  // namespace dynfilter::io
