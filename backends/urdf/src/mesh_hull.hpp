#pragma once
// Internal: collision meshes → convex hulls, and mesh URI resolution.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter::urdf {

/// Resolves a URDF mesh URI to an existing file: `package://NAME/rest` through
/// @p package_paths, then ROS_PACKAGE_PATH (a directory that is NAME or holds NAME), then
/// the folders above @p base_directory (one that is NAME or holds NAME),
/// `file:///abs`, an absolute path, or a path relative to @p base_directory. Throws
/// std::runtime_error naming the URI and the places searched when no file exists.
std::string resolveMeshUri(const std::string& uri, const std::string& base_directory,
                           const std::vector<std::string>& package_paths);

/// Reads every vertex of the mesh file (assimp: STL, DAE, OBJ, ...), scales it
/// componentwise by @p scale, and returns the convex hull (Bullet's btConvexHullComputer)
/// with its faces and outward planes. Hull vertices are input vertices as assimp reads
/// them (single precision).
/// Throws std::runtime_error on an unreadable file, no vertices, or a flat (degenerate)
/// hull.
ConvexHull convexHullOfMesh(const std::string& path, const Eigen::Vector3d& scale);

}  // namespace dynfilter::urdf
