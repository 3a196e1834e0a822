#include "dynfilter/urdf/robot_description.hpp"

#include <cmath>

#include <Eigen/Eigenvalues>

#include "dynfilter/core/errors.hpp"

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

}  // namespace dynfilter::urdf
