#pragma once
// IK retargeting with limb scaling (mapping key `ik.scaling: limbs`): a mapped link's
// position target is placed from its limb's anchor on the robot along the capture's bone,
// scaled by the ratio of the robot's limb length to the capture's, instead of the
// capture's position scaled by one factor about the base. A robot with a longer forearm or
// narrower shoulders than the captured person then gets targets it can reach with the
// capture's limb directions.
//
// The anchor of segment c is found from the BVH hierarchy: its BVH joint's parent j_a.
//  - When j_a is the BVH joint of c's nearest mapped ancestor segment P (a wrist below a
//    mapped elbow), the anchor is P's point: its target when P has a position target (the
//    root's is the base position point), else where P's point is in the current solve.
//  - Otherwise (a knee below an unmapped hip, an elbow below an unmapped shoulder), the
//    anchor is the robot's pivot of that limb, where it is in the current solve: the point
//    where the axes of the last joints between P and c that move c's point meet (taken from
//    the last one back while they meet within 2 cm: a hip's or shoulder's pitch and roll),
//    fixed in the body the earliest of them moves; with one such axis, its joint's origin.
// Ratio = |p_c − p_anchor| of the model at its neutral configuration over the same distance
// between the BVH joints in the rest pose. A ratio outside [0.5, 2] × the uniform scale is
// taken for a wrong correspondence (e.g. a wrist mapped without its elbow): that segment
// keeps the uniform scaling and the report says so.
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/kinematic_tree.hpp"
#include "dynfilter/io/bvh.hpp"
#include "dynfilter/io/pose_ik.hpp"

namespace dynfilter::io::detail {

/// What the limb scaling needs of one mapped segment (index 0: the root).
struct LimbSegment {
  int bvh_joint = -1;
  int body = -1;
  int parent = -1;                     ///< nearest mapped ancestor segment, −1 for the root
  std::vector<int> joints;             ///< moving joints from the parent's body to this one
  Eigen::Vector3d p_BP = Eigen::Vector3d::Zero();  ///< the target point in the body frame
  bool has_position = false;
};

/// Where one segment's position target is anchored (see file comment).
struct LimbAnchor {
  int segment = -1;     ///< anchored on this segment's point, or
  int joint_body = -1;  ///< on the limb's pivot, fixed in this body; both −1: uniform
  Eigen::Vector3d p_BA = Eigen::Vector3d::Zero();  ///< the pivot in joint_body's frame (m)
  int bvh_joint = -1;   ///< the BVH joint at the anchor; −1: the base position point
  double ratio = 0.0;   ///< robot limb length / capture limb length
  std::string bvh_name; ///< for the report
};

/// Anchors and ratios, one per segment (the root's: uniform). @p rest: BVH joint positions
/// in the rest pose (BVH axes); @p rest_base: the base position point there; @p model at
/// any state (changed: set to @p q0). Order of placement: every anchor segment before the
/// segments anchored on it (@p order).
std::vector<LimbAnchor> findLimbAnchors(const std::vector<LimbSegment>& segments,
                                        const BvhMotion& bvh,
                                        const std::vector<Eigen::Vector3d>& rest,
                                        const Eigen::Vector3d& rest_base,
                                        const Eigen::Matrix3d& R_conv, double uniform_scale,
                                        const KinematicTree& tree, IDynamicsModel& model,
                                        const Eigen::VectorXd& q0, std::vector<std::size_t>& order);

/// Sets targets[c].p_WP of every anchored segment from the model's current state (its
/// limbs' pivots and the points of segments without a position target) and the frame's
/// BVH joint poses @p X (BVH world), with @p base_bvh the frame's base position point (BVH
/// world). Segments without an anchor keep their targets.
void placeLimbTargets(const std::vector<LimbSegment>& segments,
                      const std::vector<LimbAnchor>& anchors, const std::vector<std::size_t>& order,
                      const std::vector<Eigen::Isometry3d>& X, const Eigen::Vector3d& base_bvh,
                      const Eigen::Matrix3d& R_conv, const IDynamicsModel& model,
                      std::vector<IkTarget>& targets);

}  // namespace dynfilter::io::detail
