#include "dynfilter/io/mapping_suggestion.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "dynfilter/core/kinematic_tree.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/io/input_error.hpp"
#include "joint_axes.hpp"

namespace dynfilter::io {

namespace {

constexpr double kLegLength_m = 0.85;    // thigh and shank of an adult
constexpr double kWristGap_m = 0.05;     // a wrist lies further than this past the elbow ...
constexpr double kWristCluster_m = 0.05; // ... and its joints within this of one another
constexpr double kLegAboveTrunk = 0.1;   // legs hang from at most this × their length above the trunk's origin
constexpr double kKneeRoomRatio = 2.0;   // a knee bends into the side of its range with this × the room of the other
constexpr double kKneeProbe_rad = 0.3;   // how far the knee is bent to see where the foot goes

// ---- the BVH ----------------------------------------------------------------------------

struct BvhSkeleton {
  const BvhMotion& bvh;
  std::vector<Eigen::Vector3d> rest;          // rest-pose positions, file units and axes
  std::vector<std::vector<int>> children;
  std::vector<int> subtree;                   // joints in each subtree (itself included)

  explicit BvhSkeleton(const BvhMotion& b) : bvh(b) {
    const std::size_t n = b.joints.size();
    rest.assign(n, Eigen::Vector3d::Zero());
    children.assign(n, {});
    subtree.assign(n, 1);
    for (std::size_t j = 0; j < n; ++j) {
      const int p = b.joints[j].parent;
      rest[j] = (p >= 0 ? rest[static_cast<std::size_t>(p)] : Eigen::Vector3d::Zero()) + b.joints[j].offset;
      if (p >= 0) children[static_cast<std::size_t>(p)].push_back(static_cast<int>(j));
    }
    for (std::size_t j = n; j-- > 0;)
      if (b.joints[j].parent >= 0) subtree[static_cast<std::size_t>(b.joints[j].parent)] += subtree[j];
  }
  const Eigen::Vector3d& at(int j) const { return rest[static_cast<std::size_t>(j)]; }
  const std::string& name(int j) const { return bvh.joints[static_cast<std::size_t>(j)].name; }
  bool endSite(int j) const { return bvh.joints[static_cast<std::size_t>(j)].end_site; }
  // Joints of j's subtree (j first).
  std::vector<int> below(int j) const {
    std::vector<int> out{j};
    for (std::size_t i = 0; i < out.size(); ++i)
      for (const int c : children[static_cast<std::size_t>(out[i])]) out.push_back(c);
    return out;
  }
  // From j down the child with the largest subtree to a leaf.
  std::vector<int> mainChain(int j) const {
    std::vector<int> out{j};
    while (!children[static_cast<std::size_t>(out.back())].empty()) {
      const auto& c = children[static_cast<std::size_t>(out.back())];
      out.push_back(*std::max_element(c.begin(), c.end(), [&](int a, int b) {
        return subtree[static_cast<std::size_t>(a)] < subtree[static_cast<std::size_t>(b)];
      }));
    }
    return out;
  }
  Eigen::Vector3d centroid(const std::vector<int>& joints) const {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const int j : joints) c += at(j);
    return c / static_cast<double>(joints.size());
  }
};

// The two consecutive bones of @p chain with the largest summed length that both point
// along @p down: index i of the chain's joint where the first starts (the bones are
// chain[i] → chain[i+1] → chain[i+2]), −1 when there are none.
int longestBonePair(const BvhSkeleton& s, const std::vector<int>& chain, const Eigen::Vector3d* down) {
  int best = -1;
  double best_len = 0.0;
  for (std::size_t i = 0; i + 2 < chain.size(); ++i) {
    const Eigen::Vector3d a = s.at(chain[i + 1]) - s.at(chain[i]);
    const Eigen::Vector3d b = s.at(chain[i + 2]) - s.at(chain[i + 1]);
    if (down != nullptr && (a.dot(*down) <= 0.0 || b.dot(*down) <= 0.0)) continue;
    if (a.norm() + b.norm() > best_len) {
      best_len = a.norm() + b.norm();
      best = static_cast<int>(i);
    }
  }
  return best;
}

// The upper arm and the forearm of an arm's chain (from its first joint, a collar bone
// perhaps, to a fingertip): the forearm is the last bone at least half as long as the
// chain's longest (the hand's and fingers' bones after it are short), the upper arm the
// bone before it. Index i as for longestBonePair, −1 when there is no bone before it.
int forearmBefore(const BvhSkeleton& s, const std::vector<int>& chain) {
  double longest = 0.0;
  for (std::size_t i = 0; i + 1 < chain.size(); ++i)
    longest = std::max(longest, (s.at(chain[i + 1]) - s.at(chain[i])).norm());
  for (std::size_t i = chain.size(); i-- > 1;) {
    if ((s.at(chain[i]) - s.at(chain[i - 1])).norm() >= 0.5 * longest)
      return i >= 2 ? static_cast<int>(i) - 2 : -1;
  }
  return -1;
}

// The axis (±x, ±y, ±z) nearest to @p v: its index and sign.
std::string axisName(const Eigen::Vector3d& v, Eigen::Vector3d& snapped) {
  Eigen::Index i = 0;
  v.cwiseAbs().maxCoeff(&i);
  snapped = Eigen::Vector3d::Zero();
  snapped[i] = v[i] >= 0 ? 1.0 : -1.0;
  return std::string(v[i] >= 0 ? "+" : "-") + "xyz"[i];
}

struct BvhLimb {
  int hip_or_shoulder = -1, knee_or_elbow = -1, ankle_or_wrist = -1;
};

struct BvhMatch {
  int root = -1, chest = -1, neck = -1;
  BvhLimb legs[2], arms[2];  // [0]: left, [1]: right
  std::string up, forward;
  Eigen::Vector3d up_axis, forward_axis;  // the same as unit vectors of the BVH's frame
  double length_scale = 1.0;
  std::string units;
};

[[noreturn]] void bvhFails(const BvhMotion& bvh, const std::string& reason) {
  throw InputError(bvh.source, 0, "cannot suggest a mapping: " + reason);
}

BvhMatch matchBvh(const BvhSkeleton& s, std::vector<std::string>& notes) {
  const BvhMotion& bvh = s.bvh;
  BvhMatch m;
  if (bvh.joints.empty()) bvhFails(bvh, "no joints");
  m.root = 0;
  int pelvis = 0;
  while (s.children[static_cast<std::size_t>(pelvis)].size() == 1 &&
         !s.endSite(s.children[static_cast<std::size_t>(pelvis)][0]))
    pelvis = s.children[static_cast<std::size_t>(pelvis)][0];
  std::vector<int> branches = s.children[static_cast<std::size_t>(pelvis)];
  branches.erase(std::remove_if(branches.begin(), branches.end(), [&](int c) { return s.endSite(c); }),
                 branches.end());
  if (branches.size() < 3)
    bvhFails(bvh, "joint \"" + s.name(pelvis) + "\" (the pelvis: the first from the root that branches) has " +
                      std::to_string(branches.size()) + " branches; a spine and two legs are needed");
  const int spine = *std::max_element(branches.begin(), branches.end(), [&](int a, int b) {
    return s.subtree[static_cast<std::size_t>(a)] < s.subtree[static_cast<std::size_t>(b)];
  });
  std::vector<int> others;
  for (const int b : branches)
    if (b != spine) others.push_back(b);
  const Eigen::Vector3d spine_centroid = s.centroid(s.below(spine));
  // Of the other branches, the two reaching furthest from the spine's centroid.
  auto reach = [&](int b) {
    double r = 0.0;
    for (const int j : s.below(b)) r = std::max(r, (s.at(j) - spine_centroid).norm());
    return r;
  };
  std::sort(others.begin(), others.end(), [&](int a, int b) { return reach(a) > reach(b); });
  const int leg_top[2] = {others[0], others[1]};
  std::vector<int> leg_joints = s.below(leg_top[0]);
  for (const int j : s.below(leg_top[1])) leg_joints.push_back(j);
  Eigen::Vector3d up;
  m.up = axisName(spine_centroid - s.centroid(leg_joints), up);
  const Eigen::Vector3d down = -up;

  // Legs: thigh and shank, then the toes' direction for forward.
  std::vector<int> chains[2];
  int pair[2];
  Eigen::Vector3d toes = Eigen::Vector3d::Zero();
  for (int k = 0; k < 2; ++k) {
    chains[k] = s.mainChain(leg_top[k]);
    pair[k] = longestBonePair(s, chains[k], &down);
    if (pair[k] < 0) bvhFails(bvh, "branch \"" + s.name(leg_top[k]) + "\" has no thigh and shank pointing down");
    const int ankle = chains[k][static_cast<std::size_t>(pair[k] + 2)];
    const Eigen::Vector3d foot = s.at(chains[k].back()) - s.at(ankle);
    toes += foot - foot.dot(up) * up;
  }
  if (toes.norm() < 1e-9) bvhFails(bvh, "the feet do not point anywhere along the ground in the rest pose");
  Eigen::Vector3d forward;
  m.forward = axisName(toes, forward);
  m.up_axis = up;
  m.forward_axis = forward;
  const Eigen::Vector3d left = up.cross(forward);
  const double leg_length = (s.at(chains[0][static_cast<std::size_t>(pair[0] + 2)]) - s.at(chains[0][static_cast<std::size_t>(pair[0])])).norm();
  for (int k = 0; k < 2; ++k) {
    const int side = (s.at(chains[k].back()) - s.at(pelvis)).dot(left) >= 0 ? 0 : 1;
    BvhLimb& l = m.legs[side];
    l.hip_or_shoulder = chains[k][static_cast<std::size_t>(pair[k])];
    l.knee_or_elbow = chains[k][static_cast<std::size_t>(pair[k] + 1)];
    l.ankle_or_wrist = chains[k][static_cast<std::size_t>(pair[k] + 2)];
  }
  if (m.legs[0].knee_or_elbow < 0 || m.legs[1].knee_or_elbow < 0)
    bvhFails(bvh, "both legs lie on one side of the pelvis");

  // Units: the common one that makes the legs closest to an adult's.
  struct Unit { double scale; const char* name; };
  const Unit units[] = {{1.0, "m"}, {0.01, "cm"}, {0.001, "mm"}, {0.0254, "inch"},
                        {0.0254 / 0.45, "CMU unit, 1/0.45 inch"}};
  double best = std::numeric_limits<double>::infinity();
  for (const Unit& u : units) {
    const double off = std::fabs(std::log(leg_length * u.scale / kLegLength_m));
    if (off < best) {
      best = off;
      m.length_scale = u.scale;
      m.units = u.name;
    }
  }
  if (best > std::log(1.5)) {
    m.length_scale = kLegLength_m / leg_length;
    m.units = "none of the usual: scaled to legs of 0.85 m";
    notes.push_back("length_scale: no usual unit gives legs of 0.6-1.3 m; set it to the file's unit");
  }

  // Arms: the spine's branches holding its leftmost and rightmost joints.
  const std::vector<int> upper = s.below(spine);
  int extreme[2] = {spine, spine};
  for (const int j : upper) {
    const double y = s.at(j).dot(left);
    if (y > s.at(extreme[0]).dot(left)) extreme[0] = j;
    if (y < s.at(extreme[1]).dot(left)) extreme[1] = j;
  }
  auto path = [&](int j) {  // root to j
    std::vector<int> p;
    for (int k = j; k >= 0; k = bvh.joints[static_cast<std::size_t>(k)].parent) p.push_back(k);
    std::reverse(p.begin(), p.end());
    return p;
  };
  const std::vector<int> pl = path(extreme[0]), pr = path(extreme[1]);
  std::size_t common = 0;
  while (common < pl.size() && common < pr.size() && pl[common] == pr[common]) ++common;
  if (common == 0 || common >= pl.size() || common >= pr.size())
    bvhFails(bvh, "no two arms branch off the spine \"" + s.name(spine) + "\"");
  m.chest = pl[common - 1];
  const int arm_top[2] = {pl[common], pr[common]};
  // The chest's bone: towards the first joint of the neck apart from it (conversions put
  // a neck joint at the chest's own place).
  int neck_size = 0;
  for (const int c : s.children[static_cast<std::size_t>(m.chest)])
    if (c != arm_top[0] && c != arm_top[1] && s.subtree[static_cast<std::size_t>(c)] > neck_size) {
      neck_size = s.subtree[static_cast<std::size_t>(c)];
      m.neck = -1;
      for (const int j : s.mainChain(c))
        if ((s.at(j) - s.at(m.chest)).norm() > 1e-3 * leg_length) {
          m.neck = j;
          break;
        }
    }
  for (int k = 0; k < 2; ++k) {
    const std::vector<int> chain = s.mainChain(arm_top[k]);
    const int i = forearmBefore(s, chain);
    if (i < 0) {
      notes.push_back("arm \"" + s.name(arm_top[k]) + "\": fewer than two bones, not mapped");
      continue;
    }
    m.arms[k].hip_or_shoulder = chain[static_cast<std::size_t>(i)];
    m.arms[k].knee_or_elbow = chain[static_cast<std::size_t>(i + 1)];
    m.arms[k].ankle_or_wrist = chain[static_cast<std::size_t>(i + 2)];
  }
  return m;
}

// ---- the model --------------------------------------------------------------------------

struct ModelLimb {
  int knee_or_elbow_body = -1, foot_or_wrist_body = -1;
};

struct ModelMatch {
  int base = -1, trunk = -1;
  ModelLimb legs[2], arms[2];
  Eigen::Vector3d p_BP_root = Eigen::Vector3d::Zero();  // the base position point, base frame
  std::vector<std::string> unmapped;
  Eigen::Vector3d forward_B = Eigen::Vector3d::UnitX();  // where the model faces, base frame (±x or ±y)
  Eigen::Vector3d up_T = Eigen::Vector3d::UnitZ();       // world up in the trunk link's frame at q = 0
};

// A limb's pivot and its knee or elbow (see the file comment): scanning @p chain from its
// root, the first run of two or more joints whose axes meet; the pivot is where they meet,
// and the knee (elbow) the first joint after it whose axis does not pass through it.
// Returns the knee's index in @p chain, −1 when there is no such run followed by a joint.
int pivotAndBend(IDynamicsModel& model, const KinematicTree& tree, const std::vector<int>& chain,
                 const Eigen::VectorXd& q0, Eigen::Vector3d& pivot_W) {
  std::vector<detail::AxisLine> run;
  for (std::size_t i = 0; i < chain.size(); ++i) {
    detail::AxisLine line;
    if (!detail::jointAxis(model, tree, chain[i], q0, line)) {
      run.clear();
      continue;
    }
    run.push_back(line);
    Eigen::Vector3d p;
    if (detail::axesMeet(run, p)) {
      if (run.size() >= 2) pivot_W = p;
      continue;
    }
    run.pop_back();
    if (run.size() >= 2) return static_cast<int>(i);
    run.assign(1, line);
  }
  return -1;
}

// A leg found on the model: the body it stands on, its knee, its hip's pivot (world).
struct FoundLeg {
  int foot = -1, knee_joint = -1;
  Eigen::Vector3d pivot_W = Eigen::Vector3d::Zero();
};

// Which way the model faces, in its base frame (±x or ±y): a knee bends its foot backwards
// (into the side of its range with more room), whatever the base frame's axes say. Knees
// with no such side: +x, with a note. Poses @p model at @p q0 at rest on return.
Eigen::Vector3d forwardFromKnees(IDynamicsModel& model, const Eigen::VectorXd& q0, const Eigen::Isometry3d& X_WB,
                                 const std::vector<FoundLeg>& legs, std::vector<std::string>& notes) {
  const ModelInfo& info = model.info();
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
  Eigen::Vector3d back_W = Eigen::Vector3d::Zero();
  for (const FoundLeg& leg : legs) {
    const int j = leg.knee_joint;
    const int iq = info.configurationIndex(j);
    const double room_up = info.q_upper[j] - q0[iq], room_down = q0[iq] - info.q_lower[j];
    if (!std::isfinite(room_up) || !std::isfinite(room_down) ||
        std::max(room_up, room_down) < kKneeRoomRatio * std::min(room_up, room_down))
      continue;
    Eigen::VectorXd q = q0;
    q[iq] += room_up > room_down ? std::min(kKneeProbe_rad, 0.5 * room_up) : -std::min(kKneeProbe_rad, 0.5 * room_down);
    model.setState(q, v0);
    const Eigen::Vector3d p_bent = model.bodyPose(leg.foot).translation();
    model.setState(q0, v0);
    const Eigen::Vector3d d = p_bent - model.bodyPose(leg.foot).translation();
    back_W += Eigen::Vector3d(d.x(), d.y(), 0.0);
  }
  Eigen::Vector3d forward_B = Eigen::Vector3d::UnitX();
  if (back_W.norm() > 1e-6) {
    const Eigen::Vector3d f = -(X_WB.rotation().transpose() * back_W);
    axisName(Eigen::Vector3d(f.x(), f.y(), 0.0), forward_B);
  } else {
    notes.push_back("the knees do not say which way the model faces (no range to bend into): its base's +x taken as forward");
  }
  return forward_B;
}

ModelMatch matchModel(IDynamicsModel& model, std::vector<std::string>& notes) {
  const ModelInfo& info = model.info();
  if (!info.floating_base) throw std::invalid_argument("suggestMapping: model " + info.name + " has no floating base");
  ModelMatch m;
  const KinematicTree tree = kinematicTreeOf(model);
  const std::vector<JointGroup> groups = jointGroupsOf(model);
  m.base = tree.base_body;
  m.trunk = chooseTrunkBody(model);
  const Eigen::VectorXd q0 = info.neutralConfiguration();
  ContactList contacts(256);
  standingContacts(model, q0, contacts);
  const std::vector<StandingSole> soles = standingSoles(contacts);
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
  model.setState(q0, v0);
  const Eigen::Isometry3d X_WB = model.bodyPose(m.base);

  auto isLimbRoot = [&](int j, JointGroup g) {
    const int p = tree.joint_parent_joint[static_cast<std::size_t>(j)];
    return groups[static_cast<std::size_t>(j)] == g && (p < 0 || groups[static_cast<std::size_t>(p)] != g);
  };
  // Legs: each ends in the sole it stands on.
  std::vector<FoundLeg> found;
  for (int root = 0; root < info.nj; ++root) {
    if (!isLimbRoot(root, JointGroup::kLeg)) continue;
    // Of the soles this leg moves, the one nearest its root (a foot before its toes).
    int foot = -1;
    std::size_t foot_depth = std::numeric_limits<std::size_t>::max();
    for (const StandingSole& sole : soles) {
      if (!tree.moves(root, sole.body)) continue;
      const std::size_t depth = tree.jointsBetween(m.base, sole.body).size();
      if (depth < foot_depth) {
        foot_depth = depth;
        foot = sole.body;
      }
    }
    if (foot < 0) continue;
    std::vector<int> chain;
    for (const int j : tree.jointsBetween(m.base, foot))
      if (groups[static_cast<std::size_t>(j)] == JointGroup::kLeg) chain.push_back(j);
    FoundLeg leg;
    const int knee = pivotAndBend(model, tree, chain, q0, leg.pivot_W);
    if (knee < 0) {
      notes.push_back("leg to " + info.body_names[static_cast<std::size_t>(foot)] +
                      ": no hip whose axes meet followed by a knee, not mapped");
      continue;
    }
    leg.foot = foot;
    leg.knee_joint = chain[static_cast<std::size_t>(knee)];
    found.push_back(leg);
  }
  auto refuse = [&](const std::string& why) {
    std::string on;
    for (const StandingSole& sole : soles) on += (on.empty() ? "" : ", ") + info.body_names[static_cast<std::size_t>(sole.body)];
    throw std::invalid_argument("suggestMapping: model " + info.name + " does not stand on a left and a right leg: " +
                                why + " (" + (on.empty() ? "it touches no ground: no collision geometry?" : "it stands on " + on) +
                                ")" + (notes.empty() ? "" : "; " + notes.back()));
  };
  if (found.size() != 2) refuse(std::to_string(found.size()) + " legs end in a body it stands on at q = 0");
  model.setState(q0, v0);
  const Eigen::Vector3d hips_W = 0.5 * (found[0].pivot_W + found[1].pivot_W);
  // Limbs that hang from above the trunk's origin are arms (an upper body standing on its hands).
  const double leg_length = hips_W.z() - model.bodyPose(found[0].foot).translation().z();
  const Eigen::Vector3d p_WT = model.bodyPose(m.trunk).translation();
  m.up_T = model.bodyPose(m.trunk).linear().transpose() * Eigen::Vector3d::UnitZ();
  if (hips_W.z() > p_WT.z() + kLegAboveTrunk * leg_length) {
    char above[96];
    std::snprintf(above, sizeof above, "%.3f m above the origin of its trunk link ", hips_W.z() - p_WT.z());
    refuse("the limbs it stands on hang from " + std::string(above) + info.body_names[static_cast<std::size_t>(m.trunk)] +
           ": arms, not legs");
  }

  const Eigen::Vector3d forward_B = forwardFromKnees(model, q0, X_WB, found, notes);
  m.forward_B = forward_B;
  const Eigen::Vector3d left_B = Eigen::Vector3d::UnitZ().cross(forward_B);
  auto sideOf = [&](int body) {
    return (X_WB.inverse() * model.bodyPose(body).translation()).dot(left_B) >= 0 ? 0 : 1;
  };
  for (const FoundLeg& leg : found) {
    ModelLimb& l = m.legs[sideOf(leg.foot)];
    if (l.foot_or_wrist_body >= 0) refuse("both legs lie on one side of its base");
    l.knee_or_elbow_body = tree.joint_child_body[static_cast<std::size_t>(leg.knee_joint)];
    l.foot_or_wrist_body = leg.foot;
    if (tree.jointsBetween(l.knee_or_elbow_body, leg.foot).empty()) {
      notes.push_back("leg to " + info.body_names[static_cast<std::size_t>(leg.foot)] +
                      ": no ankle (the foot is rigid with its shank): the foot alone is mapped");
      l.knee_or_elbow_body = -1;
    }
  }
  m.p_BP_root = X_WB.inverse() * hips_W;

  // Arms: each to the deepest body of its chain, along the heaviest branch.
  for (int root = 0; root < info.nj; ++root) {
    if (!isLimbRoot(root, JointGroup::kArm)) continue;
    std::vector<int> chain{root};
    for (;;) {
      int next = -1;
      for (int j = 0; j < info.nj; ++j)
        if (tree.joint_parent_joint[static_cast<std::size_t>(j)] == chain.back() &&
            (next < 0 || tree.joint_subtree_size[static_cast<std::size_t>(j)] >
                             tree.joint_subtree_size[static_cast<std::size_t>(next)]))
          next = j;
      if (next < 0) break;
      chain.push_back(next);
    }
    const int end = tree.joint_child_body[static_cast<std::size_t>(chain.back())];
    Eigen::Vector3d pivot;
    const int bend = pivotAndBend(model, tree, chain, q0, pivot);
    if (bend < 0) {
      notes.push_back("arm to " + info.body_names[static_cast<std::size_t>(end)] +
                      ": no shoulder whose axes meet followed by an elbow, not mapped");
      continue;
    }
    const int elbow = chain[static_cast<std::size_t>(bend)];
    const int side = sideOf(end);
    ModelLimb& l = m.arms[side];
    if (l.knee_or_elbow_body >= 0) continue;
    l.knee_or_elbow_body = tree.joint_child_body[static_cast<std::size_t>(elbow)];
    model.setState(q0, v0);
    const Eigen::Vector3d elbow_W = model.bodyPose(l.knee_or_elbow_body).translation();
    const auto after = std::find(chain.begin(), chain.end(), elbow) + 1;
    Eigen::Vector3d previous_W = elbow_W;
    bool in_cluster = false;
    for (auto it = after; it != chain.end(); ++it) {
      const int body = tree.joint_child_body[static_cast<std::size_t>(*it)];
      const Eigen::Vector3d p = model.bodyPose(body).translation();
      if (!in_cluster) {
        if ((p - elbow_W).norm() <= kWristGap_m) continue;
        in_cluster = true;
      } else if ((p - previous_W).norm() > kWristCluster_m) {
        break;
      }
      previous_W = p;
      l.foot_or_wrist_body = body;
    }
  }

  // Joints between no two mapped links.
  std::vector<int> mapped_bodies{m.trunk};
  for (const ModelLimb* l : {&m.legs[0], &m.legs[1], &m.arms[0], &m.arms[1]})
    for (const int b : {l->knee_or_elbow_body, l->foot_or_wrist_body})
      if (b >= 0) mapped_bodies.push_back(b);
  std::vector<bool> covered(static_cast<std::size_t>(info.nj), false);
  for (const int b : mapped_bodies)
    for (const int j : tree.jointsBetween(m.base, b)) covered[static_cast<std::size_t>(j)] = true;
  for (int j = 0; j < info.nj; ++j)
    if (!covered[static_cast<std::size_t>(j)]) m.unmapped.push_back(info.joint_names[static_cast<std::size_t>(j)]);
  model.setState(q0, v0);
  return m;
}

// ---- the file ---------------------------------------------------------------------------

std::string quoted(const std::string& name) {
  const bool plain = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
  });
  if (plain) return name;
  std::string out = "\"";
  for (const char c : name) out += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  return out + "\"";
}

std::string number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", std::fabs(x) < 5e-7 ? 0.0 : x);
  return buf;
}

}  // namespace

MappingSuggestion suggestMapping(const BvhMotion& bvh, IDynamicsModel& model, int bvh_skipped_frames) {
  MappingSuggestion out;
  const BvhSkeleton skeleton(bvh);
  const BvhMatch b = matchBvh(skeleton, out.notes);
  const ModelMatch m = matchModel(model, out.notes);
  const ModelInfo& info = model.info();
  auto link = [&](int body) { return quoted(info.body_names[static_cast<std::size_t>(body)]); };
  auto joint = [&](int j) { return quoted(skeleton.name(j)); };

  std::ostringstream y;
  y << "# Suggested by dynfilter-bvh2ref --suggest-mapping from the structure of both skeletons\n"
    << "# (io/mapping_suggestion.hpp): " << bvh.source << " -> " << info.name << ". Review it.\n"
    << "# BVH: up " << b.up << ", forward " << b.forward << " (where the toes point), units: " << b.units
    << "; chest " << skeleton.name(b.chest) << ".\n";
  char scale[32];
  std::snprintf(scale, sizeof scale, "%.17g", b.length_scale);
  y << "length_scale: " << scale << "\n";
  y << "skip_frames: " << bvh_skipped_frames
    << (bvh_skipped_frames > 1   ? "   # a rest pose (T-pose) before the motion, and the frames blending from it\n"
        : bvh_skipped_frames > 0 ? "   # a rest pose (T-pose) before the motion\n"
                                 : "\n");
  // bvh_forward is the BVH axis that becomes the model's +x: the capture's forward turned
  // as the model's forward is turned from +x.
  const Eigen::Vector3d bvh_left = b.up_axis.cross(b.forward_axis);
  const Eigen::Vector3d& f = m.forward_B;
  const Eigen::Vector3d to_model_x = f.x() > 0.5 ? b.forward_axis : f.x() < -0.5 ? Eigen::Vector3d(-b.forward_axis)
                                     : f.y() > 0.5 ? Eigen::Vector3d(-bvh_left) : bvh_left;
  Eigen::Vector3d unused;
  const std::string bvh_forward = axisName(to_model_x, unused);
  if (f.x() < 0.5) {
    Eigen::Vector3d unused_f;
    out.notes.push_back("the model faces " + axisName(f, unused_f) + " of its base frame (its knees bend the other way): bvh_forward is " +
                        bvh_forward + ", the capture's forward " + b.forward + " turned with it");
  }
  y << "up_axis: " << b.up << "\nbvh_forward: " << bvh_forward << "\nmode: ik\n";
  if (!m.unmapped.empty()) {
    y << "allow_unmapped: true   # held at their neutral values:";
    for (const std::string& j : m.unmapped) y << " " << j;
    y << "\n";
  }
  y << "# The base position is the mid-hip; on " << info.name << " that point is at offset_xyz in the base link.\n";
  y << "root: {bvh: " << joint(b.root) << ", link: " << link(m.base) << ", position: ["
    << joint(b.legs[0].hip_or_shoulder) << ", " << joint(b.legs[1].hip_or_shoulder) << "], offset_xyz: ["
    << number(m.p_BP_root.x()) << ", " << number(m.p_BP_root.y()) << ", " << number(m.p_BP_root.z()) << "]}\n";
  y << "segments:\n";
  if (m.trunk != m.base) {
    y << "  - {link: " << link(m.trunk) << ", bvh: " << joint(b.chest);
    if (b.neck >= 0) {
      y << ", bone_end: " << joint(b.neck) << ", figure_bone: [" << number(m.up_T.x()) << ", " << number(m.up_T.y())
        << ", " << number(m.up_T.z()) << "]";
    } else {
      y << ", align: false";
      out.notes.push_back("the chest " + skeleton.name(b.chest) +
                          " has no neck to calibrate against: its rest orientation is taken for the trunk's at q = 0");
    }
    y << ", position_weight: 0, orientation_weight: 1}\n";
  } else {
    out.notes.push_back("the model's arms leave its base: no trunk orientation mapped");
  }
  const char* side[2] = {"left", "right"};
  for (int k = 0; k < 2; ++k) {
    const ModelLimb& l = m.legs[k];
    const BvhLimb& bl = b.legs[k];
    if (l.knee_or_elbow_body >= 0)
      y << "  - {link: " << link(l.knee_or_elbow_body) << ", bvh: " << joint(bl.knee_or_elbow) << "}\n";
    y << "  - {link: " << link(l.foot_or_wrist_body) << ", bvh: " << joint(bl.ankle_or_wrist)
      << ", align: false, orientation_weight: 0.5}\n";
  }
  for (int k = 0; k < 2; ++k) {
    const ModelLimb& l = m.arms[k];
    const BvhLimb& bl = b.arms[k];
    if (l.knee_or_elbow_body < 0 || bl.knee_or_elbow < 0) {
      out.notes.push_back(std::string(side[k]) + " arm: " +
                          (l.knee_or_elbow_body < 0 ? "none on the model" : "none in the BVH") + ", not mapped");
      continue;
    }
    y << "  - {link: " << link(l.knee_or_elbow_body) << ", bvh: " << joint(bl.knee_or_elbow) << "}\n";
    if (l.foot_or_wrist_body >= 0 && !skeleton.endSite(bl.ankle_or_wrist))
      y << "  - {link: " << link(l.foot_or_wrist_body) << ", bvh: " << joint(bl.ankle_or_wrist)
        << ", position_weight: 0.5}\n";
  }
  out.yaml = y.str();
  return out;
}

}  // namespace dynfilter::io
