#pragma once
/// @file
/// A URDF as plain data: what every backend builds its engine model from. Parsing lives
/// here once; kinematics and dynamics do not (each backend derives them independently).

#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/model_info.hpp"

namespace dynfilter::urdf {

enum class JointType { kRevolute, kContinuous, kPrismatic, kFixed };

/// Mass properties of a link, in the link frame L.
struct InertialDesc {
  bool present = false;                               ///< an <inertial> element was given
  double mass_kg = 0.0;
  Eigen::Vector3d p_LCom = Eigen::Vector3d::Zero();   ///< centre of mass (m)
  Eigen::Matrix3d I_Com_L = Eigen::Matrix3d::Zero();  ///< inertia about the CoM, L axes (kg m²)
};

enum class ShapeKind { kBox, kSphere, kCylinder };

/// A collision primitive attached to a link. Cylinders have their axis along the shape's z.
struct CollisionShapeDesc {
  ShapeKind kind = ShapeKind::kBox;
  Eigen::Vector3d box_size_m = Eigen::Vector3d::Zero();   ///< full edge lengths (box)
  double radius_m = 0.0;                                  ///< sphere, cylinder
  double length_m = 0.0;                                  ///< cylinder
  Eigen::Isometry3d X_LS = Eigen::Isometry3d::Identity(); ///< shape pose in the link frame
};

struct LinkDesc {
  std::string name;
  int line = 0;                     ///< line of <link> in the source
  InertialDesc inertial;
  std::vector<CollisionShapeDesc> collisions;
  int parent_joint = -1;            ///< index into RobotDescription::joints, −1 for the root
  std::vector<int> child_joints;    ///< in file order
};

/// A joint. The child link frame coincides with the joint frame J; at q = 0,
/// X_PC = X_PJ. Revolute: X_PC(q) = X_PJ · Rot(axis_J, q); prismatic: X_PJ · Trans(axis_J q).
struct JointDesc {
  std::string name;
  int line = 0;
  JointType type = JointType::kFixed;
  int parent_link = -1;
  int child_link = -1;
  Eigen::Isometry3d X_PJ = Eigen::Isometry3d::Identity();
  Eigen::Vector3d axis_J = Eigen::Vector3d::UnitX();  ///< unit axis in J
  double lower = 0.0;          ///< rad or m; −inf for continuous
  double upper = 0.0;          ///< rad or m; +inf for continuous
  double velocity_max = 0.0;   ///< +inf when the URDF gives none (or 0)
  double effort_max = 0.0;     ///< +inf when the URDF gives none (or 0)
  int coordinate = -1;         ///< index among the moving joints (nj), −1 for fixed

  bool moving() const { return type != JointType::kFixed; }
};

struct RobotDescription {
  std::string name;
  std::string source;                 ///< file path or label, for messages
  std::vector<LinkDesc> links;        ///< file order
  std::vector<JointDesc> joints;      ///< file order
  std::vector<int> moving_joints;     ///< joint indices in file order (defines nj)
  int root_link = -1;
  std::vector<std::string> warnings;  ///< accepted oddities (e.g. mesh collisions skipped)

  int findLink(std::string_view link_name) const;    ///< −1 when unknown
  int findJoint(std::string_view joint_name) const;  ///< −1 when unknown
  /// Links ordered so that every parent precedes its children (depth first, file order).
  std::vector<int> linksParentFirst() const;
  double totalMass() const;
};

/// Checks what dynamics needs beyond a well-formed URDF: every link on a moving joint (and
/// the root of a floating-base model) has mass > 0 and an inertia
/// that is symmetric positive definite and satisfies the triangle inequality; all numbers
/// are finite. Throws ModelError naming the file, line, element and reason.
void validateForDynamics(const RobotDescription& robot, bool floating_base);

/// The model's names, sizes and limits as every backend reports them (ModelInfo): joints
/// are the moving joints in file order, bodies all links in file order.
ModelInfo makeModelInfo(const RobotDescription& robot, bool floating_base);

}  // namespace dynfilter::urdf
