#pragma once
/// @file
/// A URDF as plain data: what every backend builds its engine model from. Parsing lives
/// here once; kinematics and dynamics do not (each backend derives them independently).

#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/ground_contacts.hpp"
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

enum class ShapeKind { kBox, kSphere, kCylinder, kConvexHull };

/// The convex hull of a collision mesh, in the shape frame S, scale applied (m).
struct ConvexHull {
  std::vector<Eigen::Vector3d> vertices_S;
  /// Faces as vertex-index loops, counter-clockwise seen from outside.
  std::vector<std::vector<int>> faces;
  /// One plane per face: n · p = d, n the unit outward normal (n = xyz, d = w).
  std::vector<Eigen::Vector4d> planes_S;
};

/// A collision shape attached to a link. Cylinders have their axis along the shape's z.
/// A URDF <mesh> becomes the convex hull of its vertices (kConvexHull).
struct CollisionShapeDesc {
  ShapeKind kind = ShapeKind::kBox;
  Eigen::Vector3d box_size_m = Eigen::Vector3d::Zero();   ///< full edge lengths (box)
  double radius_m = 0.0;                                  ///< sphere, cylinder
  double length_m = 0.0;                                  ///< cylinder
  ConvexHull hull;                                        ///< kConvexHull
  std::string mesh_path;                                  ///< kConvexHull: the resolved file
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
  int coordinate = -1;         ///< index among the independent moving joints (nj), −1 for
                               ///< fixed joints and mimic followers
  /// A mimic follower (URDF <mimic>): q = mimic_multiplier · q_leader + mimic_offset, with
  /// mimic_leader the independent joint it follows (chains of mimics are resolved to
  /// their first leader). −1 when the joint is independent. Followers carry no
  /// coordinate and no actuator: the coupling's force acts on the leader.
  int mimic_leader = -1;
  double mimic_multiplier = 1.0;
  double mimic_offset = 0.0;    ///< rad or m
  bool locked = false;          ///< welded on request (lockJoints): now a fixed joint

  bool moving() const { return type != JointType::kFixed; }
  bool mimics() const { return mimic_leader >= 0; }
};

struct RobotDescription {
  std::string name;
  std::string source;                 ///< file path or label, for messages
  std::vector<LinkDesc> links;        ///< file order
  std::vector<JointDesc> joints;      ///< file order
  std::vector<int> moving_joints;     ///< independent moving joints, file order (defines nj)
  std::vector<int> mimic_joints;      ///< mimic followers, file order
  int root_link = -1;
  std::vector<std::string> warnings;  ///< accepted oddities (e.g. a zero effort limit)
  /// Elements that do not change the dynamics and are ignored (<gazebo>, <transmission>,
  /// <sensor>, <visual>, ...), one entry per element name: "<name> ×count (first at
  /// file:line)". Tools print them with --verbose.
  std::vector<std::string> ignored_elements;

  int findLink(std::string_view link_name) const;    ///< −1 when unknown
  int findJoint(std::string_view joint_name) const;  ///< −1 when unknown
  /// Links ordered so that every parent precedes its children (depth first, file order).
  std::vector<int> linksParentFirst() const;
  double totalMass() const;
};

/// Checks what dynamics needs beyond a well-formed URDF: all numbers are finite, masses are
/// non-negative; every rigid body that moves (a link with the links welded to it by fixed
/// joints, as the backends lump them) has a positive semi-definite inertia about its centre
/// of mass (a single link's inertia may be singular or violate the triangle inequality:
/// the loader warns, see RobotDescription::warnings); every moving joint moves mass (its subtree has mass, and for
/// a revolute joint an inertia about the joint axis > 0); a floating base carries a
/// whole-body mass and inertia. Massless links are accepted wherever this holds (e.g. the
/// intermediate links of a 3-DoF hip). Throws ModelError naming the file, line, element
/// (the joint whose motion moves no mass) and reason.
void validateForDynamics(const RobotDescription& robot, bool floating_base);

/// Appends to @p robot's warnings a description of the joint motions that move (almost) no
/// inertia at q = 0: eigenvectors of the fixed-base mass matrix A_JJ(0) whose eigenvalue is
/// at most 1e-9 of the largest, with the joints that take part in them. Such a model passes
/// validateForDynamics (each joint alone moves mass) but its forward dynamics is singular
/// near that pose, e.g. a point-mass head on a neck whose axes meet at its centre of mass:
/// a simulator (either engine) spins those joints up without bound. Returns whether it
/// warned.
bool warnSingularMassMatrix(RobotDescription& robot);

/// Turns the named joints into fixed joints at the given position (rad or m): the child is
/// welded at X_PJ · motion(position). Mimic followers of a locked joint are locked at
/// their own k · position + c. Coordinates are renumbered. Throws ModelError on an unknown
/// joint name or a position outside the joint's limits.
struct JointLock {
  std::string joint;
  double position = 0.0;
};
void lockJoints(RobotDescription& robot, const std::vector<JointLock>& locks);

/// The model's names, sizes and limits as every backend reports them (ModelInfo): joints
/// are the moving joints in file order, bodies all links in file order.
ModelInfo makeModelInfo(const RobotDescription& robot, bool floating_base);

/// Every convex-hull and cylinder collision shape of @p robot with its link (body index =
/// link index), for the backends' ground contacts (core/ground_contacts.hpp).
GroundContactShapes groundContactShapes(const RobotDescription& robot);

}  // namespace dynfilter::urdf
