#include "limb_scaling.hpp"

#include <cmath>
#include <functional>
#include <numeric>

#include "joint_axes.hpp"

namespace dynfilter::io::detail {

namespace {
constexpr double kMinRatioOfUniform = 0.5;
constexpr double kMaxRatioOfUniform = 2.0;
constexpr double kMinLength_m = 1e-6;

constexpr double kMovesPoint_m = 0.01;   // a joint whose axis passes closer does not move the point

Eigen::Vector3d pointOf(const IDynamicsModel& model, const LimbSegment& s) {
  return model.bodyPose(s.body) * s.p_BP;
}

// The pivot of a limb at q0 (see the file comment; world): where the axes of the last
// joints of the chain (root to leaf) that move the point p_W (world, at q0) meet, and the
// body it is fixed in. False when no joint of the chain moves the point. Leaves the model
// at q0.
bool limbPivot(IDynamicsModel& model, const KinematicTree& tree, const std::vector<int>& chain,
               const Eigen::Vector3d& p_W, const Eigen::VectorXd& q0, Eigen::Vector3d& pivot_W,
               int& body) {
  model.setState(q0, Eigen::VectorXd::Zero(model.info().nv));
  std::vector<AxisLine> lines;
  std::vector<int> joints;
  for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
    AxisLine l;
    if (!jointAxis(model, tree, *it, q0, l)) break;
    if (distanceToLine(l, p_W) < kMovesPoint_m) continue;
    lines.push_back(l);
    if (lines.size() >= 2) {
      Eigen::Vector3d p;
      if (!axesMeet(lines, p)) {
        lines.pop_back();
        break;
      }
      pivot_W = p;
    }
    joints.push_back(*it);
  }
  if (joints.empty()) return false;
  body = tree.joint_child_body[static_cast<std::size_t>(joints.back())];
  if (lines.size() == 1) pivot_W = model.bodyPose(body).translation();
  return true;
}

}  // namespace

std::vector<LimbAnchor> findLimbAnchors(const std::vector<LimbSegment>& segments,
                                        const BvhMotion& bvh,
                                        const std::vector<Eigen::Vector3d>& rest,
                                        const Eigen::Vector3d& rest_base,
                                        const Eigen::Matrix3d& R_conv, double uniform_scale,
                                        const KinematicTree& tree, IDynamicsModel& model,
                                        const Eigen::VectorXd& q0, std::vector<std::size_t>& order) {
  model.setState(q0, Eigen::VectorXd::Zero(model.info().nv));
  std::vector<LimbAnchor> anchors(segments.size());
  for (std::size_t c = 1; c < segments.size(); ++c) {
    const LimbSegment& s = segments[c];
    if (!s.has_position || s.parent < 0) continue;
    const int ja = bvh.joints[static_cast<std::size_t>(s.bvh_joint)].parent;
    if (ja < 0) continue;
    const LimbSegment& P = segments[static_cast<std::size_t>(s.parent)];
    LimbAnchor a;
    a.bvh_name = bvh.joints[static_cast<std::size_t>(ja)].name;
    Eigen::Vector3d anchor_model, anchor_rest;
    if (ja == P.bvh_joint) {
      a.segment = s.parent;
      a.bvh_joint = s.parent == 0 ? -1 : ja;
      anchor_model = pointOf(model, P);
      anchor_rest = s.parent == 0 ? rest_base : rest[static_cast<std::size_t>(ja)];
    } else if (limbPivot(model, tree, s.joints, pointOf(model, s), q0, anchor_model, a.joint_body)) {
      a.p_BA = model.bodyPose(a.joint_body).inverse() * anchor_model;
      a.bvh_joint = ja;
      anchor_rest = rest[static_cast<std::size_t>(ja)];
    } else {
      continue;
    }
    const double length_model = (pointOf(model, s) - anchor_model).norm();
    const double length_bvh = (R_conv * (rest[static_cast<std::size_t>(s.bvh_joint)] - anchor_rest)).norm();
    if (length_model < kMinLength_m || length_bvh < kMinLength_m) continue;
    const double ratio = length_model / length_bvh;
    if (ratio < kMinRatioOfUniform * uniform_scale || ratio > kMaxRatioOfUniform * uniform_scale) {
      anchors[c].bvh_name = a.bvh_name;  // reported as kept uniform
      anchors[c].ratio = ratio;
      continue;
    }
    a.ratio = ratio;
    anchors[c] = a;
  }
  // Anchor segments before the segments placed from them.
  std::vector<int> depth(segments.size(), -1);
  std::function<int(std::size_t)> depthOf = [&](std::size_t c) -> int {
    if (depth[c] >= 0) return depth[c];
    const int a = anchors[c].segment;
    depth[c] = a < 0 ? 0 : depthOf(static_cast<std::size_t>(a)) + 1;
    return depth[c];
  };
  order.resize(segments.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  for (std::size_t c = 0; c < segments.size(); ++c) depthOf(c);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t x, std::size_t y) { return depth[x] < depth[y]; });
  return anchors;
}

void placeLimbTargets(const std::vector<LimbSegment>& segments,
                      const std::vector<LimbAnchor>& anchors, const std::vector<std::size_t>& order,
                      const std::vector<Eigen::Isometry3d>& X, const Eigen::Vector3d& base_bvh,
                      const Eigen::Matrix3d& R_conv, const IDynamicsModel& model,
                      std::vector<IkTarget>& targets) {
  for (const std::size_t c : order) {
    const LimbAnchor& a = anchors[c];
    if (a.segment < 0 && a.joint_body < 0) continue;
    Eigen::Vector3d anchor_W;
    if (a.segment >= 0) {
      const std::size_t p = static_cast<std::size_t>(a.segment);
      anchor_W = targets[p].position_weight > 0 ? targets[p].p_WP : pointOf(model, segments[p]);
    } else {
      anchor_W = model.bodyPose(a.joint_body) * a.p_BA;
    }
    const Eigen::Vector3d from = a.bvh_joint >= 0 ? X[static_cast<std::size_t>(a.bvh_joint)].translation() : base_bvh;
    targets[c].p_WP =
        anchor_W + a.ratio * (R_conv * (X[static_cast<std::size_t>(segments[c].bvh_joint)].translation() - from));
  }
}

}  // namespace dynfilter::io::detail
