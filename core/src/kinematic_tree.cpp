#include "dynfilter/core/kinematic_tree.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace dynfilter {
namespace {

// The body whose origin is highest in the model's present state (the first among equals).
int highestBody(const IDynamicsModel& model) {
  int highest = 0;
  double z_max = -1e300;
  for (int b = 0; b < static_cast<int>(model.info().body_names.size()); ++b) {
    const double z = model.bodyPose(b).translation().z();
    if (z > z_max + 1e-12) {
      z_max = z;
      highest = b;
    }
  }
  return highest;
}

}  // namespace

bool KinematicTree::moves(int j, int b) const {
  for (int k = body_parent_joint[static_cast<std::size_t>(b)]; k >= 0;
       k = joint_parent_joint[static_cast<std::size_t>(k)])
    if (k == j) return true;
  return false;
}

bool KinematicTree::isAncestorOrRigid(int ancestor, int body) const {
  const int pa = body_parent_joint[static_cast<std::size_t>(ancestor)];
  if (pa < 0) return true;
  return moves(pa, body);
}

bool KinematicTree::posesFreely(int body) const {
  return static_cast<int>(jointsBetween(base_body, body).size()) >= kJointsToPoseFreely;
}

std::vector<int> KinematicTree::jointsBetween(int ancestor, int body) const {
  if (!isAncestorOrRigid(ancestor, body))
    throw std::invalid_argument("KinematicTree: body " + std::to_string(ancestor) +
                                " is not on the path of body " + std::to_string(body) +
                                " to the root");
  const int stop = body_parent_joint[static_cast<std::size_t>(ancestor)];
  std::vector<int> out;
  for (int k = body_parent_joint[static_cast<std::size_t>(body)]; k != stop;
       k = joint_parent_joint[static_cast<std::size_t>(k)])
    out.push_back(k);
  std::reverse(out.begin(), out.end());
  return out;
}

KinematicTree kinematicTreeOf(IDynamicsModel& model) {
  const ModelInfo& info = model.info();
  const int nb = static_cast<int>(info.body_names.size());
  const Eigen::VectorXd q0 = info.neutralConfiguration();
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
  model.setState(q0, v0);
  std::vector<Eigen::Isometry3d> X0(static_cast<std::size_t>(nb));
  for (int b = 0; b < nb; ++b) X0[static_cast<std::size_t>(b)] = model.bodyPose(b);

  // moved[j][b]: joint j moves body b; shift[j][b]: how far b's origin moved.
  std::vector<std::vector<char>> moved(static_cast<std::size_t>(info.nj),
                                       std::vector<char>(static_cast<std::size_t>(nb), 0));
  std::vector<std::vector<double>> shift(static_cast<std::size_t>(info.nj),
                                         std::vector<double>(static_cast<std::size_t>(nb), 0.0));
  KinematicTree tree;
  tree.joint_subtree_size.assign(static_cast<std::size_t>(info.nj), 0);
  constexpr double kStep = 0.1, kTol = 1e-9;
  for (int j = 0; j < info.nj; ++j) {
    Eigen::VectorXd q = q0;
    const int qi = info.configurationIndex(j);
    q[qi] += (q0[qi] + kStep <= info.q_upper[j]) ? kStep : -kStep;
    model.setState(q, v0);
    for (int b = 0; b < nb; ++b) {
      const Eigen::Isometry3d X = model.bodyPose(b);
      const Eigen::Isometry3d& Y = X0[static_cast<std::size_t>(b)];
      const double dp = (X.translation() - Y.translation()).norm();
      const double dr = (X.linear() - Y.linear()).norm();
      if (dp > kTol || dr > kTol) {
        moved[static_cast<std::size_t>(j)][static_cast<std::size_t>(b)] = 1;
        shift[static_cast<std::size_t>(j)][static_cast<std::size_t>(b)] = dp;
        ++tree.joint_subtree_size[static_cast<std::size_t>(j)];
      }
    }
  }
  model.setState(q0, v0);

  auto deepest = [&](int b, int excluded) {
    int best = -1;
    for (int j = 0; j < info.nj; ++j) {
      if (j == excluded || !moved[static_cast<std::size_t>(j)][static_cast<std::size_t>(b)]) continue;
      if (best < 0 || tree.joint_subtree_size[static_cast<std::size_t>(j)] <
                          tree.joint_subtree_size[static_cast<std::size_t>(best)])
        best = j;
    }
    return best;
  };
  tree.body_parent_joint.resize(static_cast<std::size_t>(nb));
  for (int b = 0; b < nb; ++b) tree.body_parent_joint[static_cast<std::size_t>(b)] = deepest(b, -1);

  tree.joint_child_body.assign(static_cast<std::size_t>(info.nj), -1);
  tree.joint_parent_joint.assign(static_cast<std::size_t>(info.nj), -1);
  for (int j = 0; j < info.nj; ++j) {
    int child = -1;
    for (int b = 0; b < nb; ++b) {
      if (tree.body_parent_joint[static_cast<std::size_t>(b)] != j) continue;
      if (child < 0 || shift[static_cast<std::size_t>(j)][static_cast<std::size_t>(b)] <
                           shift[static_cast<std::size_t>(j)][static_cast<std::size_t>(child)] - kTol)
        child = b;
    }
    if (child < 0)
      throw std::invalid_argument("kinematicTreeOf: joint \"" +
                                  info.joint_names[static_cast<std::size_t>(j)] +
                                  "\" of model \"" + info.name + "\" moves no body of its own");
    tree.joint_child_body[static_cast<std::size_t>(j)] = child;
  }
  for (int j = 0; j < info.nj; ++j)
    tree.joint_parent_joint[static_cast<std::size_t>(j)] =
        deepest(tree.joint_child_body[static_cast<std::size_t>(j)], j);

  if (info.floating_base) {
    for (int b = 0; b < nb && tree.base_body < 0; ++b) {
      const Eigen::Isometry3d& X = X0[static_cast<std::size_t>(b)];
      if (tree.body_parent_joint[static_cast<std::size_t>(b)] < 0 && X.translation().norm() < kTol &&
          (X.linear() - Eigen::Matrix3d::Identity()).norm() < kTol)
        tree.base_body = b;
    }
    if (tree.base_body < 0)
      throw std::invalid_argument("kinematicTreeOf: no body of model \"" + info.name +
                                  "\" is at the base pose");
  }
  return tree;
}

namespace {

// chooseTrunkBody on a tree already found; leaves the model at its neutral configuration.
int trunkBodyOf(IDynamicsModel& model, const KinematicTree& tree) {
  const ModelInfo& info = model.info();
  model.setState(info.neutralConfiguration(), Eigen::VectorXd::Zero(info.nv));
  std::vector<int> children(static_cast<std::size_t>(info.nj), 0);
  for (int j = 0; j < info.nj; ++j)
    if (tree.joint_parent_joint[static_cast<std::size_t>(j)] >= 0)
      ++children[static_cast<std::size_t>(tree.joint_parent_joint[static_cast<std::size_t>(j)])];
  if (!info.floating_base) {
    int deepest = -1, depth_max = -1;
    for (int j = 0; j < info.nj; ++j) {
      int depth = 0;
      for (int k = j; k >= 0; k = tree.joint_parent_joint[static_cast<std::size_t>(k)]) ++depth;
      if (depth > depth_max) {
        depth_max = depth;
        deepest = j;
      }
    }
    return deepest < 0 ? 0 : tree.joint_child_body[static_cast<std::size_t>(deepest)];
  }
  for (const int j : tree.jointsBetween(tree.base_body, highestBody(model)))
    if (children[static_cast<std::size_t>(j)] >= 2) return tree.joint_child_body[static_cast<std::size_t>(j)];
  return tree.base_body;
}

}  // namespace

int chooseTrunkBody(IDynamicsModel& model) { return trunkBodyOf(model, kinematicTreeOf(model)); }

const char* toString(JointGroup group) {
  switch (group) {
    case JointGroup::kSpine: return "spine";
    case JointGroup::kLeg: return "legs";
    case JointGroup::kArm: return "arms";
    case JointGroup::kOther: break;
  }
  return "other";
}

std::vector<JointGroup> jointGroupsOf(IDynamicsModel& model) {
  const ModelInfo& info = model.info();
  std::vector<JointGroup> groups(static_cast<std::size_t>(info.nj), JointGroup::kOther);
  if (!info.floating_base || info.nj == 0) return groups;
  const KinematicTree tree = kinematicTreeOf(model);
  const int trunk = trunkBodyOf(model, tree);  // leaves the base at the origin
  const int nb = static_cast<int>(info.body_names.size());
  double z_lo = 1e300, z_hi = -1e300, y_max = 0.0;
  for (int b = 0; b < nb; ++b) {
    const Eigen::Vector3d p = model.bodyPose(b).translation();
    z_lo = std::min(z_lo, p.z());
    z_hi = std::max(z_hi, p.z());
    y_max = std::max(y_max, std::abs(p.y()));
  }
  for (const int j : tree.jointsBetween(tree.base_body, trunk))
    groups[static_cast<std::size_t>(j)] = JointGroup::kSpine;
  const auto onSpine = [&](int j) {
    return j >= 0 && groups[static_cast<std::size_t>(j)] == JointGroup::kSpine;
  };
  // Each limb's root: the first joint off the base-to-trunk path on its chain.
  std::vector<int> root(static_cast<std::size_t>(info.nj), -1);
  for (int j = 0; j < info.nj; ++j) {
    if (onSpine(j)) continue;
    int r = j;
    for (int p = tree.joint_parent_joint[static_cast<std::size_t>(r)]; p >= 0 && !onSpine(p);
         p = tree.joint_parent_joint[static_cast<std::size_t>(r)])
      r = p;
    root[static_cast<std::size_t>(j)] = r;
  }
  for (int j = 0; j < info.nj; ++j) {
    if (root[static_cast<std::size_t>(j)] != j) continue;
    double z_min = 1e300;
    for (int b = 0; b < nb; ++b)
      if (tree.moves(j, b)) z_min = std::min(z_min, model.bodyPose(b).translation().z());
    const double y_root =
        std::abs(model.bodyPose(tree.joint_child_body[static_cast<std::size_t>(j)]).translation().y());
    JointGroup& g = groups[static_cast<std::size_t>(j)];
    if (z_min <= z_lo + 0.25 * (z_hi - z_lo))
      g = JointGroup::kLeg;
    else if (y_root <= 0.2 * y_max)
      g = JointGroup::kSpine;  // a limb on the midline: neck and head
    else
      g = JointGroup::kArm;
  }
  for (int j = 0; j < info.nj; ++j)
    if (root[static_cast<std::size_t>(j)] >= 0 && root[static_cast<std::size_t>(j)] != j)
      groups[static_cast<std::size_t>(j)] = groups[static_cast<std::size_t>(root[static_cast<std::size_t>(j)])];
  return groups;
}

}  // namespace dynfilter
