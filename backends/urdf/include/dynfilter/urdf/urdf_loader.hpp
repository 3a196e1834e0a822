#pragma once
/// @file
/// URDF loading with errors that name the file, the line, the element and the reason.

#include <string>
#include <vector>

#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter::urdf {

/// How a URDF is read beyond its own text.
struct UrdfLoadOptions {
  /// Directories searched for `package://NAME/...` mesh URIs: a directory is used when it
  /// is NAME itself or holds NAME. Searched before the entries of ROS_PACKAGE_PATH.
  std::vector<std::string> package_paths;
  /// Joints to weld (see lockJoints): an entry names a joint exactly or is a pattern with
  /// `*` and `?` wildcards; "name=value" locks at value (rad or m), otherwise at 0. A
  /// pattern that matches no joint is an error.
  std::vector<std::string> lock_joints;
};

/// Reads and parses a URDF file. Elements that do not change the dynamics (<gazebo>,
/// <transmission>, <sensor>, visuals, unknown extensions) are ignored and listed in
/// RobotDescription::ignored_elements. Collision meshes (STL, DAE, OBJ, anything assimp
/// reads; `package://`, `file://`, absolute or relative to the URDF) become convex hulls.
/// Throws ModelError on a missing or unreadable file or mesh, malformed XML, an
/// unsupported joint type, a dangling link or mimic reference, a non-tree structure, a
/// mirrored mesh scale, or a malformed number.
RobotDescription loadUrdfFile(const std::string& path, const UrdfLoadOptions& options = {});

/// Same as loadUrdfFile for a URDF held in memory; @p source_label names it in messages
/// and relative mesh paths are resolved against @p base_directory (default: the current
/// directory).
RobotDescription loadUrdfString(const std::string& xml, const std::string& source_label,
                                const UrdfLoadOptions& options = {},
                                const std::string& base_directory = "");

/// Parses the --lock-joints syntax against @p robot: entries separated by commas,
/// each "pattern" or "pattern=value". Throws ModelError when a pattern matches no joint.
std::vector<JointLock> resolveJointLocks(const RobotDescription& robot,
                                         const std::vector<std::string>& entries);

}  // namespace dynfilter::urdf
