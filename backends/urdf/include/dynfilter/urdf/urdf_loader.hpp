#pragma once
/// @file
/// URDF loading with errors that name the file, the line, the element and the reason.

#include <string>

#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter::urdf {

/// Reads and parses a URDF file. Throws ModelError on a missing or unreadable file,
/// malformed XML, an unknown or unsupported element or joint type, a dangling link
/// reference, a non-tree structure, or a malformed number.
RobotDescription loadUrdfFile(const std::string& path);

/// Same as loadUrdfFile for a URDF held in memory; @p source_label names it in messages.
RobotDescription loadUrdfString(const std::string& xml, const std::string& source_label);

}  // namespace dynfilter::urdf
