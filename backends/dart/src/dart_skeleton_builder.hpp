#pragma once
// Internal: turns a RobotDescription / Environment into DART skeletons.

#include <unordered_map>
#include <vector>

#include <dart/dynamics/BodyNode.hpp>
#include <dart/dynamics/Skeleton.hpp>

#include "dynfilter/core/environment.hpp"
#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter::dart_backend {

/// Where a URDF link lives in the skeleton: links welded by fixed joints are lumped into
/// the nearest body with a moving (or root) joint, so they are a frame on that body.
struct LinkFrame {
  dart::dynamics::BodyNode* node = nullptr;
  Eigen::Isometry3d X_NL = Eigen::Isometry3d::Identity();  ///< link frame in the node frame
};

struct BuiltRobot {
  dart::dynamics::SkeletonPtr skeleton;
  std::vector<LinkFrame> links;  ///< by description link index
  /// The URDF link each collision ShapeNode came from.
  std::unordered_map<const dart::dynamics::ShapeFrame*, int> link_of_shape;
  /// dof_of_v[i]: DART generalized coordinate index of our velocity coordinate i (dim nv).
  std::vector<int> dof_of_v;
  /// Per DART dof: the velocity coordinate that drives it and how (dim ndofs). A mimic
  /// follower's dof is q_dof = factor · q_leader + offset; every other dof has factor 1
  /// and offset 0 and v_of_dof inverts dof_of_v.
  std::vector<int> v_of_dof;
  std::vector<double> factor_of_dof;
  std::vector<double> offset_of_dof;
  bool has_mimic = false;
};

/// One DART body per URDF link on a moving joint (plus the root), created parent-first;
/// fixed-joint links are lumped into their carrier (masses and inertias combined).
BuiltRobot buildRobotSkeleton(const urdf::RobotDescription& robot, bool floating_base);

/// Name of the ground slab's ShapeNode (the ground's plane shape is the other one).
inline constexpr const char* kGroundSlabShapeName = "ground_slab";

struct BuiltEnvironment {
  dart::dynamics::SkeletonPtr skeleton;
  /// object_of_body[k] = environment object index (kGroundObject or box index) of body k.
  std::vector<int> object_of_body;
};

/// A static skeleton: the ground (a slab for primitive shapes and a PlaneShape for
/// convex-hull meshes on one body) and one welded body per box.
BuiltEnvironment buildEnvironmentSkeleton(const Environment& environment);

}  // namespace dynfilter::dart_backend
