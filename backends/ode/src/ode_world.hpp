#pragma once
// Internal: an ODE world (bodies, joints, collision geoms) built from a RobotDescription
// and an Environment.

#include <memory>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ode/ode.h>

#include "dynfilter/core/contact.hpp"
#include "dynfilter/core/environment.hpp"
#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter::ode_backend {

/// ODE's dMatrix3 is 3 × 4, row-major, the fourth column unused.
inline Eigen::Matrix3d rotationFromOde(const dReal* R) {
  Eigen::Matrix3d M;
  M << R[0], R[1], R[2], R[4], R[5], R[6], R[8], R[9], R[10];
  return M;
}
inline void toOdeRotation(const Eigen::Matrix3d& R, dMatrix3 out) {
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out[4 * i + j] = R(i, j);
    out[4 * i + 3] = 0.0;
  }
}

/// dInitODE2 once per process (thread-safe), plus ODE's per-thread data for the calling
/// thread. Throws std::runtime_error when the library is not double precision.
void ensureOdeInitialised();

/// One rigid body of the model: a URDF link on a moving joint (or the root) together with
/// the links welded to it by fixed joints. Its frame N is that link's frame; the ODE body
/// sits at the lumped centre of mass with N's axes (ODE wants the CoM at the body origin),
/// so X_NB = Trans(p_NCom).
struct OdeNode {
  dBodyID body = nullptr;     ///< null only for a fixed-base root: the world itself
  int parent = -1;            ///< parent node (nodes are parent-first), −1 for the root
  int link = -1;              ///< the carrier URDF link (the one whose frame N is)
  int coordinate = -1;        ///< joint coordinate (0 ≤ c < nj) that drives the joint, −1
                              ///< for the root; a mimic follower's is its leader's
  double factor = 1.0;        ///< joint position = factor · q[coordinate] + offset
  double offset = 0.0;        ///< (a mimic follower's multiplier and offset; 1 and 0 else)
  bool follower = false;      ///< a mimic follower (passive: no torque of its own)
  bool prismatic = false;     ///< slider; otherwise hinge (revolute, continuous)
  double lower = 0.0, upper = 0.0;  ///< the joint's own position limits
  bool ball = false;          ///< ball joint: 3 coordinates from `coordinate` on (ball_joint.hpp)
  bool fixed = false;         ///< fixed joint: welded to the parent, no coordinate
  double axis_sign = 1.0;     ///< −1 when the child is the joint's body 2 (user's joints)
  dJointID joint = nullptr;   ///< hinge or slider, body 1 = this node, body 2 = parent
  dJointID mimic_motor = nullptr;  ///< follower: angular or linear motor holding the coupling in dWorldStep
  Eigen::Isometry3d X_PJ = Eigen::Isometry3d::Identity();  ///< joint frame in parent's N
  Eigen::Vector3d axis_J = Eigen::Vector3d::UnitX();       ///< unit axis in J
  Eigen::Vector3d p_NCom = Eigen::Vector3d::Zero();        ///< body origin in N (m)
  /// Lumped URDF mass. A massless node's ODE body gets a token mass for the stepper
  /// (ODE needs one); the analytic queries skip it and use the URDF's zero.
  double mass_kg = 0.0;
  Eigen::Matrix3d I_Com_N = Eigen::Matrix3d::Zero();       ///< about the CoM, N axes
  /// Added to every principal moment of the body's dMass (ODE's stepper needs a positive
  /// definite inertia; a point mass has none); the analytic queries take it off (kg m²).
  double inertia_lift = 0.0;
};

/// Where a URDF link lives: a frame on a node.
struct OdeLinkFrame {
  int node = -1;
  Eigen::Isometry3d X_NL = Eigen::Isometry3d::Identity();  ///< link frame in N
  Eigen::Isometry3d X_BL = Eigen::Isometry3d::Identity();  ///< link frame in the ODE body frame
};

/// What a collision geom belongs to (dGeomSetData points at one of these).
struct OdeGeomTag {
  bool robot = false;
  int link = -1;                 ///< robot geoms: URDF link index
  int node = -1;                 ///< robot geoms: node index
  int object = kGroundObject;    ///< environment geoms: kGroundObject or box index
  double friction = 0.0;         ///< environment geoms: Coulomb μ
};

/// Owns the ODE world, its collision spaces and the contact joint group.
class OdeWorld {
 public:
  OdeWorld(const urdf::RobotDescription& robot, bool floating_base,
           const Eigen::Vector3d& gravity_W, const Environment& environment,
           bool enforce_joint_limits);
  ~OdeWorld();
  OdeWorld(const OdeWorld&) = delete;
  OdeWorld& operator=(const OdeWorld&) = delete;

  dWorldID world() const { return world_; }
  dSpaceID robotSpace() const { return robot_space_; }
  dSpaceID environmentSpace() const { return environment_space_; }
  dJointGroupID contactGroup() const { return contact_group_; }

  const std::vector<OdeNode>& nodes() const { return nodes_; }
  const std::vector<OdeLinkFrame>& links() const { return links_; }
  /// node_of_coordinate[c]: the node moved by joint coordinate c.
  const std::vector<int>& nodeOfCoordinate() const { return node_of_coordinate_; }
  /// Longest root-to-node path (number of nodes), for scratch sizes.
  int maxDepth() const { return max_depth_; }

 private:
  void buildNodes(const urdf::RobotDescription& robot, bool floating_base);
  void createBodiesAndJoints(bool enforce_joint_limits);
  void setJointLimits(const OdeNode& node);
  void createRobotGeoms(const urdf::RobotDescription& robot);
  void createEnvironmentGeoms(const Environment& environment);
  /// The convex geom of @p hull, about the hull's vertex centroid, returned in @p p_SO
  /// (shape frame): the geom belongs there.
  dGeomID createConvexGeom(const urdf::ConvexHull& hull, Eigen::Vector3d& p_SO);

  dWorldID world_ = nullptr;
  dSpaceID robot_space_ = nullptr;
  dSpaceID environment_space_ = nullptr;
  dJointGroupID contact_group_ = nullptr;
  std::vector<OdeNode> nodes_;
  std::vector<OdeLinkFrame> links_;
  std::vector<int> node_of_coordinate_;
  bool fixed_root_ = false;
  std::vector<OdeGeomTag> geom_tags_;  // sized before any geom points at an entry
  // Convex geoms keep pointers to their planes, points and polygons: one block per geom,
  // never reallocated (a list of vectors).
  struct ConvexData {
    std::vector<dReal> planes, points;
    std::vector<unsigned int> polygons;
  };
  std::vector<std::unique_ptr<ConvexData>> convex_data_;
  int max_depth_ = 1;
};

}  // namespace dynfilter::ode_backend
