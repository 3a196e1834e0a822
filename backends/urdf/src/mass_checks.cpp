// The mass properties a model needs for dynamics (validateForDynamics) and the warning of a
// mass matrix that is singular at q = 0 (warnSingularMassMatrix).
#include "dynfilter/urdf/robot_description.hpp"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>

#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/urdf/rigid_mass.hpp"

namespace dynfilter::urdf {

namespace {

// Kinetic energy ×2 of a unit-rate motion of @p body (summed in the root frame R) about
// (revolute) or along (prismatic) the axis a_R through o_R.
double unitMotionInertia(const RigidMass& body, bool prismatic, const Eigen::Vector3d& a_R,
                         const Eigen::Vector3d& o_R) {
  if (prismatic) return body.mass_kg;
  if (!(body.mass_kg > 0.0)) return 0.0;
  const Eigen::Vector3d d = body.p_FCom() - o_R;
  return a_R.dot(body.I_Com_F() * a_R) + body.mass_kg * a_R.cross(d).squaredNorm();
}

// Smallest moment of inertia (kg m²) or mass (kg) a joint's motion must move.
constexpr double kMinMovedInertia = 1e-12;

// Every link's pose in the root frame R at q = 0; @p order is robot.linksParentFirst().
std::vector<Eigen::Isometry3d> linkPosesAtZero(const RobotDescription& robot, const std::vector<int>& order) {
  std::vector<Eigen::Isometry3d> X_RL(robot.links.size(), Eigen::Isometry3d::Identity());
  for (const int l : order) {
    const int pj = robot.links[static_cast<std::size_t>(l)].parent_joint;
    if (pj < 0) continue;
    const JointDesc& j = robot.joints[static_cast<std::size_t>(pj)];
    X_RL[static_cast<std::size_t>(l)] = X_RL[static_cast<std::size_t>(j.parent_link)] * j.X_PJ;
  }
  return X_RL;
}

}  // namespace

void validateForDynamics(const RobotDescription& robot, bool floating_base) {
  for (std::size_t i = 0; i < robot.links.size(); ++i) {
    const LinkDesc& link = robot.links[i];
    const InertialDesc& in = link.inertial;
    const std::string label = "link \"" + link.name + "\"";
    if (!std::isfinite(in.mass_kg) || !in.p_LCom.allFinite() || !in.I_Com_L.allFinite())
      throw ModelError(robot.source, link.line, label, "inertial values are not finite");
    if (in.mass_kg < 0.0)
      throw ModelError(robot.source, link.line, label, "negative mass");
  }

  // Every joint's motion must move mass, or A has a zero row. Evaluated at q = 0 in the
  // root frame, per joint over its subtree; an independent joint passes when it or one of
  // its mimic followers moves mass.
  const std::vector<int> order = robot.linksParentFirst();
  const std::vector<Eigen::Isometry3d> X_RL = linkPosesAtZero(robot, order);
  // Links welded by fixed joints move as one rigid body, and both backends lump them: the
  // body's inertia has to be physical, not each link's. Robots ship dummy links (a 1e-6 kg
  // root with a singular inertia welded to the trunk, point-mass sensor frames) that only
  // the body's sum makes sense of. A body on a moving joint (or a floating root) needs a
  // positive semi-definite rotational inertia about its centre of mass; rounding in the
  // URDF's digits (a product of inertia of 1e-20 on a point mass) is tolerated.
  std::vector<int> body_of(robot.links.size(), -1);
  std::vector<RigidMass> body(robot.links.size());
  std::vector<int> welded(robot.links.size(), 0);
  for (const int l : order) {
    const auto li = static_cast<std::size_t>(l);
    const int pj = robot.links[li].parent_joint;
    const bool carrier = pj < 0 || robot.joints[static_cast<std::size_t>(pj)].moving();
    const int b = carrier ? l : body_of[static_cast<std::size_t>(robot.joints[static_cast<std::size_t>(pj)].parent_link)];
    body_of[li] = b;
    body[static_cast<std::size_t>(b)].add(robot.links[li].inertial, X_RL[li]);
    if (b != l) ++welded[static_cast<std::size_t>(b)];
  }
  for (const int l : order) {
    const auto li = static_cast<std::size_t>(l);
    if (body_of[li] != l) continue;
    const RigidMass& c = body[li];
    const bool moves = robot.links[li].parent_joint >= 0 || floating_base;
    if (!moves || !(c.mass_kg > 0.0)) continue;  // massless: the joint check below decides
    const Eigen::Vector3d m = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(c.I_Com_F()).eigenvalues();
    if (m[0] >= -std::max(1e-9 * std::abs(m[2]), kMinMovedInertia)) continue;
    const LinkDesc& link = robot.links[li];
    const std::string with =
        welded[li] > 0 ? " (with the " + std::to_string(welded[li]) + " link(s) welded to it)" : std::string();
    throw ModelError(robot.source, link.line, "link \"" + link.name + "\"",
                     "the rigid body's inertia" + with +
                         " is not positive semi-definite (principal moments " + std::to_string(m[0]) +
                         ", " + std::to_string(m[1]) + ", " + std::to_string(m[2]) +
                         " kg m² about its centre of mass)");
  }
  // Subtree composites, children before parents.
  std::vector<RigidMass> subtree(robot.links.size());
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    const auto l = static_cast<std::size_t>(*it);
    subtree[l].add(robot.links[l].inertial, X_RL[l]);
    const int pj = robot.links[l].parent_joint;
    if (pj < 0) continue;
    subtree[static_cast<std::size_t>(robot.joints[static_cast<std::size_t>(pj)].parent_link)].add(subtree[l]);
  }
  std::vector<char> moves_mass(robot.joints.size(), 0);
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    const JointDesc& joint = robot.joints[j];
    if (!joint.moving()) continue;
    const Eigen::Isometry3d X_RJ = X_RL[static_cast<std::size_t>(joint.parent_link)] * joint.X_PJ;
    const double moved = unitMotionInertia(subtree[static_cast<std::size_t>(joint.child_link)],
        joint.type == JointType::kPrismatic, X_RJ.linear() * joint.axis_J, X_RJ.translation());
    moves_mass[j] = moved > kMinMovedInertia;
  }
  for (const int f : robot.mimic_joints)
    if (moves_mass[static_cast<std::size_t>(f)])
      moves_mass[static_cast<std::size_t>(robot.joints[static_cast<std::size_t>(f)].mimic_leader)] = 1;
  for (const int j : robot.moving_joints) {
    const JointDesc& joint = robot.joints[static_cast<std::size_t>(j)];
    if (moves_mass[static_cast<std::size_t>(j)]) continue;
    const LinkDesc& child = robot.links[static_cast<std::size_t>(joint.child_link)];
    throw ModelError(robot.source, joint.line, "joint \"" + joint.name + "\"",
                     std::string(joint.type == JointType::kPrismatic
                                     ? "moves no mass"
                                     : "moves no mass or inertia about its axis") +
                         ": link \"" + child.name +
                         "\" and everything beyond it are massless (the mass matrix would be "
                         "singular; give the links <inertial> data or lock the joint)");
  }
  if (floating_base) {
    const RigidMass& all = subtree[static_cast<std::size_t>(robot.root_link)];
    const LinkDesc& root = robot.links[static_cast<std::size_t>(robot.root_link)];
    bool ok = all.mass_kg > 0.0;
    if (ok) {
      ok = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(all.I_Com_F()).eigenvalues()[0] >
           kMinMovedInertia;
    }
    if (!ok)
      throw ModelError(robot.source, root.line, "link \"" + root.name + "\"",
                       "the floating base carries no mass or no rotational inertia (the whole "
                       "model is massless)");
  }
}

bool warnSingularMassMatrix(RobotDescription& robot) {
  const int nj = static_cast<int>(robot.moving_joints.size());
  if (nj == 0) return false;
  const std::vector<int> order = robot.linksParentFirst();
  const std::vector<Eigen::Isometry3d> X_RL = linkPosesAtZero(robot, order);
  // Twists (ω; v at the root origin, root frame) of each link per unit coordinate rate.
  std::vector<Eigen::Matrix<double, 6, Eigen::Dynamic>> T(robot.links.size(),
                                                           Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, nj));
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(nj, nj);
  for (const int l : order) {
    const auto li = static_cast<std::size_t>(l);
    const int pj = robot.links[li].parent_joint;
    if (pj >= 0) {
      const JointDesc& j = robot.joints[static_cast<std::size_t>(pj)];
      T[li] = T[static_cast<std::size_t>(j.parent_link)];
      const JointDesc& driver = j.mimics() ? robot.joints[static_cast<std::size_t>(j.mimic_leader)] : j;
      if (j.moving() && driver.coordinate >= 0) {
        const double k = j.mimics() ? j.mimic_multiplier : 1.0;
        const Eigen::Vector3d a = X_RL[li].linear() * j.axis_J, o = X_RL[li].translation();
        Eigen::Matrix<double, 6, 1> s;
        if (j.type == JointType::kPrismatic) s << Eigen::Vector3d::Zero(), a;
        else s << a, o.cross(a);
        T[li].col(driver.coordinate) += k * s;
      }
    }
    const InertialDesc& in = robot.links[li].inertial;
    if (!(in.mass_kg > 0.0)) continue;
    // 2 × kinetic energy of the link for twist (ω, v): m|v + ω × c|² + ωᵀ I_c ω.
    const Eigen::Vector3d c = X_RL[li] * in.p_LCom;
    const Eigen::Matrix3d I_c = X_RL[li].linear() * in.I_Com_L * X_RL[li].linear().transpose();
    const Eigen::Matrix<double, 3, Eigen::Dynamic> v_c = T[li].bottomRows<3>() - skew(c) * T[li].topRows<3>();
    A.noalias() += in.mass_kg * v_c.transpose() * v_c;
    A.noalias() += T[li].topRows<3>().transpose() * I_c * T[li].topRows<3>();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(A);
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  const double largest = lambda[nj - 1];
  bool warned = false;
  for (int e = 0; e < nj && lambda[e] <= 1e-9 * largest; ++e) {
    Eigen::VectorXd mode = eig.eigenvectors().col(e);
    Eigen::Index largest_entry = 0;
    mode.cwiseAbs().maxCoeff(&largest_entry);
    if (mode[largest_entry] < 0.0) mode = -mode;  // the sign of its largest entry: +
    std::string joints;
    for (int c = 0; c < nj; ++c) {
      if (std::abs(mode[c]) < 0.1) continue;
      char weight[32];
      std::snprintf(weight, sizeof weight, " (%+.2f)", mode[c]);
      joints += (joints.empty() ? "\"" : ", \"") +
                robot.joints[static_cast<std::size_t>(robot.moving_joints[static_cast<std::size_t>(c)])].name +
                "\"" + weight;
    }
    char numbers[96];
    std::snprintf(numbers, sizeof numbers, "%.2g against a largest %.3g", lambda[e], largest);
    robot.warnings.push_back(robot.source + ": the mass matrix is singular at q = 0: joint(s) " + joints +
                             " together move no inertia (eigenvalue " + numbers +
                             "); forward simulation near this pose is ill-posed in either engine "
                             "(the joints spin up without bound): give the links they move a "
                             "rotational inertia, or lock one of them");
    warned = true;
  }
  return warned;
}

}  // namespace dynfilter::urdf
