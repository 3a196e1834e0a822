// attachOdeModel: reads the joint tree, frames and geoms off a user's ODE world and hands
// them to the one OdeBodyModel implementation (the same the URDF-built backend uses).
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dynfilter/core/ball_joint.hpp"
#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "ode_bodies.hpp"

namespace dynfilter::ode_backend {
namespace {

Eigen::Isometry3d pose(const Eigen::Vector3d& p, const Eigen::Matrix3d& R) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = R;
  X.translation() = p;
  return X;
}

Eigen::Isometry3d bodyPose(dBodyID body) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = rotationFromOde(dBodyGetRotation(body));
  X.translation() = toEigen(dBodyGetPosition(body));
  return X;
}

[[noreturn]] void refuse(const OdeRobotRefs& robot, const std::string& what, const std::string& reason) {
  throw ModelError("<ODE robot \"" + robot.name + "\">", 0, what, reason);
}

// Every geom of @p space and its sub-spaces, spaces themselves excluded.
void collectGeoms(dSpaceID space, std::vector<dGeomID>& out) {
  for (int i = 0; i < dSpaceGetNumGeoms(space); ++i) {
    const dGeomID g = dSpaceGetGeom(space, i);
    if (dGeomIsSpace(g) != 0)
      collectGeoms(reinterpret_cast<dSpaceID>(g), out);
    else
      out.push_back(g);
  }
}

class UserBodies final : public OdeBodies {
 public:
  UserBodies(const OdeRobotRefs& robot, std::vector<OdeNode> nodes,
             std::vector<OdeLinkFrame> links, int max_coordinates)
      : world_(robot.world),
        space_(robot.space),
        friction_(robot.friction),
        nodes_(std::move(nodes)),
        links_(std::move(links)),
        max_coordinates_(max_coordinates),
        contact_group_(dJointGroupCreate(0)) {
    for (std::size_t i = 0; i < robot.bodies.size(); ++i)
      body_index_.emplace_back(robot.bodies[i].body, static_cast<int>(i));
    std::sort(body_index_.begin(), body_index_.end());
    std::vector<dGeomID> geoms;
    collectGeoms(space_, geoms);
    int object = 0;
    for (const dGeomID g : geoms)
      if (!isRobotBody(dGeomGetBody(g))) object_index_.emplace_back(g, object++);
    std::sort(object_index_.begin(), object_index_.end());
  }
  ~UserBodies() override { dJointGroupDestroy(contact_group_); }
  UserBodies(const UserBodies&) = delete;
  UserBodies& operator=(const UserBodies&) = delete;

  dWorldID world() const override { return world_; }
  dJointGroupID contactGroup() const override { return contact_group_; }
  const std::vector<OdeNode>& nodes() const override { return nodes_; }
  const std::vector<OdeLinkFrame>& links() const override { return links_; }
  int maxPathCoordinates() const override { return max_coordinates_; }

  void collide(void* data, dNearCallback* callback) const override {
    Pass pass{this, data, callback};
    dSpaceCollide(space_, &pass, &near);
  }

  bool role(dGeomID geom, GeomRole& out) const override {
    const int body = bodyIndex(dGeomGetBody(geom));
    out.robot = body >= 0;
    out.link = body;
    out.object = kGroundObject;
    out.friction = friction_;
    if (body < 0) {
      const auto it = std::lower_bound(object_index_.begin(), object_index_.end(),
                                       std::make_pair(geom, -1));
      if (it != object_index_.end() && it->first == geom) out.object = it->second;
    }
    return true;
  }

 private:
  struct Pass {
    const UserBodies* self;
    void* data;
    dNearCallback* callback;
  };

  // ODE's idiom for nested spaces; pairs without a robot geom go nowhere.
  static void near(void* data, dGeomID g1, dGeomID g2) {
    auto* pass = static_cast<Pass*>(data);
    if (dGeomIsSpace(g1) != 0 || dGeomIsSpace(g2) != 0) {
      dSpaceCollide2(g1, g2, data, &near);
      if (dGeomIsSpace(g1) != 0) dSpaceCollide(reinterpret_cast<dSpaceID>(g1), data, &near);
      if (dGeomIsSpace(g2) != 0) dSpaceCollide(reinterpret_cast<dSpaceID>(g2), data, &near);
      return;
    }
    const bool robot1 = pass->self->isRobotBody(dGeomGetBody(g1));
    const bool robot2 = pass->self->isRobotBody(dGeomGetBody(g2));
    if (robot1 == robot2) return;
    pass->callback(pass->data, g1, g2);
  }

  int bodyIndex(dBodyID body) const {
    if (body == nullptr) return -1;
    const auto it = std::lower_bound(body_index_.begin(), body_index_.end(),
                                     std::make_pair(body, -1));
    return it != body_index_.end() && it->first == body ? it->second : -1;
  }
  bool isRobotBody(dBodyID body) const { return bodyIndex(body) >= 0; }

  dWorldID world_;
  dSpaceID space_;
  double friction_;
  std::vector<OdeNode> nodes_;
  std::vector<OdeLinkFrame> links_;
  int max_coordinates_;
  dJointGroupID contact_group_;
  std::vector<std::pair<dBodyID, int>> body_index_;     // sorted by handle
  std::vector<std::pair<dGeomID, int>> object_index_;   // sorted by handle
};

}  // namespace

std::unique_ptr<OdeBodyModel> attachOdeModel(const OdeRobotRefs& robot) {
  if (robot.world == nullptr || robot.space == nullptr)
    throw std::invalid_argument("attachOdeModel: null world or space");
  if (!(robot.friction >= 0.0) || !std::isfinite(robot.friction))
    throw std::invalid_argument("attachOdeModel: friction must be finite and ≥ 0");
  if (robot.bodies.empty()) refuse(robot, "bodies", "none given");
  ensureOdeInitialised();
  const std::size_t nb = robot.bodies.size();
  auto indexOf = [&](dBodyID body) {
    for (std::size_t i = 0; i < nb; ++i)
      if (robot.bodies[i].body == body) return static_cast<int>(i);
    return -1;
  };
  for (std::size_t i = 0; i < nb; ++i) {
    const OdeBodyRef& b = robot.bodies[i];
    const std::string what = "body \"" + b.name + "\"";
    if (b.body == nullptr) refuse(robot, what, "null dBodyID");
    if (indexOf(b.body) != static_cast<int>(i)) refuse(robot, what, "listed twice");
    dMass mass;
    dBodyGetMass(b.body, &mass);
    if (!(mass.mass > 0.0)) refuse(robot, what, "no mass");
    if (!bodyPose(b.body).matrix().allFinite()) refuse(robot, what, "pose not finite");
  }
  if (!robot.bodies.front().X_BL.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-12))
    refuse(robot, "body \"" + robot.bodies.front().name + "\"",
           "the base's link frame must have the body's axes (X_BL without rotation)");

  // The tree: each joint's parent and child body, and its coordinates in joint order.
  ModelInfo info;
  info.name = robot.name;
  info.floating_base = true;
  std::vector<std::vector<int>> joints_of_body(nb);
  int coordinates = 0;
  std::vector<double> lower, upper, v_max, tau_max;
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    const OdeJointRef& ref = robot.joints[j];
    const std::string what = "joint \"" + ref.name + "\"";
    if (ref.joint == nullptr) refuse(robot, what, "null dJointID");
    const int type = dJointGetType(ref.joint);
    const dBodyID b1 = dJointGetBody(ref.joint, 0), b2 = dJointGetBody(ref.joint, 1);
    const int i1 = indexOf(b1), i2 = indexOf(b2);
    if (type == dJointTypeFixed && (b1 == nullptr || b2 == nullptr) &&
        (i1 == 0 || i2 == 0)) {
      info.floating_base = false;  // the base welded to the world
      continue;
    }
    if (type != dJointTypeHinge && type != dJointTypeSlider && type != dJointTypeBall &&
        type != dJointTypeFixed)
      refuse(robot, what, "unsupported ODE joint type " + std::to_string(type) +
                              " (supported: hinge, slider, ball, fixed)");
    if (i1 < 0 || i2 < 0)
      refuse(robot, what, "connects a body that is not listed (or the world)");
    // The parent is the body nearer the base: decided by the traversal below.
    joints_of_body[static_cast<std::size_t>(i1)].push_back(static_cast<int>(j));
    joints_of_body[static_cast<std::size_t>(i2)].push_back(static_cast<int>(j));
  }
  // Breadth-first from the base: parent-first node order.
  std::vector<int> order{0};
  std::vector<int> parent_of(nb, -2), joint_of(nb, -1);
  parent_of[0] = -1;
  for (std::size_t head = 0; head < order.size(); ++head) {
    const int body = order[head];
    for (const int j : joints_of_body[static_cast<std::size_t>(body)]) {
      if (j == joint_of[static_cast<std::size_t>(body)]) continue;  // the one we came through
      const dJointID joint = robot.joints[static_cast<std::size_t>(j)].joint;
      const int other = indexOf(dJointGetBody(joint, 0)) == body ? indexOf(dJointGetBody(joint, 1))
                                                                 : indexOf(dJointGetBody(joint, 0));
      if (parent_of[static_cast<std::size_t>(other)] != -2)
        refuse(robot, "body \"" + robot.bodies[static_cast<std::size_t>(other)].name + "\"",
               "reached twice (the joints must form a tree)");
      parent_of[static_cast<std::size_t>(other)] = body;
      joint_of[static_cast<std::size_t>(other)] = j;
      order.push_back(other);
    }
  }
  for (std::size_t i = 0; i < nb; ++i)
    if (parent_of[i] == -2)
      refuse(robot, "body \"" + robot.bodies[i].name + "\"", "not connected to the base");

  // Coordinates in the order of the joints given.
  std::vector<int> coordinate_of_joint(robot.joints.size(), -1);
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    const OdeJointRef& ref = robot.joints[j];
    const int type = dJointGetType(ref.joint);
    const bool used = std::find(joint_of.begin(), joint_of.end(), static_cast<int>(j)) != joint_of.end();
    if (!used || type == dJointTypeFixed) continue;
    coordinate_of_joint[j] = coordinates;
    const int n = type == dJointTypeBall ? kBallJointDofs : 1;
    const double inf = std::numeric_limits<double>::infinity();
    for (int k = 0; k < n; ++k) {
      double lo = -inf, hi = inf;
      if (type == dJointTypeHinge) {
        lo = dJointGetHingeParam(ref.joint, dParamLoStop);
        hi = dJointGetHingeParam(ref.joint, dParamHiStop);
      } else if (type == dJointTypeSlider) {
        lo = dJointGetSliderParam(ref.joint, dParamLoStop);
        hi = dJointGetSliderParam(ref.joint, dParamHiStop);
      }
      info.joint_names.push_back(n == 1 ? ref.name : ref.name + "_" + "xyz"[k]);
      lower.push_back(lo <= -dInfinity ? -inf : lo);
      upper.push_back(hi >= dInfinity ? inf : hi);
      v_max.push_back(ref.v_max);
      tau_max.push_back(ref.tau_max);
    }
    coordinates += n;
  }
  info.nj = coordinates;
  info.nv = coordinates + (info.floating_base ? kFloatingBaseNv : 0);
  info.nq = coordinates + (info.floating_base ? kFloatingBaseNq : 0);
  info.q_lower = Eigen::Map<Eigen::VectorXd>(lower.data(), coordinates);
  info.q_upper = Eigen::Map<Eigen::VectorXd>(upper.data(), coordinates);
  info.v_max = Eigen::Map<Eigen::VectorXd>(v_max.data(), coordinates);
  info.tau_max = Eigen::Map<Eigen::VectorXd>(tau_max.data(), coordinates);

  // Nodes: one per body, frame N with the body's axes; its origin at the joint's anchor
  // (hinge, ball) or at the body's link frame (base, slider, fixed), so that the forward
  // kinematics of OdeBodyModel reproduce the bodies' poses now.
  std::vector<OdeNode> nodes(nb);
  std::vector<int> node_of_body(nb, -1);
  std::vector<Eigen::Isometry3d> X_WN(nb);
  std::vector<int> path_coordinates(nb, 0);
  int max_coordinates = 1;
  for (std::size_t n = 0; n < nb; ++n) node_of_body[static_cast<std::size_t>(order[n])] = static_cast<int>(n);
  for (std::size_t n = 0; n < nb; ++n) {
    const int b = order[n];
    const OdeBodyRef& ref = robot.bodies[static_cast<std::size_t>(b)];
    OdeNode& node = nodes[n];
    node.body = ref.body;
    node.link = b;
    dMass mass;
    dBodyGetMass(ref.body, &mass);
    node.mass_kg = mass.mass;
    const Eigen::Isometry3d X_WB = bodyPose(ref.body);
    Eigen::Vector3d origin_W = X_WB * ref.X_BL.translation();  // N's origin
    if (parent_of[static_cast<std::size_t>(b)] < 0) {
      if (!info.floating_base) node.X_PJ = pose(origin_W, X_WB.linear());
    } else {
      const int j = joint_of[static_cast<std::size_t>(b)];
      const OdeJointRef& jref = robot.joints[static_cast<std::size_t>(j)];
      const int type = dJointGetType(jref.joint);
      node.parent = node_of_body[static_cast<std::size_t>(parent_of[static_cast<std::size_t>(b)])];
      node.joint = jref.joint;
      node.coordinate = coordinate_of_joint[static_cast<std::size_t>(j)];
      node.axis_sign = dJointGetBody(jref.joint, 0) == ref.body ? 1.0 : -1.0;
      node.prismatic = type == dJointTypeSlider;
      node.ball = type == dJointTypeBall;
      node.fixed = type == dJointTypeFixed;
      dVector3 v;
      double q0 = 0.0;
      Eigen::Vector3d axis_W = Eigen::Vector3d::UnitX();
      if (type == dJointTypeHinge) {
        dJointGetHingeAnchor(jref.joint, v);
        origin_W = toEigen(v);
        dJointGetHingeAxis(jref.joint, v);
        axis_W = node.axis_sign * toEigen(v);
        q0 = dJointGetHingeAngle(jref.joint);
      } else if (type == dJointTypeBall) {
        dJointGetBallAnchor(jref.joint, v);
        origin_W = toEigen(v);
      } else if (type == dJointTypeSlider) {
        dJointGetSliderAxis(jref.joint, v);
        axis_W = node.axis_sign * toEigen(v);
        q0 = dJointGetSliderPosition(jref.joint);
      }
      const Eigen::Isometry3d& X_WP = X_WN[static_cast<std::size_t>(node.parent)];
      const Eigen::Matrix3d& R_WN = X_WB.linear();
      node.axis_J = R_WN.transpose() * axis_W;
      // The joint frame J: where N is at q = 0. Hinge: N rotated back by q0 about the
      // axis; slider: moved back by q0; ball: the parent's axes (θ = log(R_PN)); fixed: N.
      Eigen::Matrix3d R_WJ = R_WN;
      Eigen::Vector3d p_WJ = origin_W;
      if (node.ball) {
        R_WJ = X_WP.linear();
      } else if (type == dJointTypeHinge) {
        R_WJ = R_WN * Eigen::AngleAxisd(-q0, node.axis_J).toRotationMatrix();
      } else if (node.prismatic) {
        p_WJ = origin_W - axis_W * q0;
      }
      node.X_PJ.linear() = X_WP.linear().transpose() * R_WJ;
      node.X_PJ.translation() = X_WP.linear().transpose() * (p_WJ - X_WP.translation());
      const int path = path_coordinates[static_cast<std::size_t>(node.parent)] +
                       (node.fixed ? 0 : node.ball ? kBallJointDofs : 1);
      path_coordinates[n] = path;
      max_coordinates = std::max(max_coordinates, path);
    }
    X_WN[n] = pose(origin_W, X_WB.linear());
    node.p_NCom = X_WB.linear().transpose() * (X_WB.translation() - origin_W);
  }
  std::vector<OdeLinkFrame> links(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    const auto n = static_cast<std::size_t>(node_of_body[b]);
    links[b].node = static_cast<int>(n);
    links[b].X_BL = robot.bodies[b].X_BL;
    links[b].X_NL = Eigen::Translation3d(nodes[n].p_NCom) * robot.bodies[b].X_BL;
    info.body_names.push_back(robot.bodies[b].name);
    info.total_mass += nodes[n].mass_kg;
  }

  Environment environment;
  environment.has_ground = false;  // the space's geoms are the environment
  environment.ground.friction = robot.friction;
  dVector3 g;
  dWorldGetGravity(robot.world, g);
  auto bodies = std::make_unique<UserBodies>(robot, std::move(nodes), std::move(links), max_coordinates);
  return makeOdeBodyModel(std::move(bodies), std::move(info), std::move(environment), toEigen(g), true);
}

}  // namespace dynfilter::ode_backend
