#include "joint_axes.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>

namespace dynfilter::io::detail {

namespace {
constexpr double kProbeStep = 0.1;  // joint displacement that reveals its axis (rad)
}  // namespace

bool jointAxis(IDynamicsModel& model, const KinematicTree& tree, int j, const Eigen::VectorXd& q,
               AxisLine& line) {
  const ModelInfo& info = model.info();
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
  const int body = tree.joint_child_body[static_cast<std::size_t>(j)];
  model.setState(q, v0);
  const Eigen::Isometry3d X0 = model.bodyPose(body);
  Eigen::VectorXd q1 = q;
  const int qi = info.configurationIndex(j);
  q1[qi] += (q[qi] + kProbeStep <= info.q_upper[j]) ? kProbeStep : -kProbeStep;
  model.setState(q1, v0);
  const Eigen::Isometry3d X1 = model.bodyPose(body);
  model.setState(q, v0);
  const Eigen::Matrix3d R = X1.linear() * X0.linear().transpose();
  const Eigen::AngleAxisd aa(R);
  if (aa.angle() < 0.5 * kProbeStep) return false;
  line.u = aa.axis();
  const Eigen::Vector3d t = X1.translation() - R * X0.translation();
  line.a = (Eigen::Matrix3d::Identity() - R).completeOrthogonalDecomposition().solve(t);
  return true;
}

double distanceToLine(const AxisLine& l, const Eigen::Vector3d& p) {
  const Eigen::Vector3d d = p - l.a;
  return (d - d.dot(l.u) * l.u).norm();
}

bool axesMeet(const std::vector<AxisLine>& lines, Eigen::Vector3d& point_W) {
  if (lines.empty()) return false;
  if (lines.size() == 1) {
    point_W = lines.front().a;
    return true;
  }
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const AxisLine& m : lines) {
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - m.u * m.u.transpose();
    A += P;
    b += P * m.a;
  }
  if (A.fullPivLu().rank() < 3) return false;
  const Eigen::Vector3d p = A.ldlt().solve(b);
  for (const AxisLine& m : lines)
    if (distanceToLine(m, p) >= kAxesMeet_m) return false;
  point_W = p;
  return true;
}

}  // namespace dynfilter::io::detail
