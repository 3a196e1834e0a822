#pragma once
/// @file
/// IDynamicsModel over ODE bodies and joints: a user's own (attachOdeModel), or the ones
/// the ODE backend builds from a URDF (makeOdeModel is this model over a world it builds).
///
/// A, b, Jacobians and J̇·v come from ODE's bodies (dBodyGetMass, poses, velocities) and
/// joints (hinge and ball anchors, hinge and slider axes) in world coordinates — never
/// from DART. setState() poses the bodies by forward kinematics over the joint tree;
/// pullBodyState() reads (q, v) back from the bodies after the world stepped.
///
/// Coordinates (model_info.hpp, ball_joint.hpp): the first body is the base — free
/// (floating base; q's base pose is that body's link frame, see OdeBodyRef::X_BL) or
/// welded to the world by a fixed joint (fixed base). Joints in the order given: a hinge
/// or slider one coordinate (ODE's own hinge angle / slider position, the child moving
/// along +axis when it is ODE's body 1, along −axis when it is body 2), a ball joint
/// three (θ, the rotation vector of the child body's frame relative to the parent
/// body's, with v = θ̇), a fixed joint none. Bodies are the given bodies in order.

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ode/ode.h>

#include "dynfilter/core/dynamics_model.hpp"

namespace dynfilter::ode_backend {

class OdeBodyModel : public IDynamicsModel {
 public:
  /// (q, v) ← the bodies' current poses and velocities (e.g. after dWorldStep), then the
  /// bodies are posed by forward kinematics from it (exactly on their joints). Returns
  /// false, changing nothing, when a body's state is not finite. No allocation.
  virtual bool pullBodyState() = 0;
  /// The bodies' current state in the model's coordinates, leaving the bodies and the
  /// model's (q, v) as they are (what a controller reads between world steps: posing the
  /// bodies onto their joints every step, as pullBodyState does, changes the user's
  /// simulation — measured: it made the figure's closed loop diverge within 20 ms).
  /// @p q dim nq, @p v dim nv; returns false on a size mismatch or a non-finite state.
  /// No allocation.
  virtual bool readBodyState(Eigen::Ref<Eigen::VectorXd> q, Eigen::Ref<Eigen::VectorXd> v) const = 0;
  /// Adds the joint torques @p tau_J (dim nj) through ODE's joint API for the next
  /// dWorldStep: dJointAddHingeTorque, dJointAddSliderForce; a ball joint's three as the
  /// torque J_r⁻ᵀ τ on the child body and its opposite on the parent (dBodyAddTorque; ODE
  /// has no ball-joint torque). Throws InvalidStateError on a size mismatch.
  virtual void addJointTorques(const Eigen::Ref<const Eigen::VectorXd>& tau_J) const = 0;
  /// The ODE bodies of the model (ModelInfo::body_names order).
  virtual const std::vector<dBodyID>& bodies() const = 0;
};

/// A body of the user's robot. ODE wants the centre of mass at the body origin, so the
/// frame a user knows the body by (a URDF link frame, say) may sit elsewhere: X_BL is
/// that frame in the ODE body frame (identity: the body frame itself). bodyPose() and
/// every point on the body are in that frame. For the base its rotation must be identity.
struct OdeBodyRef {
  std::string name;
  dBodyID body = nullptr;
  Eigen::Isometry3d X_BL = Eigen::Isometry3d::Identity();
};

/// A joint of the user's robot: hinge, slider, ball or fixed (dJointGetType), between two
/// of its bodies — or, fixed only, between the base and the world (a fixed base).
struct OdeJointRef {
  std::string name;
  dJointID joint = nullptr;
  double tau_max = std::numeric_limits<double>::infinity();  ///< |τ| bound (N m or N)
  double v_max = std::numeric_limits<double>::infinity();    ///< |q̇| bound (rad/s or m/s)
};

/// The user's robot in the user's ODE world.
struct OdeRobotRefs {
  std::string name = "robot";
  dWorldID world = nullptr;
  /// Contacts: the robot's geoms (those on its bodies) against every other geom in this
  /// space (nested spaces included).
  dSpaceID space = nullptr;
  std::vector<OdeBodyRef> bodies;   ///< the first is the base
  std::vector<OdeJointRef> joints;  ///< all joints of the tree, in coordinate order
  /// Coulomb μ the filter's QP mode and simulateStep() assume for every contact.
  double friction = 0.8;
};

/// The model of the user's robot. Gravity is read from the world now. Position limits
/// are the joints' ODE stops (dParamLoStop, dParamHiStop; ±inf when unset). A contact's
/// object index is the other geom's index among the space's geoms now (−1 for geoms
/// added later). simulateStep() adds the torques, makes contact joints for the robot's
/// contacts (its own group, μ = friction) and steps the whole world with dWorldStep.
/// The initial (q, v) is read from the bodies (which attaching does not move). Throws ModelError naming the body or joint
/// on a joint type other than hinge, slider, ball and fixed, a joint to a body that is
/// not listed, a body reached twice or never, a massless body, or a base link frame
/// with rotation; std::invalid_argument on null handles or a bad friction.
std::unique_ptr<OdeBodyModel> attachOdeModel(const OdeRobotRefs& robot);

}  // namespace dynfilter::ode_backend
