#include "dynfilter/urdf/robot_description.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/lie_group.hpp"

namespace dynfilter::urdf {
namespace {
template <typename T>
int findByName(const std::vector<T>& items, std::string_view name) {
  for (std::size_t i = 0; i < items.size(); ++i)
    if (items[i].name == name) return static_cast<int>(i);
  return -1;
}
}  // namespace

int RobotDescription::findLink(std::string_view link_name) const {
  return findByName(links, link_name);
}

int RobotDescription::findJoint(std::string_view joint_name) const {
  return findByName(joints, joint_name);
}

std::vector<int> RobotDescription::linksParentFirst() const {
  std::vector<int> order;
  order.reserve(links.size());
  std::vector<int> stack{root_link};
  while (!stack.empty()) {
    const int link = stack.back();
    stack.pop_back();
    order.push_back(link);
    const auto& children = links[link].child_joints;
    for (auto it = children.rbegin(); it != children.rend(); ++it)
      stack.push_back(joints[*it].child_link);
  }
  return order;
}

double RobotDescription::totalMass() const {
  double m = 0.0;
  for (const auto& link : links) m += link.inertial.mass_kg;
  return m;
}

ModelInfo makeModelInfo(const RobotDescription& robot, bool floating_base) {
  ModelInfo info;
  info.name = robot.name;
  info.floating_base = floating_base;
  info.nj = static_cast<int>(robot.moving_joints.size());
  info.nq = (floating_base ? kFloatingBaseNq : 0) + info.nj;
  info.nv = (floating_base ? kFloatingBaseNv : 0) + info.nj;
  info.q_lower.resize(info.nj);
  info.q_upper.resize(info.nj);
  info.v_max.resize(info.nj);
  info.tau_max.resize(info.nj);
  for (int c = 0; c < info.nj; ++c) {
    const JointDesc& j = robot.joints[static_cast<std::size_t>(robot.moving_joints[static_cast<std::size_t>(c)])];
    info.joint_names.push_back(j.name);
    info.q_lower[c] = j.lower;
    info.q_upper[c] = j.upper;
    info.v_max[c] = j.velocity_max;
    info.tau_max[c] = j.effort_max;
  }
  for (const auto& link : robot.links) info.body_names.push_back(link.name);
  for (const JointDesc& j : robot.joints)
    if (j.locked) info.locked_joint_names.push_back(j.name);
  info.total_mass = robot.totalMass();
  return info;
}

}  // namespace dynfilter::urdf

namespace dynfilter::urdf {

void lockJoints(RobotDescription& robot, const std::vector<JointLock>& locks) {
  std::vector<char> locked(robot.joints.size(), 0);
  std::vector<double> position(robot.joints.size(), 0.0);
  for (const JointLock& lock : locks) {
    const int j = robot.findJoint(lock.joint);
    if (j < 0 || !robot.joints[static_cast<std::size_t>(j)].moving())
      throw ModelError(robot.source, 0, "joint \"" + lock.joint + "\"",
                       "cannot lock: not a moving joint of model \"" + robot.name + "\"");
    locked[static_cast<std::size_t>(j)] = 1;
    position[static_cast<std::size_t>(j)] = lock.position;
  }
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    const JointDesc& joint = robot.joints[j];
    if (!locked[j] || !joint.mimics()) continue;
    if (!locked[static_cast<std::size_t>(joint.mimic_leader)])
      throw ModelError(robot.source, joint.line, "joint \"" + joint.name + "\"",
                       "cannot lock a mimic follower without its leader \"" +
                           robot.joints[static_cast<std::size_t>(joint.mimic_leader)].name + "\"");
  }
  // Followers of a locked leader are locked where the coupling puts them.
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    const JointDesc& joint = robot.joints[j];
    if (!joint.mimics() || !locked[static_cast<std::size_t>(joint.mimic_leader)]) continue;
    locked[j] = 1;
    position[j] = joint.mimic_multiplier * position[static_cast<std::size_t>(joint.mimic_leader)] +
                  joint.mimic_offset;
  }
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    if (!locked[j]) continue;
    JointDesc& joint = robot.joints[j];
    const double q = position[j];
    const bool limited = joint.type != JointType::kContinuous;
    if (limited && (q < joint.lower - 1e-12 || q > joint.upper + 1e-12))
      throw ModelError(robot.source, joint.line, "joint \"" + joint.name + "\"",
                       "cannot lock at " + std::to_string(q) + ": outside its limits [" +
                           std::to_string(joint.lower) + ", " + std::to_string(joint.upper) + "]");
    if (joint.type == JointType::kPrismatic)
      joint.X_PJ = joint.X_PJ * Eigen::Translation3d(joint.axis_J * q);
    else
      joint.X_PJ = joint.X_PJ * Eigen::AngleAxisd(q, joint.axis_J);
    joint.type = JointType::kFixed;
    joint.locked = true;
    joint.mimic_leader = -1;
    joint.mimic_multiplier = 1.0;
    joint.mimic_offset = 0.0;
  }
  robot.moving_joints.clear();
  robot.mimic_joints.clear();
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    JointDesc& joint = robot.joints[j];
    joint.coordinate = -1;
    if (!joint.moving()) continue;
    if (joint.mimics()) {
      robot.mimic_joints.push_back(static_cast<int>(j));
      continue;
    }
    joint.coordinate = static_cast<int>(robot.moving_joints.size());
    robot.moving_joints.push_back(static_cast<int>(j));
  }
}

GroundContactShapes groundContactShapes(const RobotDescription& robot) {
  GroundContactShapes shapes;
  for (std::size_t l = 0; l < robot.links.size(); ++l)
    for (const CollisionShapeDesc& shape : robot.links[l].collisions) {
      const int body = static_cast<int>(l);
      if (shape.kind == ShapeKind::kCylinder) {
        shapes.cylinders.push_back({body, shape.X_LS, shape.radius_m, shape.length_m});
      } else if (shape.kind == ShapeKind::kConvexHull) {
        Eigen::Matrix3Xd p_SV(3, static_cast<Eigen::Index>(shape.hull.vertices_S.size()));
        for (std::size_t i = 0; i < shape.hull.vertices_S.size(); ++i)
          p_SV.col(static_cast<Eigen::Index>(i)) = shape.hull.vertices_S[i];
        shapes.hulls.push_back(BodyHull::make(body, shape.X_LS, std::move(p_SV)));
      }
    }
  return shapes;
}

}  // namespace dynfilter::urdf
