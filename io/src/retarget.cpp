#include "dynfilter/io/retarget.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <Eigen/Cholesky>

#include "dynfilter/core/kinematic_tree.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/io/pose_ik.hpp"
#include "limb_scaling.hpp"

namespace dynfilter::io {
namespace {

// ---- decomposition --------------------------------------------------------------------

// Axis index and sign of an axis-aligned unit vector.
void axisIndex(const Eigen::Vector3d& a, int& index, double& sign) {
  a.cwiseAbs().maxCoeff(&index);
  sign = a[index] > 0 ? 1.0 : -1.0;
  if (std::fabs(std::fabs(a[index]) - 1.0) > 1e-6 || (a.cwiseAbs().sum() - 1.0) > 1e-6)
    throw std::invalid_argument("decomposeRotation: axis is not axis-aligned");
}

// Chain mode: largest change of a joint angle between frames accepted from a switch of
// the Tait–Bryan branch made to stay inside the limits (rad).
constexpr double kMaxBranchJumpRad = 0.5;

// IK mode: weight of the base pose target (the root link's), and of the posture term that
// holds unmapped joints (allow_unmapped) at their neutral value.
constexpr double kIkRootWeight = 3.0;
constexpr double kIkUnmappedWeight = 100.0;

// Angles θ (3) of R(θ) = R_a0(θ0) R_a1(θ1) R_a2(θ2) inside the joints' limits nearest to
// @p R in rotation, by damped Gauss–Newton from @p theta (the damping keeps the answer
// near the start where the rotation does not determine it).
void limitedRotationFit(const Eigen::Matrix3d& R, const std::vector<Eigen::Vector3d>& axes,
                        const std::vector<int>& joints, const ModelInfo& info,
                        std::vector<double>& theta) {
  constexpr double kDamping = 1e-2;
  for (int it = 0; it < 30; ++it) {
    Eigen::Matrix3d Ra[3];
    for (int a = 0; a < 3; ++a)
      Ra[a] = Eigen::AngleAxisd(theta[static_cast<std::size_t>(a)], axes[static_cast<std::size_t>(a)]).toRotationMatrix();
    const Eigen::Matrix3d Rt = Ra[0] * Ra[1] * Ra[2];
    const Eigen::Vector3d e = logSO3(Rt.transpose() * R);  // child frame
    Eigen::Matrix3d J;
    J.col(0) = (Ra[1] * Ra[2]).transpose() * axes[0];
    J.col(1) = Ra[2].transpose() * axes[1];
    J.col(2) = axes[2];
    const Eigen::Vector3d d =
        (J.transpose() * J + kDamping * Eigen::Matrix3d::Identity()).ldlt().solve(J.transpose() * e);
    for (int a = 0; a < 3; ++a) {
      const int j = joints[static_cast<std::size_t>(a)];
      theta[static_cast<std::size_t>(a)] =
          std::clamp(theta[static_cast<std::size_t>(a)] + d[a], info.q_lower[j], info.q_upper[j]);
    }
    if (d.lpNorm<Eigen::Infinity>() < 1e-10) break;
  }
}

// The angle in [−π, π).
double wrapAngle(double angle) {
  const double two_pi = 2.0 * M_PI;
  return angle - two_pi * std::floor((angle + M_PI) / two_pi);
}

// A mapped link: its BVH joint, body, calibration and joint group.
struct Segment {
  const RetargetSegment* spec = nullptr;  // null for the root
  std::string link;
  int bvh_joint = -1;
  int body = -1;
  Eigen::Matrix3d C = Eigen::Matrix3d::Identity();
  int parent = -1;                  // nearest mapped ancestor (index into the segments)
  std::vector<int> joints;          // moving joints from the parent's body to this one
  std::vector<Eigen::Vector3d> axes;  // chain mode: their axes in the parent's frame
  int line = 0;
};

}  // namespace

// ---- public ---------------------------------------------------------------------------

std::vector<double> decomposeRotation(const Eigen::Matrix3d& R,
                                      const std::vector<Eigen::Vector3d>& axes, int missing_at) {
  if (axes.empty() || axes.size() > 3)
    throw std::invalid_argument("decomposeRotation: expected 1 to 3 axes");
  if (missing_at != 1 && missing_at != 2)
    throw std::invalid_argument("decomposeRotation: missing_at must be 1 or 2");
  std::vector<int> idx(axes.size());
  std::vector<double> sign(axes.size());
  for (std::size_t a = 0; a < axes.size(); ++a) axisIndex(axes[a], idx[a], sign[a]);
  for (std::size_t a = 0; a < axes.size(); ++a)
    for (std::size_t b = a + 1; b < axes.size(); ++b)
      if (idx[a] == idx[b]) throw std::invalid_argument("decomposeRotation: repeated axis");

  if (axes.size() == 1) {
    const int i = idx[0], j = (i + 1) % 3, k = (i + 2) % 3;
    const double theta = std::atan2(R(k, j) - R(j, k), R(j, j) + R(k, k));
    return {sign[0] * theta};
  }
  if (axes.size() == 2 && missing_at == 1) {
    // R ≈ R_a0(α) · R_c(·) · R_a1(β): decompose in the order (a0, c, a1), drop the middle.
    const Eigen::Vector3d c = Eigen::Vector3d::Unit(3 - idx[0] - idx[1]);
    const std::vector<double> full =
        decomposeRotation(R, {Eigen::Vector3d::Unit(idx[0]), c, Eigen::Vector3d::Unit(idx[1])});
    return {sign[0] * full[0], sign[1] * full[2]};
  }
  const int i = idx[0], j = idx[1];
  const int k = axes.size() == 3 ? idx[2] : 3 - i - j;
  // ε = +1 for a cyclic (i, j, k), −1 otherwise.
  const double eps = ((j - i + 3) % 3 == 1) ? 1.0 : -1.0;
  const double beta = std::asin(std::clamp(eps * R(i, k), -1.0, 1.0));
  const double alpha = std::atan2(-eps * R(j, k), R(k, k));
  const double gamma = std::atan2(-eps * R(i, j), R(i, i));
  std::vector<double> out = {sign[0] * alpha, sign[1] * beta};
  if (axes.size() == 3) out.push_back(sign[2] * gamma);
  return out;
}

namespace {

// Soles flat in stance: a segment mapped onto a link the model stands on at its neutral
// configuration gets its calibration turned (about an axis in the sole's plane) so that,
// over the frames where its BVH joint is low and still, its sole is level on average. A
// skeleton's rest pose says nothing about where its feet are flat; the clip does.
void calibrateSoles(const BvhMotion& bvh, const RetargetMapping& mapping, IDynamicsModel& model,
                    const Eigen::Matrix3d& R_conv, std::vector<Segment>& segs,
                    std::vector<SoleCalibration>& out) {
  constexpr double kLowM = 0.03;        // above the joint's lowest height over the clip
  constexpr double kStillMps = 0.3;     // joint speed
  constexpr int kMinFrames = 10;
  ContactList contacts(256);
  standingContacts(model, model.info().neutralConfiguration(), contacts);
  const int first = mapping.skip_frames;
  const int count = bvh.frameCount() - first;
  std::vector<std::vector<Eigen::Isometry3d>> X(static_cast<std::size_t>(count));
  for (int k = 0; k < count; ++k) bvhForwardKinematics(bvh, first + k, X[static_cast<std::size_t>(k)]);
  for (Segment& S : segs) {
    bool sole = false;
    for (const ContactCandidate& c : contacts) sole = sole || c.body == S.body;
    if (!sole || S.spec == nullptr) continue;
    const std::size_t j = static_cast<std::size_t>(S.bvh_joint);
    double z_low = std::numeric_limits<double>::infinity();
    for (int k = 0; k < count; ++k) z_low = std::min(z_low, (R_conv * X[static_cast<std::size_t>(k)][j].translation()).z());
    // The sole's normal in the link frame: world up at the neutral stance.
    const Eigen::Vector3d n_B = model.bodyPose(S.body).linear().transpose() * Eigen::Vector3d::UnitZ();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int frames = 0;
    for (int k = 1; k + 1 < count; ++k) {
      const Eigen::Vector3d p = R_conv * X[static_cast<std::size_t>(k)][j].translation();
      const Eigen::Vector3d d = X[static_cast<std::size_t>(k + 1)][j].translation() - X[static_cast<std::size_t>(k - 1)][j].translation();
      if (p.z() > z_low + kLowM || d.norm() > 2.0 * bvh.frame_time_s * kStillMps) continue;
      const Eigen::Matrix3d R = R_conv * X[static_cast<std::size_t>(k)][j].linear() * S.C;
      sum += R.transpose() * Eigen::Vector3d::UnitZ();
      ++frames;
    }
    SoleCalibration cal;
    cal.link = S.link;
    cal.stance_frames = frames;
    cal.levelled = frames >= kMinFrames && sum.norm() > 1e-9;
    if (cal.levelled) {
      const Eigen::Vector3d u = sum.normalized();
      cal.angle_rad = std::acos(std::clamp(u.dot(n_B), -1.0, 1.0));
      S.C = S.C * Eigen::Quaterniond::FromTwoVectors(n_B, u).toRotationMatrix();
    }
    out.push_back(cal);
  }
}

}  // namespace

RetargetResult retargetBvh(const BvhMotion& bvh, const RetargetMapping& mapping,
                           IDynamicsModel& model) {
  const ModelInfo& info = model.info();
  if (!info.floating_base)
    throw std::invalid_argument("retargetBvh: the model must have a floating base");
  const int first = mapping.skip_frames;
  const int count = bvh.frameCount() - first;
  if (count < 2)
    throw std::invalid_argument("retargetBvh: " + std::to_string(bvh.frameCount()) +
                                " BVH frames minus skip_frames " + std::to_string(first) +
                                " leave fewer than 2 frames");
  const Eigen::Matrix3d R_conv = mapping.axisConversion();
  const bool ik_mode = mapping.mode == RetargetMode::kIk;

  auto bvhJoint = [&](const std::string& name, int line) {
    const int j = bvh.findJoint(name);
    if (j < 0)
      throw InputError(mapping.source, line,
                       "BVH joint \"" + name + "\" not found in " + bvh.source);
    return j;
  };
  // A mapping most of whose links the model does not have was written for another robot.
  {
    const int total = static_cast<int>(mapping.segments.size()) + 1;
    std::string missing;
    int found = 0, listed = 0;
    auto look = [&](const std::string& link) {
      if (info.findBody(link) >= 0) {
        ++found;
      } else if (missing.size() < 60) {
        missing += (missing.empty() ? "\"" : ", \"") + link + "\"";
        ++listed;
      }
    };
    look(mapping.root_link);
    for (const RetargetSegment& seg : mapping.segments) look(seg.link);
    if (2 * found < total)
      throw InputError(mapping.source, 0,
                       "only " + std::to_string(found) + " of its " + std::to_string(total) +
                           " links are links of model " + info.name + " (not: " + missing +
                           (found + listed < total ? ", ..." : "") + "): a mapping written for another robot?");
  }
  auto body = [&](const std::string& name, int line) {
    const int b = info.findBody(name);
    if (b < 0)
      throw InputError(mapping.source, line, "link \"" + name + "\" not in model " + info.name);
    return b;
  };

  // Rest positions (all rotations zero, OFFSETs as translations), BVH world axes.
  std::vector<Eigen::Vector3d> rest(bvh.joints.size());
  for (std::size_t j = 0; j < bvh.joints.size(); ++j) {
    const BvhJoint& J = bvh.joints[j];
    rest[j] = (J.parent >= 0 ? rest[static_cast<std::size_t>(J.parent)] : Eigen::Vector3d::Zero()) +
              J.offset;
  }
  auto firstChild = [&](int j) {
    for (std::size_t c = static_cast<std::size_t>(j) + 1; c < bvh.joints.size(); ++c)
      if (bvh.joints[c].parent == j) return static_cast<int>(c);
    return -1;
  };

  // Segments: the root first, then the list.
  std::vector<Segment> segs;
  {
    Segment root;
    root.link = mapping.root_link;
    root.bvh_joint = bvhJoint(mapping.root_bvh, 0);
    root.body = body(mapping.root_link, 0);
    root.C = R_conv.transpose();
    segs.push_back(root);
  }
  // The IK mode's targets are world orientations: a link's rest orientation is its own at
  // q = 0 (identity for a URDF whose link frames are aligned at q = 0).
  model.setState(info.neutralConfiguration(), Eigen::VectorXd::Zero(info.nv));
  for (const RetargetSegment& s : mapping.segments) {
    if (s.link == mapping.root_link)
      throw InputError(mapping.source, s.line, "link \"" + s.link + "\" is the root link");
    Segment c;
    c.spec = &s;
    c.link = s.link;
    c.line = s.line;
    c.bvh_joint = bvhJoint(s.bvh, s.line);
    c.body = body(s.link, s.line);
    const Eigen::Matrix3d R_WL0 = ik_mode ? Eigen::Matrix3d(model.bodyPose(c.body).linear()) : Eigen::Matrix3d::Identity();
    Eigen::Matrix3d A = Eigen::Matrix3d::Identity();
    if (s.align) {
      int end = -1;
      if (!s.bone_end.empty()) {
        end = bvhJoint(s.bone_end, s.line);
      } else {
        for (int c2 = firstChild(c.bvh_joint); c2 >= 0; c2 = firstChild(c2)) {
          if ((rest[static_cast<std::size_t>(c2)] - rest[static_cast<std::size_t>(c.bvh_joint)])
                  .norm() > 1e-9) {
            end = c2;
            break;
          }
        }
      }
      if (end < 0)
        throw InputError(mapping.source, s.line,
                         "segment " + s.link + ": BVH joint \"" + s.bvh +
                             "\" has no bone end (set bone_end or align: false)");
      const Eigen::Vector3d bone =
          rest[static_cast<std::size_t>(end)] - rest[static_cast<std::size_t>(c.bvh_joint)];
      if (bone.norm() < 1e-9)
        throw InputError(mapping.source, s.line, "segment " + s.link + ": zero-length bone");
      A = Eigen::Quaterniond::FromTwoVectors(R_WL0 * s.figure_bone, R_conv * bone).toRotationMatrix();
    }
    c.C = R_conv.transpose() * A * R_WL0;
    segs.push_back(c);
  }

  // The tree between mapped links: each segment's nearest mapped ancestor and the moving
  // joints between them.
  const KinematicTree tree = kinematicTreeOf(model);
  if (tree.body_parent_joint[static_cast<std::size_t>(segs[0].body)] >= 0)
    throw InputError(mapping.source, 0,
                     "root.link \"" + mapping.root_link + "\" is moved by joints of model " +
                         info.name + ": map the floating base link (" +
                         info.body_names[static_cast<std::size_t>(tree.base_body)] + ")");
  for (std::size_t c = 1; c < segs.size(); ++c) {
    Segment& C = segs[c];
    std::size_t best_joints = std::numeric_limits<std::size_t>::max();
    for (std::size_t p = 0; p < segs.size(); ++p) {
      if (p == c || !tree.isAncestorOrRigid(segs[p].body, C.body)) continue;
      const std::vector<int> joints = tree.jointsBetween(segs[p].body, C.body);
      if (joints.empty())
        throw InputError(mapping.source, C.line,
                         "link \"" + C.link + "\" is rigidly attached to mapped link \"" +
                             segs[p].link + "\": map only one of them");
      if (joints.size() < best_joints) {
        best_joints = joints.size();
        C.parent = static_cast<int>(p);
        C.joints = joints;
      }
    }
  }

  // Hinge twist: the twist of a segment with `flexion` (a thigh, an upper arm) about its
  // bone is taken from the data so that the BVH's hinge (knee, elbow) bends in the plane
  // of the model's: F = the mean direction (perpendicular to the bone) into which the
  // child bone deflects, over all frames, is mapped onto the flexion direction. Kept as
  // calibrated from the rest pose when the clip hardly bends the joint.
  {
    std::vector<Eigen::Isometry3d> Xh;
    for (std::size_t p = 1; p < segs.size(); ++p) {
      Segment& P = segs[p];
      const RetargetSegment& ps = *P.spec;
      if (!ps.has_flexion) continue;
      int child = -1, children = 0;
      for (std::size_t c = 1; c < segs.size(); ++c)
        if (segs[c].parent == static_cast<int>(p)) {
          child = static_cast<int>(c);
          ++children;
        }
      if (children != 1)
        throw InputError(mapping.source, ps.line,
                         "flexion: link \"" + P.link + "\" needs exactly one mapped child link (has " +
                             std::to_string(children) + ")");
      if (!ps.align || !ps.hinge_twist) continue;
      const Segment& Cc = segs[static_cast<std::size_t>(child)];
      const Eigen::Vector3d& d_p = ps.figure_bone;
      const Eigen::Vector3d& d_c = Cc.spec->figure_bone;
      // Bone of the parent in its BVH joint frame, and the child's bone in the child's.
      const Eigen::Vector3d b_p = (P.C * d_p).normalized();
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double mean_sin = 0.0;
      for (int k = 0; k < count; ++k) {
        bvhForwardKinematics(bvh, first + k, Xh);
        const Eigen::Vector3d u = Xh[static_cast<std::size_t>(P.bvh_joint)].linear().transpose() *
                                  Xh[static_cast<std::size_t>(Cc.bvh_joint)].linear() * (Cc.C * d_c);
        const Eigen::Vector3d w = u - u.dot(b_p) * b_p;
        sum += w;
        mean_sin += w.norm() / count;
      }
      if (mean_sin < std::sin(10.0 * M_PI / 180.0) || sum.norm() < 1e-9) continue;
      // A maps the model's (bone, flexion direction) onto the converted BVH ones.
      const Eigen::Vector3d B = R_conv * b_p;
      const Eigen::Vector3d F = R_conv * sum.normalized();
      const Eigen::Vector3d e3 = d_p.cross(ps.flexion).normalized();
      Eigen::Matrix3d fig, cap;
      fig << d_p, ps.flexion, e3;
      cap << B, F, B.cross(F).normalized();
      P.C = R_conv.transpose() * cap * fig.transpose();
    }
  }

  RetargetResult result;
  if (mapping.flat_soles) calibrateSoles(bvh, mapping, model, R_conv, segs, result.soles);
  std::vector<bool> mapped(static_cast<std::size_t>(info.nj), false);
  for (const Segment& C : segs)
    for (const int j : C.joints) mapped[static_cast<std::size_t>(j)] = true;
  for (int j = 0; j < info.nj; ++j)
    if (!mapped[static_cast<std::size_t>(j)])
      result.unmapped_joints.push_back(info.joint_names[static_cast<std::size_t>(j)]);
  if (!result.unmapped_joints.empty() && !mapping.allow_unmapped) {
    std::string list;
    for (const std::string& j : result.unmapped_joints) list += (list.empty() ? "" : ", ") + j;
    throw InputError(mapping.source, 0,
                     std::to_string(result.unmapped_joints.size()) + " joints of model " +
                         info.name + " are between no two mapped links: " + list +
                         " (map their links, or allow_unmapped: true / --allow-unmapped)");
  }

  // Chain mode: the joints' axes in the parent segment's frame (relative rotation of the
  // two links with one joint moved).
  const Eigen::VectorXd q0 = info.neutralConfiguration();
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
  if (!ik_mode) {
    for (std::size_t c = 1; c < segs.size(); ++c) {
      Segment& C = segs[c];
      if (C.joints.size() > 3)
        throw InputError(mapping.source, C.line,
                         "chain mode: " + std::to_string(C.joints.size()) + " joints between \"" +
                             segs[static_cast<std::size_t>(C.parent)].link + "\" and \"" + C.link +
                             "\" (at most 3; map a link between them, or use mode: ik)");
      for (const int j : C.joints) {
        Eigen::VectorXd q = q0;
        q[info.configurationIndex(j)] = 0.3;
        model.setState(q, v0);
        const Eigen::Matrix3d Rrel =
            model.bodyPose(segs[static_cast<std::size_t>(C.parent)].body).linear().transpose() *
            model.bodyPose(C.body).linear();
        const Eigen::AngleAxisd aa(Rrel);
        const Eigen::Vector3d raw = aa.axis() * (aa.angle() / 0.3);
        Eigen::Vector3d axis = raw;
        for (int i = 0; i < 3; ++i) axis[i] = std::round(axis[i]);
        if ((axis - raw).norm() > 1e-6 || std::fabs(axis.norm() - 1.0) > 1e-9)
          throw InputError(mapping.source, C.line,
                           "chain mode: joint \"" + info.joint_names[static_cast<std::size_t>(j)] +
                               "\" does not turn about an axis of link \"" +
                               segs[static_cast<std::size_t>(C.parent)].link +
                               "\"'s frame at q = 0 (use mode: ik)");
        C.axes.push_back(axis);
      }
    }
  }

  // Base position source: mean of root.position (default: the root joint).
  std::vector<int> base_joints;
  for (const std::string& name : mapping.root_position) base_joints.push_back(bvhJoint(name, 0));
  if (base_joints.empty()) base_joints.push_back(segs[0].bvh_joint);
  auto basePoint = [&](const std::vector<Eigen::Isometry3d>& X) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const int j : base_joints) sum += X[static_cast<std::size_t>(j)].translation();
    return Eigen::Vector3d(sum * (1.0 / static_cast<double>(base_joints.size())));
  };
  auto limitExcess = [&](int j, double x) {
    return std::max({0.0, info.q_lower[j] - x, x - info.q_upper[j]});
  };

  // IK mode: scale, targets and solver settings.
  std::vector<IkTarget> targets;
  std::vector<detail::LimbSegment> limb_segments;  // empty: uniform scaling
  std::vector<detail::LimbAnchor> limb_anchors;
  std::vector<std::size_t> limb_order;
  std::vector<Eigen::Vector3d> placed;
  constexpr int kLimbRounds = 10;
  constexpr double kLimbTolerance_m = 1e-6;
  Eigen::VectorXd posture_weights = Eigen::VectorXd::Zero(info.nv);
  double scale = 1.0;
  if (ik_mode) {
    scale = mapping.ik.scale;
    if (scale == 0.0) {
      model.setState(q0, v0);
      const double z_root = (model.bodyPose(segs[0].body) * mapping.root_offset_xyz).z();
      std::vector<Eigen::Isometry3d> X_rest(bvh.joints.size(), Eigen::Isometry3d::Identity());
      for (std::size_t j = 0; j < bvh.joints.size(); ++j) X_rest[j].translation() = rest[j];
      const double z_root_bvh = (R_conv * basePoint(X_rest)).z();
      double z_low = std::numeric_limits<double>::infinity();
      int lowest = -1;
      for (std::size_t c = 1; c < segs.size(); ++c) {
        const double z = (model.bodyPose(segs[c].body) * segs[c].spec->offset_xyz).z();
        if (z < z_low) {
          z_low = z;
          lowest = static_cast<int>(c);
        }
      }
      const double d_bvh =
          lowest < 0 ? 0.0
                     : z_root_bvh - (R_conv * rest[static_cast<std::size_t>(
                                                  segs[static_cast<std::size_t>(lowest)].bvh_joint)]).z();
      if (lowest < 0 || d_bvh < 1e-6 || z_root - z_low < 1e-6)
        throw InputError(mapping.source, 0,
                         "ik.scale: cannot size the model against the BVH (no mapped link below "
                         "the base position in both); set ik.scale");
      scale = (z_root - z_low) / d_bvh;
    }
    result.ik_scale = scale;
    targets.resize(segs.size());
    for (std::size_t c = 0; c < segs.size(); ++c) {
      IkTarget& t = targets[c];
      t.body = segs[c].body;
      if (c == 0) {
        t.p_BP = mapping.root_offset_xyz;
        t.position_weight = kIkRootWeight;
        t.orientation_weight = kIkRootWeight;
      } else {
        t.p_BP = segs[c].spec->offset_xyz;
        t.position_weight = segs[c].spec->position_weight;
        t.orientation_weight = segs[c].spec->orientation_weight;
      }
    }
    for (int j = 0; j < info.nj; ++j)
      posture_weights[info.velocityIndex(j)] =
          mapped[static_cast<std::size_t>(j)] ? mapping.ik.posture_weight : kIkUnmappedWeight;
    result.targets.resize(segs.size());
    for (std::size_t c = 0; c < segs.size(); ++c) {
      result.targets[c].link = segs[c].link;
      result.targets[c].has_position = targets[c].position_weight > 0;
      result.targets[c].has_orientation = targets[c].orientation_weight > 0;
    }
    if (mapping.ik.limb_scaling) {
      limb_segments.resize(segs.size());
      placed.resize(segs.size());
      for (std::size_t c = 0; c < segs.size(); ++c) {
        detail::LimbSegment& l = limb_segments[c];
        l.bvh_joint = segs[c].bvh_joint;
        l.body = segs[c].body;
        l.parent = segs[c].parent;
        l.joints = segs[c].joints;
        l.p_BP = targets[c].p_BP;
        l.has_position = targets[c].position_weight > 0;
      }
      Eigen::Vector3d rest_base = Eigen::Vector3d::Zero();
      for (const int j : base_joints) rest_base += rest[static_cast<std::size_t>(j)];
      rest_base /= static_cast<double>(base_joints.size());
      limb_anchors = detail::findLimbAnchors(limb_segments, bvh, rest, rest_base, R_conv, scale, tree,
                                             model, q0, limb_order);
      for (std::size_t c = 1; c < segs.size(); ++c) {
        const detail::LimbAnchor& a = limb_anchors[c];
        TargetReport& r = result.targets[c];
        r.limb_from = a.bvh_name;
        r.limb_ratio = a.ratio;
        r.limb_scaled = a.segment >= 0 || a.joint_body >= 0;
      }
    }
  }
  IkOptions ik_options;
  ik_options.max_iterations = mapping.ik.max_iterations;

  // Frames.
  std::vector<ReferenceFrame>& frames = result.motion.frames;
  frames.assign(static_cast<std::size_t>(count), ReferenceFrame(info.nq, info.nv));
  std::vector<Eigen::Isometry3d> X;
  std::vector<Eigen::Matrix3d> R(segs.size());
  Eigen::Quaterniond previous_quat = Eigen::Quaterniond::Identity();
  Eigen::VectorXd q_ik = q0;
  std::vector<double> pos_sq(segs.size(), 0.0), rot_sq(segs.size(), 0.0);
  for (int k = 0; k < count; ++k) {
    bvhForwardKinematics(bvh, first + k, X);
    ReferenceFrame& f = frames[static_cast<std::size_t>(k)];
    f.time_s = k * bvh.frame_time_s;
    for (std::size_t c = 0; c < segs.size(); ++c)
      R[c] = R_conv * X[static_cast<std::size_t>(segs[c].bvh_joint)].linear() * segs[c].C;
    const Eigen::Vector3d base_bvh = basePoint(X);
    f.q.head<3>() = R_conv * base_bvh;
    Eigen::Quaterniond quat(R[0]);
    quat.normalize();
    if (k > 0 && quat.dot(previous_quat) < 0) quat.coeffs() *= -1.0;
    previous_quat = quat;
    f.q[3] = quat.w();
    f.q[4] = quat.x();
    f.q[5] = quat.y();
    f.q[6] = quat.z();

    if (ik_mode) {
      for (std::size_t c = 0; c < segs.size(); ++c) {
        IkTarget& t = targets[c];
        if (c == 0) {
          t.p_WP = scale * f.q.head<3>();
          t.R_WB = R[0];
        } else {
          t.p_WP = scale * (R_conv * X[static_cast<std::size_t>(segs[c].bvh_joint)].translation());
          t.R_WB = R[c] * segs[c].spec->R_offset;
        }
      }
      if (k == 0) {
        q_ik = q0;
        q_ik.head<3>() = targets[0].p_WP - R[0] * targets[0].p_BP;
        q_ik.segment<4>(3) = f.q.segment<4>(3);
      }
      if (limb_segments.empty()) {
        solvePoseIk(model, targets, q0, posture_weights, ik_options, q_ik);
      } else {
        // The anchors (hip and shoulder pivots) move with the solution: place the targets,
        // solve, and place them again from the solution until they stay.
        model.setState(q_ik, v0);
        detail::placeLimbTargets(limb_segments, limb_anchors, limb_order, X, base_bvh, R_conv,
                                 model, targets);
        for (int round = 0; round < kLimbRounds; ++round) {
          solvePoseIk(model, targets, q0, posture_weights, ik_options, q_ik);
          for (std::size_t c = 0; c < segs.size(); ++c) placed[c] = targets[c].p_WP;
          model.setState(q_ik, v0);
          detail::placeLimbTargets(limb_segments, limb_anchors, limb_order, X, base_bvh, R_conv,
                                   model, targets);
          double moved = 0.0;
          for (std::size_t c = 0; c < segs.size(); ++c)
            moved = std::max(moved, (targets[c].p_WP - placed[c]).norm());
          if (moved < kLimbTolerance_m) break;
        }
      }
      for (std::size_t c = 0; c < segs.size(); ++c) {
        double ep = 0.0, er = 0.0;
        ikTargetError(model, targets[c], ep, er);
        TargetReport& r = result.targets[c];
        pos_sq[c] += ep * ep;
        rot_sq[c] += er * er;
        r.position_max_m = std::max(r.position_max_m, ep);
        r.orientation_max_rad = std::max(r.orientation_max_rad, er);
      }
      Eigen::Quaterniond qb(q_ik[3], q_ik[4], q_ik[5], q_ik[6]);
      if (k > 0 && qb.dot(previous_quat) < 0) q_ik.segment<4>(3) *= -1.0;
      previous_quat = Eigen::Quaterniond(q_ik[3], q_ik[4], q_ik[5], q_ik[6]);
      f.q = q_ik;
      continue;
    }

    for (std::size_t c = 1; c < segs.size(); ++c) {
      const Segment& g = segs[c];
      if (g.joints.empty()) continue;
      const Eigen::Matrix3d Rrel = R[static_cast<std::size_t>(g.parent)].transpose() * R[c];
      std::vector<double> angles = decomposeRotation(Rrel, g.axes, 2);
      if (g.axes.size() == 2) {
        // Of the two placements of the missing axis, keep the one that reproduces the
        // child's bone direction better.
        const std::vector<double> middle = decomposeRotation(Rrel, g.axes, 1);
        const Eigen::Vector3d& bone = g.spec->figure_bone;
        auto error = [&](const std::vector<double>& a) {
          const Eigen::Matrix3d Rc = Eigen::AngleAxisd(a[0], g.axes[0]).toRotationMatrix() *
                                     Eigen::AngleAxisd(a[1], g.axes[1]).toRotationMatrix();
          return (Rc * bone - Rrel * bone).norm();
        };
        if (error(middle) < error(angles)) angles = middle;
      }
      // Of the equivalent angle sets — the other Tait–Bryan solution (α + π, π − β, γ + π)
      // and each angle ± 2π — the one nearest to the previous frame; when it leaves the
      // limits or jumps, the other inside the limits without a jump, else the limited fit
      // from the previous frame (keeps a shoulder continuous and limited through its Euler
      // singularity, and a joint past ±π continuous).
      auto choose = [&](std::vector<double>& set, double& excess, double& distance) {
        excess = distance = 0.0;
        for (std::size_t a = 0; a < set.size(); ++a) {
          const int j = g.joints[a];
          const double prev =
              k > 0 ? frames[static_cast<std::size_t>(k - 1)].q[info.configurationIndex(j)] : set[a];
          double best = set[a];
          for (const double shift : {-2.0 * M_PI, 2.0 * M_PI}) {
            const double y = set[a] + shift;
            const double ey = limitExcess(j, y), eb = limitExcess(j, best);
            if (ey < eb - 1e-12 || (ey <= eb + 1e-12 && std::fabs(y - prev) < std::fabs(best - prev)))
              best = y;
          }
          set[a] = best;
          excess += limitExcess(j, best);
          distance += (best - prev) * (best - prev);
        }
      };
      double x_main = 0.0, d_main = 0.0;
      choose(angles, x_main, d_main);
      if (angles.size() == 3) {
        std::vector<double> alt = {wrapAngle(angles[0] + M_PI),
                                   wrapAngle(M_PI * std::copysign(1.0, g.axes[1].sum()) - angles[1]),
                                   wrapAngle(angles[2] + M_PI)};
        double x_alt = 0.0, d_alt = 0.0;
        choose(alt, x_alt, d_alt);
        const bool alt_nearer = k > 0 && d_alt < d_main;
        std::vector<double>& nearer = alt_nearer ? alt : angles;
        std::vector<double>& other = alt_nearer ? angles : alt;
        const double x_nearer = alt_nearer ? x_alt : x_main, x_other = alt_nearer ? x_main : x_alt;
        auto jump = [&](const std::vector<double>& set) {
          double m = 0.0;
          for (std::size_t a = 0; a < 3; ++a)
            m = std::max(m, std::fabs(set[a] - frames[static_cast<std::size_t>(k - 1)]
                                                   .q[info.configurationIndex(g.joints[a])]));
          return m;
        };
        std::vector<double> chosen = nearer;
        if (x_nearer > 0 || (k > 0 && jump(nearer) > kMaxBranchJumpRad)) {
          if (k == 0) {
            if (x_other < x_nearer) chosen = other;
          } else if (x_nearer == 0 && jump(nearer) <= kMaxBranchJumpRad) {
            chosen = nearer;
          } else if (x_other == 0 && jump(other) <= kMaxBranchJumpRad) {
            chosen = other;
          } else {
            // Both outside the limits, or the other branch only by a jump (near the
            // singularity, where the two outer angles trade off): the angles inside the
            // limits nearest in rotation, from the previous frame's, so that the joint
            // stays continuous and inside its limits.
            std::vector<double> theta(3);
            for (std::size_t a = 0; a < 3; ++a) {
              const int j = g.joints[a];
              theta[a] = std::clamp(frames[static_cast<std::size_t>(k - 1)].q[info.configurationIndex(j)],
                                    info.q_lower[j], info.q_upper[j]);
            }
            limitedRotationFit(Rrel, g.axes, g.joints, info, theta);
            chosen = theta;
          }
        }
        angles = chosen;
      }
      for (std::size_t a = 0; a < angles.size(); ++a)
        f.q[info.configurationIndex(g.joints[a])] = angles[a];
    }
    // Unmapped joints at their neutral value.
    for (int j = 0; j < info.nj; ++j)
      if (!mapped[static_cast<std::size_t>(j)])
        f.q[info.configurationIndex(j)] = q0[info.configurationIndex(j)];
  }
  for (std::size_t c = 0; c < result.targets.size(); ++c) {
    result.targets[c].position_rms_m = std::sqrt(pos_sq[c] / count);
    result.targets[c].orientation_rms_rad = std::sqrt(rot_sq[c] / count);
  }

  // Limit report (before any clamping).
  result.limits.resize(static_cast<std::size_t>(info.nj));
  for (int j = 0; j < info.nj; ++j) {
    JointLimitReport& r = result.limits[static_cast<std::size_t>(j)];
    r.joint = info.joint_names[static_cast<std::size_t>(j)];
    const int qi = info.configurationIndex(j);
    r.min_rad = std::numeric_limits<double>::infinity();
    r.max_rad = -std::numeric_limits<double>::infinity();
    double sum_sq = 0.0;
    for (int k = 0; k < count; ++k) {
      const double x = frames[static_cast<std::size_t>(k)].q[qi];
      r.min_rad = std::min(r.min_rad, x);
      r.max_rad = std::max(r.max_rad, x);
      const double excess = limitExcess(j, x);
      sum_sq += excess * excess;
      if (excess > 0) {
        ++r.frames_outside;
        if (excess > r.worst_excess_rad) {
          r.worst_excess_rad = excess;
          r.worst_frame = k;
        }
      }
    }
    r.fraction_outside = static_cast<double>(r.frames_outside) / count;
    r.excess_rms_rad = std::sqrt(sum_sq / count);
  }
  if (mapping.clamp_to_limits) {
    for (ReferenceFrame& f : frames)
      for (int j = 0; j < info.nj; ++j) {
        const int qi = info.configurationIndex(j);
        f.q[qi] = std::clamp(f.q[qi], info.q_lower[j], info.q_upper[j]);
      }
    result.clamped = true;
  }

  // Ground: lowest point over the first frames on the environment.
  double dz = -std::numeric_limits<double>::infinity();
  const int n_ground = std::min(count, mapping.ground_frames);
  for (int k = 0; k < n_ground; ++k) {
    const Eigen::VectorXd& q = frames[static_cast<std::size_t>(k)].q;
    dz = std::max(dz, standingBaseHeight(model, q) - q[2]);
  }
  for (ReferenceFrame& f : frames) f.q[2] += dz;
  result.ground_offset_m = dz;
  result.axis_conversion = R_conv;
  result.first_bvh_frame = first;

  estimateDerivatives(frames, true, mapping.smoothing_window, true, true);
  result.motion.source = bvh.source;
  return result;
}

RetargetResult retargetBvhFile(const std::string& bvh_path, const RetargetMapping& mapping,
                               IDynamicsModel& model, double start_s, double end_s) {
  BvhReadOptions options;
  options.length_scale = mapping.length_scale;
  return retargetBvhWindow(readBvh(bvh_path, options), mapping, model, start_s, end_s);
}

RetargetResult retargetBvhWindow(const BvhMotion& bvh, const RetargetMapping& mapping,
                                 IDynamicsModel& model, double start_s, double end_s) {
  if (start_s == 0.0 && std::isinf(end_s) && end_s > 0.0) return retargetBvh(bvh, mapping, model);
  const BvhMotion window = bvhWindow(bvh, mapping.skip_frames, start_s, end_s);
  RetargetMapping from_window = mapping;
  from_window.skip_frames = 0;  // the window starts after them
  RetargetResult result = retargetBvh(window, from_window, model);
  result.first_bvh_frame = window.skipped_frames - bvh.skipped_frames;
  return result;
}

void writeReferenceMotionCsv(const std::string& path, const ModelInfo& info,
                             const ReferenceMotion& motion) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) throw InputError(path, 0, std::string("cannot write: ") + std::strerror(errno));
  std::fprintf(file, "time,base_x,base_y,base_z,base_qw,base_qx,base_qy,base_qz");
  for (const std::string& name : info.joint_names) std::fprintf(file, ",%s", name.c_str());
  std::fprintf(file, "\n");
  for (const ReferenceFrame& f : motion.frames) {
    std::fprintf(file, "%.17g", f.time_s);
    for (int i = 0; i < f.q.size(); ++i) std::fprintf(file, ",%.17g", f.q[i]);
    std::fprintf(file, "\n");
  }
  const bool failed = std::ferror(file) != 0;
  if (std::fclose(file) != 0 || failed) throw InputError(path, 0, "write failed");
}

std::string formatLimitReport(const RetargetResult& result) {
  std::ostringstream out;
  char line[256];
  int outside = 0;
  double worst = 0.0;
  std::string worst_joint;
  for (const JointLimitReport& r : result.limits) {
    if (r.frames_outside == 0) continue;
    ++outside;
    std::snprintf(line, sizeof line,
                  "  %-18s %5.1f %% of frames outside, worst %6.1f deg beyond (frame %d), "
                  "range [%7.1f, %7.1f] deg\n",
                  r.joint.c_str(), 100.0 * r.fraction_outside, r.worst_excess_rad * 180.0 / M_PI,
                  r.worst_frame, r.min_rad * 180.0 / M_PI, r.max_rad * 180.0 / M_PI);
    out << line;
    if (r.worst_excess_rad > worst) {
      worst = r.worst_excess_rad;
      worst_joint = r.joint;
    }
  }
  std::snprintf(line, sizeof line, "%d of %zu joints leave their limits", outside,
                result.limits.size());
  out << line;
  if (outside > 0) {
    std::snprintf(line, sizeof line, "; worst %.1f deg (%s)", worst * 180.0 / M_PI,
                  worst_joint.c_str());
    out << line;
  }
  double sum_sq = 0.0;
  for (const JointLimitReport& r : result.limits) sum_sq += r.excess_rms_rad * r.excess_rms_rad;
  std::snprintf(line, sizeof line, "; excess %.4f rad RMS over all joints",
                result.limits.empty() ? 0.0 : std::sqrt(sum_sq / static_cast<double>(result.limits.size())));
  out << line;
  out << (result.clamped ? "; values clamped into the limits\n" : "; values NOT clamped\n");
  return out.str();
}

std::string formatTargetReport(const RetargetResult& result) {
  std::ostringstream out;
  char line[256];
  std::snprintf(line, sizeof line, "IK targets (scale %.4f): position RMS / max (mm), orientation RMS / max (deg)\n",
                result.ik_scale);
  out << line;
  for (const TargetReport& t : result.targets) {
    std::string pos = "      -", rot = "      -";
    if (t.has_position) {
      std::snprintf(line, sizeof line, "%7.1f / %7.1f", 1e3 * t.position_rms_m, 1e3 * t.position_max_m);
      pos = line;
    }
    if (t.has_orientation) {
      std::snprintf(line, sizeof line, "%6.1f / %6.1f", t.orientation_rms_rad * 180.0 / M_PI,
                    t.orientation_max_rad * 180.0 / M_PI);
      rot = line;
    }
    std::string limb;
    if (!t.limb_from.empty()) {
      std::snprintf(line, sizeof line, t.limb_scaled ? "   limb x %.3f from %s" : "   uniform (limb x %.3f from %s: out of range)",
                    t.limb_ratio, t.limb_from.c_str());
      limb = line;
    }
    std::snprintf(line, sizeof line, "  %-24s %-17s %-15s%s\n", t.link.c_str(), pos.c_str(), rot.c_str(),
                  limb.c_str());
    out << line;
  }
  return out.str();
}

}  // namespace dynfilter::io
