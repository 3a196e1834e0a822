#include "dynfilter/urdf/robot_description.hpp"

#include <cmath>

#include <Eigen/Eigenvalues>

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

void validateForDynamics(const RobotDescription& robot, bool floating_base) {
  // Links on a moving joint (and a floating root) need mass and inertia; links welded by
  // fixed joints may be massless frames (sensor or tool frames).
  std::vector<char> moves(robot.links.size(), 0);
  for (std::size_t i = 0; i < robot.links.size(); ++i) {
    const int pj = robot.links[i].parent_joint;
    moves[i] = pj < 0 ? floating_base : robot.joints[pj].moving();
  }
  for (std::size_t i = 0; i < robot.links.size(); ++i) {
    const LinkDesc& link = robot.links[i];
    const InertialDesc& in = link.inertial;
    const std::string label = "link \"" + link.name + "\"";
    if (!std::isfinite(in.mass_kg) || !in.p_LCom.allFinite() || !in.I_Com_L.allFinite())
      throw ModelError(robot.source, link.line, label, "inertial values are not finite");
    if (in.mass_kg < 0.0)
      throw ModelError(robot.source, link.line, label, "negative mass");
    if (!moves[i]) continue;
    const int pj = link.parent_joint;
    const std::string where =
        pj < 0 ? "the floating base" : "a link moved by joint \"" + robot.joints[pj].name + "\"";
    if (!in.present)
      throw ModelError(robot.source, link.line, label,
                       "no <inertial> on " + where + " (mass and inertia are required)");
    if (!(in.mass_kg > 0.0))
      throw ModelError(robot.source, link.line, label, "zero mass on " + where);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(in.I_Com_L);
    const Eigen::Vector3d m = eig.eigenvalues();  // ascending
    if (!(m[0] > 0.0))
      throw ModelError(robot.source, link.line, label,
                       "inertia is not positive definite (smallest principal moment " +
                           std::to_string(m[0]) + " kg m²)");
    if (m[0] + m[1] < m[2] * (1.0 - 1e-9))
      throw ModelError(robot.source, link.line, label,
                       "inertia violates the triangle inequality (principal moments " +
                           std::to_string(m[0]) + ", " + std::to_string(m[1]) + ", " +
                           std::to_string(m[2]) + " kg m²)");
  }
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
  info.total_mass = robot.totalMass();
  return info;
}

}  // namespace dynfilter::urdf
