#pragma once
/// @file
/// The kinematic tree of a model, found from its own kinematics (which bodies move when
/// one joint moves), so that code above core can walk the tree of any URDF without names.

#include <vector>

#include "dynfilter/core/dynamics_model.hpp"

namespace dynfilter {

/// Joints a chain needs from the base to orient and place a body freely (a leg with an
/// ankle roll has six; one without has five and cannot lay its sole flat everywhere).
inline constexpr int kJointsToPoseFreely = 6;

/// Tree of the moving joints and the bodies they carry. Bodies rigidly attached to one
/// another (URDF fixed joints) share their parent joint.
struct KinematicTree {
  /// dim number of bodies: the deepest joint that moves body b, −1 for the bodies rigid
  /// with the base (or with the world of a fixed-base model).
  std::vector<int> body_parent_joint;
  /// dim nj: the joint whose motion carries joint j, −1 for joints on the base.
  std::vector<int> joint_parent_joint;
  /// dim nj: the body that joint j moves directly (its URDF child link: of the bodies
  /// rigid with it, the one whose origin the joint's motion leaves in place, first in file
  /// order among equals).
  std::vector<int> joint_child_body;
  /// dim nj: number of bodies that joint j moves.
  std::vector<int> joint_subtree_size;
  /// The floating base body (the body whose pose is q's base pose), −1 for a fixed base.
  int base_body = -1;

  /// Whether joint @p j moves body @p b.
  bool moves(int j, int b) const;
  /// Moving joints between @p ancestor and @p body (those that move @p body but not
  /// @p ancestor), root to leaf. Empty when both are rigid with one another.
  /// @throws std::invalid_argument when @p ancestor is not an ancestor of (or rigid with)
  ///         @p body.
  std::vector<int> jointsBetween(int ancestor, int body) const;
  /// Whether @p ancestor is @p body, rigid with it, or on its path to the root.
  bool isAncestorOrRigid(int ancestor, int body) const;
  /// Whether the joints between the base and @p body number kJointsToPoseFreely or more.
  bool posesFreely(int body) const;
};

/// Finds the tree of @p model by moving one joint at a time from the neutral
/// configuration (each by 0.1 rad or m, inside its limits) and seeing which body poses
/// change. Changes the model's state.
KinematicTree kinematicTreeOf(IDynamicsModel& model);

/// The trunk body of a floating-base humanoid, by structure (no names): on the path from
/// the base towards the body highest above the base origin at the neutral configuration,
/// the first body after the base that carries two or more joint chains (e.g. a torso that
/// carries the arms and the neck); the base itself when the path has no such body (a
/// robot whose arms are on its base). For a fixed-base model: the child body of the last
/// joint of the longest chain. Changes the model's state.
int chooseTrunkBody(IDynamicsModel& model);

/// What a joint moves, by structure: for reports that group tracking errors.
enum class JointGroup : int { kSpine = 0, kLeg = 1, kArm = 2, kOther = 3 };
/// "spine", "legs", "arms", "other": static strings.
const char* toString(JointGroup group);

/// Groups the joints of a floating-base model by structure (no names), at its neutral
/// configuration (URDF convention: x forward, y left, z up). The spine is the path from the
/// base to the trunk (chooseTrunkBody). Every other joint belongs to the limb that leaves
/// that path where its chain does. A limb is a leg when its lowest body origin is within a
/// quarter of the model's height (highest minus lowest body origin) of the lowest; else
/// part of the spine when it leaves on the midline (|y| of its first body within a fifth of
/// the widest body's: neck and head); else an arm (hands, grippers and fingers included).
/// Every joint of a fixed-base model is kOther.
/// @return dim nj. Changes the model's state.
std::vector<JointGroup> jointGroupsOf(IDynamicsModel& model);

}  // namespace dynfilter
