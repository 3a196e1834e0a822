#include "dynfilter/io/retarget.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "dynfilter/core/model_sampling.hpp"

namespace dynfilter::io {
namespace {

// ---- mapping file -------------------------------------------------------------------

class MappingParser {
 public:
  explicit MappingParser(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const YAML::Mark& mark, const std::string& reason) const {
    const int line = mark.is_null() ? 0 : mark.line + 1;
    const int column = mark.is_null() ? 0 : mark.column + 1;
    throw InputError(source_, line, column, reason);
  }

  static int lineOf(const YAML::Node& node) {
    const YAML::Mark m = node.Mark();
    return m.is_null() ? 0 : m.line + 1;
  }

  template <class Handler>
  void readMap(const YAML::Node& node, const std::string& what, const std::set<std::string>& keys,
               Handler&& handle) {
    if (!node.IsMap()) fail(node.Mark(), what + ": expected a map");
    std::set<std::string> seen;
    for (const auto& item : node) {
      if (!item.first.IsScalar()) fail(item.first.Mark(), what + ": keys must be plain names");
      const std::string key = item.first.Scalar();
      if (!keys.count(key)) fail(item.first.Mark(), what + ": unknown key \"" + key + "\"");
      if (!seen.insert(key).second)
        fail(item.first.Mark(), what + ": repeated key \"" + key + "\"");
      handle(key, item.second);
    }
  }

  std::string text(const YAML::Node& v, const std::string& key) const {
    if (!v.IsScalar() || v.Scalar().empty()) fail(v.Mark(), key + ": expected a name");
    return v.Scalar();
  }

  double number(const YAML::Node& v, const std::string& key) const {
    if (!v.IsScalar()) fail(v.Mark(), key + ": expected a number");
    const std::string& s = v.Scalar();
    char* end = nullptr;
    errno = 0;
    const double x = std::strtod(s.c_str(), &end);
    if (s.empty() || end != s.c_str() + s.size() || errno == ERANGE || !std::isfinite(x))
      fail(v.Mark(), key + ": not a finite number: \"" + s + "\"");
    return x;
  }

  int integer(const YAML::Node& v, const std::string& key) const {
    const double x = number(v, key);
    if (x != std::floor(x) || std::fabs(x) > 1e9) fail(v.Mark(), key + ": expected an integer");
    return static_cast<int>(x);
  }

  bool boolean(const YAML::Node& v, const std::string& key) const {
    if (v.IsScalar()) {
      const std::string& s = v.Scalar();
      if (s == "true") return true;
      if (s == "false") return false;
    }
    fail(v.Mark(), key + ": expected true or false");
  }

  Eigen::Vector3d vector3(const YAML::Node& v, const std::string& key) const {
    if (!v.IsSequence() || v.size() != 3) fail(v.Mark(), key + ": expected [x, y, z]");
    Eigen::Vector3d out;
    for (int i = 0; i < 3; ++i) out[i] = number(v[static_cast<std::size_t>(i)], key);
    if (out.norm() < 1e-12) fail(v.Mark(), key + ": zero vector");
    return out;
  }

  RetargetMapping parse(const std::string& yaml_text) {
    YAML::Node root;
    try {
      root = YAML::Load(yaml_text);
    } catch (const YAML::Exception& e) {
      fail(e.mark, "YAML syntax error: " + e.msg);
    }
    RetargetMapping m;
    m.source = source_;
    if (!root.IsMap()) fail(root.Mark(), "expected a map of mapping options");
    bool have_segments = false;
    readMap(root, "mapping",
            {"length_scale", "skip_frames", "up_axis", "bvh_forward", "root", "segments",
             "ground_frames", "smoothing_window", "clamp_to_limits"},
            [&](const std::string& k, const YAML::Node& v) {
              if (k == "length_scale") {
                m.length_scale = number(v, k);
                if (!(m.length_scale > 0)) fail(v.Mark(), "length_scale: must be > 0");
              } else if (k == "skip_frames") {
                m.skip_frames = integer(v, k);
                if (m.skip_frames < 0) fail(v.Mark(), "skip_frames: must be >= 0");
              } else if (k == "up_axis" || k == "bvh_forward") {
                std::string axis = text(v, k);
                if (axis.size() == 1) axis = "+" + axis;
                if (axis.size() != 2 || (axis[0] != '+' && axis[0] != '-') ||
                    (axis[1] != 'x' && axis[1] != 'y' && axis[1] != 'z'))
                  fail(v.Mark(), k + ": expected one of +x, -x, +y, -y, +z, -z");
                (k == "up_axis" ? m.up_axis : m.bvh_forward) = axis;
                if (k == "bvh_forward") forward_mark_ = v.Mark();
              } else if (k == "root") {
                bool have_bvh = false;
                readMap(v, "root", {"bvh", "link"}, [&](const std::string& rk, const YAML::Node& rv) {
                  if (rk == "bvh") {
                    m.root_bvh = text(rv, "root.bvh");
                    have_bvh = true;
                  }
                  if (rk == "link") m.root_link = text(rv, "root.link");
                });
                if (!have_bvh) fail(v.Mark(), "root: missing key \"bvh\"");
              } else if (k == "segments") {
                have_segments = true;
                if (!v.IsSequence()) fail(v.Mark(), "segments: expected a list");
                std::set<std::string> links;
                for (const auto& item : v) {
                  RetargetSegment s;
                  s.line = lineOf(item);
                  readMap(item, "segment",
                          {"link", "bvh", "bone_end", "align", "figure_bone", "hinge_twist"},
                          [&](const std::string& sk, const YAML::Node& sv) {
                            if (sk == "link") s.link = text(sv, sk);
                            if (sk == "bvh") s.bvh = text(sv, sk);
                            if (sk == "bone_end") s.bone_end = text(sv, sk);
                            if (sk == "align") s.align = boolean(sv, sk);
                            if (sk == "hinge_twist") s.hinge_twist = boolean(sv, sk);
                            if (sk == "figure_bone") {
                              s.figure_bone = vector3(sv, sk).normalized();
                              s.has_figure_bone = true;
                            }
                          });
                  if (s.link.empty()) fail(item.Mark(), "segment: missing key \"link\"");
                  if (s.bvh.empty()) fail(item.Mark(), "segment: missing key \"bvh\"");
                  if (!links.insert(s.link).second)
                    fail(item.Mark(), "segment: link \"" + s.link + "\" mapped twice");
                  m.segments.push_back(s);
                }
              } else if (k == "ground_frames") {
                m.ground_frames = integer(v, k);
                if (m.ground_frames < 1) fail(v.Mark(), "ground_frames: must be >= 1");
              } else if (k == "smoothing_window") {
                m.smoothing_window = integer(v, k);
                if (m.smoothing_window < 3 || m.smoothing_window % 2 == 0)
                  fail(v.Mark(), "smoothing_window: must be odd and >= 3");
              } else if (k == "clamp_to_limits") {
                m.clamp_to_limits = boolean(v, k);
              }
            });
    if (!have_segments) fail(root.Mark(), "missing key \"segments\"");
    try {
      m.axisConversion();
    } catch (const std::invalid_argument& e) {
      fail(forward_mark_, e.what());
    }
    return m;
  }

 private:
  std::string source_;
  YAML::Mark forward_mark_ = YAML::Mark::null_mark();
};

Eigen::Vector3d axisVector(const std::string& axis) {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  v[axis[1] - 'x'] = axis[0] == '-' ? -1.0 : 1.0;
  return v;
}

// ---- decomposition --------------------------------------------------------------------

// Axis index and sign of an axis-aligned unit vector.
void axisIndex(const Eigen::Vector3d& a, int& index, double& sign) {
  a.cwiseAbs().maxCoeff(&index);
  sign = a[index] > 0 ? 1.0 : -1.0;
  if (std::fabs(std::fabs(a[index]) - 1.0) > 1e-6 || (a.cwiseAbs().sum() - 1.0) > 1e-6)
    throw std::invalid_argument("decomposeRotation: axis is not axis-aligned");
}

// ---- figure structure -----------------------------------------------------------------

struct JointGroup {
  const char* parent;
  const char* child;
  std::vector<const char*> joints;
};

const std::vector<JointGroup>& humanFigureGroups() {
  static const std::vector<JointGroup> groups = {
      {"pelvis", "torso", {"waist_yaw", "waist_roll", "waist_pitch"}},
      {"torso", "head", {"neck_yaw", "neck_roll", "neck_pitch"}},
      {"pelvis", "l_thigh", {"l_hip_yaw", "l_hip_roll", "l_hip_pitch"}},
      {"l_thigh", "l_shank", {"l_knee"}},
      {"l_shank", "l_foot", {"l_ankle_pitch", "l_ankle_roll"}},
      {"pelvis", "r_thigh", {"r_hip_yaw", "r_hip_roll", "r_hip_pitch"}},
      {"r_thigh", "r_shank", {"r_knee"}},
      {"r_shank", "r_foot", {"r_ankle_pitch", "r_ankle_roll"}},
      {"torso", "l_upper_arm", {"l_shoulder_pitch", "l_shoulder_roll", "l_shoulder_yaw"}},
      {"l_upper_arm", "l_forearm", {"l_elbow", "l_forearm_yaw"}},
      {"l_forearm", "l_hand", {"l_wrist_pitch", "l_wrist_roll"}},
      {"torso", "r_upper_arm", {"r_shoulder_pitch", "r_shoulder_roll", "r_shoulder_yaw"}},
      {"r_upper_arm", "r_forearm", {"r_elbow", "r_forearm_yaw"}},
      {"r_forearm", "r_hand", {"r_wrist_pitch", "r_wrist_roll"}},
  };
  return groups;
}

// The figure's bone direction of a link at q = 0, in the link frame.
Eigen::Vector3d defaultFigureBone(const std::string& link) {
  if (link == "torso" || link == "head" || link == "pelvis") return Eigen::Vector3d::UnitZ();
  if (link.size() > 4 && link.compare(link.size() - 4, 4, "foot") == 0)
    return Eigen::Vector3d::UnitX();
  return -Eigen::Vector3d::UnitZ();
}

// The angle in [−π, π).
double wrapAngle(double angle) {
  const double two_pi = 2.0 * M_PI;
  return angle - two_pi * std::floor((angle + M_PI) / two_pi);
}

struct SegmentCalib {
  int bvh_joint = -1;
  int body = -1;
  Eigen::Matrix3d C = Eigen::Matrix3d::Identity();
};

}  // namespace

// ---- public ---------------------------------------------------------------------------

Eigen::Matrix3d RetargetMapping::axisConversion() const {
  const Eigen::Vector3d up = axisVector(up_axis);
  const Eigen::Vector3d fwd = axisVector(bvh_forward);
  if (std::fabs(up.dot(fwd)) > 0.5)
    throw std::invalid_argument("bvh_forward \"" + bvh_forward +
                                "\" is along up_axis \"" + up_axis + "\"");
  Eigen::Matrix3d R;
  R.row(0) = fwd.transpose();
  R.row(1) = up.cross(fwd).transpose();  // left = up × forward
  R.row(2) = up.transpose();
  return R;
}

RetargetMapping parseRetargetMapping(const std::string& yaml_text, const std::string& source) {
  return MappingParser(source).parse(yaml_text);
}

RetargetMapping readRetargetMapping(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream ss;
  ss << in.rdbuf();
  return parseRetargetMapping(ss.str(), path);
}

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

  auto bvhJoint = [&](const std::string& name, int line) {
    const int j = bvh.findJoint(name);
    if (j < 0)
      throw InputError(mapping.source, line,
                       "BVH joint \"" + name + "\" not found in " + bvh.source);
    return j;
  };
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
  std::map<std::string, SegmentCalib> seg;
  {
    SegmentCalib root;
    root.bvh_joint = bvhJoint(mapping.root_bvh, 0);
    root.body = body(mapping.root_link, 0);
    root.C = R_conv.transpose();
    seg[mapping.root_link] = root;
  }
  for (const RetargetSegment& s : mapping.segments) {
    SegmentCalib c;
    c.bvh_joint = bvhJoint(s.bvh, s.line);
    c.body = body(s.link, s.line);
    Eigen::Matrix3d A = Eigen::Matrix3d::Identity();
    if (s.align && s.link != mapping.root_link) {
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
      const Eigen::Vector3d d_fig = s.has_figure_bone ? s.figure_bone : defaultFigureBone(s.link);
      A = Eigen::Quaterniond::FromTwoVectors(d_fig, R_conv * bone).toRotationMatrix();
    }
    c.C = R_conv.transpose() * A;
    seg[s.link] = c;
  }

  // Hinge twist: the twist of a thigh / upper arm about its bone is taken from the data so
  // that the BVH's knee / elbow bends in the plane of the figure's hinge: F = the mean
  // direction (perpendicular to the bone) into which the child bone deflects, over all
  // frames, is mapped onto the figure's flexion direction (knee −x, elbow +x of the parent
  // frame). Kept as calibrated from the rest pose when the clip hardly bends the joint.
  struct Hinge {
    const char* parent;
    const char* child;
    Eigen::Vector3d flexion_dir;
  };
  const Hinge hinges[] = {{"l_thigh", "l_shank", -Eigen::Vector3d::UnitX()},
                          {"r_thigh", "r_shank", -Eigen::Vector3d::UnitX()},
                          {"l_upper_arm", "l_forearm", Eigen::Vector3d::UnitX()},
                          {"r_upper_arm", "r_forearm", Eigen::Vector3d::UnitX()}};
  {
    std::vector<Eigen::Isometry3d> Xh;
    for (const Hinge& h : hinges) {
      if (!seg.count(h.parent) || !seg.count(h.child)) continue;
      const RetargetSegment* ps = nullptr;
      for (const RetargetSegment& s : mapping.segments)
        if (s.link == h.parent) ps = &s;
      if (ps == nullptr || !ps->align || !ps->hinge_twist) continue;
      SegmentCalib& P = seg[h.parent];
      const SegmentCalib& Cc = seg[h.child];
      const Eigen::Vector3d d_p = ps->has_figure_bone ? ps->figure_bone : defaultFigureBone(h.parent);
      const Eigen::Vector3d d_c = defaultFigureBone(h.child);
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
      // A maps the figure's (bone, flexion direction) onto the converted BVH ones.
      const Eigen::Vector3d B = R_conv * b_p;
      const Eigen::Vector3d F = R_conv * sum.normalized();
      const Eigen::Vector3d e3 = d_p.cross(h.flexion_dir).normalized();
      Eigen::Matrix3d fig, cap;
      fig << d_p, h.flexion_dir.normalized(), e3;
      cap << B, F, B.cross(F).normalized();
      P.C = R_conv.transpose() * cap * fig.transpose();
    }
  }

  // Joint groups with their axes, read from the model (relative rotation of the group's
  // links for a single joint moved).
  struct Group {
    std::string parent, child;
    std::vector<int> joints;
    std::vector<Eigen::Vector3d> axes;
    Eigen::Vector3d child_bone;
  };
  std::vector<Group> groups;
  RetargetResult result;
  std::vector<bool> mapped(static_cast<std::size_t>(info.nj), false);
  {
    const Eigen::VectorXd q0 = info.neutralConfiguration();
    const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
    for (const JointGroup& g : humanFigureGroups()) {
      if (!seg.count(g.parent) || !seg.count(g.child)) continue;
      Group G{g.parent, g.child, {}, {}, defaultFigureBone(g.child)};
      for (const RetargetSegment& s : mapping.segments)
        if (s.link == g.child && s.has_figure_bone) G.child_bone = s.figure_bone;
      for (const char* name : g.joints) {
        const int j = info.findJoint(name);
        if (j < 0)
          throw std::invalid_argument(std::string("retargetBvh: model has no joint ") + name);
        Eigen::VectorXd q = q0;
        q[info.configurationIndex(j)] = 0.3;
        model.setState(q, v0);
        const Eigen::Matrix3d Rrel =
            model.bodyPose(seg[g.parent].body).linear().transpose() *
            model.bodyPose(seg[g.child].body).linear();
        const Eigen::AngleAxisd aa(Rrel);
        Eigen::Vector3d axis = aa.axis() * (aa.angle() / 0.3);
        for (int i = 0; i < 3; ++i) axis[i] = std::round(axis[i]);
        G.joints.push_back(j);
        G.axes.push_back(axis);
        mapped[static_cast<std::size_t>(j)] = true;
      }
      groups.push_back(G);
    }
  }
  for (int j = 0; j < info.nj; ++j)
    if (!mapped[static_cast<std::size_t>(j)])
      result.unmapped_joints.push_back(info.joint_names[static_cast<std::size_t>(j)]);

  // Base position source: mid-hip when both thighs are mapped.
  int hip_l = -1, hip_r = -1;
  if (seg.count("l_thigh") && seg.count("r_thigh")) {
    hip_l = seg["l_thigh"].bvh_joint;
    hip_r = seg["r_thigh"].bvh_joint;
  }
  const int root_joint = seg[mapping.root_link].bvh_joint;

  // Frames.
  std::vector<ReferenceFrame>& frames = result.motion.frames;
  frames.assign(static_cast<std::size_t>(count), ReferenceFrame(info.nq, info.nv));
  std::vector<Eigen::Isometry3d> X;
  Eigen::Quaterniond previous_quat = Eigen::Quaterniond::Identity();
  for (int k = 0; k < count; ++k) {
    bvhForwardKinematics(bvh, first + k, X);
    ReferenceFrame& f = frames[static_cast<std::size_t>(k)];
    f.time_s = k * bvh.frame_time_s;
    std::map<std::string, Eigen::Matrix3d> R;
    for (const auto& [link, c] : seg)
      R[link] = R_conv * X[static_cast<std::size_t>(c.bvh_joint)].linear() * c.C;
    const Eigen::Vector3d p_bvh =
        hip_l >= 0 ? Eigen::Vector3d(0.5 * (X[static_cast<std::size_t>(hip_l)].translation() +
                                            X[static_cast<std::size_t>(hip_r)].translation()))
                   : Eigen::Vector3d(X[static_cast<std::size_t>(root_joint)].translation());
    f.q.head<3>() = R_conv * p_bvh;
    Eigen::Quaterniond quat(R[mapping.root_link]);
    quat.normalize();
    if (k > 0 && quat.dot(previous_quat) < 0) quat.coeffs() *= -1.0;
    previous_quat = quat;
    f.q[3] = quat.w();
    f.q[4] = quat.x();
    f.q[5] = quat.y();
    f.q[6] = quat.z();
    for (const Group& g : groups) {
      const Eigen::Matrix3d Rrel = R[g.parent].transpose() * R[g.child];
      std::vector<double> angles = decomposeRotation(Rrel, g.axes, 2);
      if (g.axes.size() == 2) {
        // Of the two placements of the missing axis, keep the one that reproduces the
        // child's bone direction better.
        const std::vector<double> middle = decomposeRotation(Rrel, g.axes, 1);
        auto error = [&](const std::vector<double>& a) {
          const Eigen::Matrix3d Rc = Eigen::AngleAxisd(a[0], g.axes[0]).toRotationMatrix() *
                                     Eigen::AngleAxisd(a[1], g.axes[1]).toRotationMatrix();
          return (Rc * g.child_bone - Rrel * g.child_bone).norm();
        };
        if (error(middle) < error(angles)) angles = middle;
      }
      if (angles.size() == 3 && k > 0) {
        // The other Tait–Bryan solution (α + π, π − β, γ + π): take the one nearer to the
        // previous frame (matters near the middle axis' ±90°).
        const std::vector<double> alt = {wrapAngle(angles[0] + M_PI),
                                         wrapAngle(M_PI * std::copysign(1.0, g.axes[1].sum()) -
                                                   angles[1]),
                                         wrapAngle(angles[2] + M_PI)};
        double d_main = 0.0, d_alt = 0.0;
        for (std::size_t a = 0; a < 3; ++a) {
          const double prev =
              frames[static_cast<std::size_t>(k - 1)].q[info.configurationIndex(g.joints[a])];
          d_main += std::pow(wrapAngle(angles[a] - prev), 2);
          d_alt += std::pow(wrapAngle(alt[a] - prev), 2);
        }
        if (d_alt < d_main) angles = alt;
      }
      for (std::size_t a = 0; a < angles.size(); ++a)
        f.q[info.configurationIndex(g.joints[a])] = angles[a];
    }
  }

  // Limit report (before any clamping).
  result.limits.resize(static_cast<std::size_t>(info.nj));
  for (int j = 0; j < info.nj; ++j) {
    JointLimitReport& r = result.limits[static_cast<std::size_t>(j)];
    r.joint = info.joint_names[static_cast<std::size_t>(j)];
    const int qi = info.configurationIndex(j);
    r.min_rad = std::numeric_limits<double>::infinity();
    r.max_rad = -std::numeric_limits<double>::infinity();
    for (int k = 0; k < count; ++k) {
      const double x = frames[static_cast<std::size_t>(k)].q[qi];
      r.min_rad = std::min(r.min_rad, x);
      r.max_rad = std::max(r.max_rad, x);
      const double excess = std::max(info.q_lower[j] - x, x - info.q_upper[j]);
      if (excess > 0) {
        ++r.frames_outside;
        if (excess > r.worst_excess_rad) {
          r.worst_excess_rad = excess;
          r.worst_frame = k;
        }
      }
    }
    r.fraction_outside = static_cast<double>(r.frames_outside) / count;
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
                               IDynamicsModel& model) {
  BvhReadOptions options;
  options.length_scale = mapping.length_scale;
  return retargetBvh(readBvh(bvh_path, options), mapping, model);
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
  out << (result.clamped ? "; values clamped into the limits\n" : "; values NOT clamped\n");
  return out.str();
}

}  // namespace dynfilter::io
