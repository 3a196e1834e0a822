#include "dynfilter/core/virtual_links.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dynfilter/core/lie_group.hpp"

namespace dynfilter {
namespace {

constexpr double kLiftedPairMaxDepth = 0.005;  // m
constexpr double kRollingSinkDepth = 0.002;    // m: a rolling sole sinking deeper gets its face back
constexpr double kSlideSpeed = 0.01;  // m/s: out of the reference's stance, a point this fast slides
constexpr double kStickSpeed = 0.05;  // m/s: in the reference's stance, a slide goes on above this
constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kApproachSpeed = 0.01;  // m/s: a released pair moving into the surface this fast re-engages


}  // namespace

int constrainedAxes(ContactKind kind, std::array<int, 6>& axes) {
  switch (kind) {
    case ContactKind::kPoint:
      axes = {0, 1, 2, 0, 0, 0};
      return 3;
    case ContactKind::kEdge:  // free rotation about the edge (x)
      axes = {0, 1, 2, 4, 5, 0};
      return 5;
    case ContactKind::kFace:
      axes = {0, 1, 2, 3, 4, 5};
      return 6;
  }
  return 0;
}

VirtualLinkSet::VirtualLinkSet(const ContactOptions& options, int nv)
    : options_(options),
      links_(static_cast<std::size_t>(options.max_links)),
      released_(static_cast<std::size_t>(2 * options.max_links + 8)),
      grouped_(256, 0),
      J_(6, nv) {}

void VirtualLinkSet::clear() {
  size_ = 0;
  num_released_ = 0;
}

void VirtualLinkSet::reanchor(const IDynamicsModel& model) {
  for (int i = 0; i < size_; ++i) {
    VirtualLink& link = links_[static_cast<std::size_t>(i)];
    link.X_WA = model.bodyPose(link.body) * link.X_BC;
  }
}

void VirtualLinkSet::releaseAll() {
  for (int i = 0; i < size_ && num_released_ < static_cast<int>(released_.size()); ++i) {
    const VirtualLink& link = links_[static_cast<std::size_t>(i)];
    if (!isReleased(link.body, link.object))
      released_[static_cast<std::size_t>(num_released_++)] = {link.body, link.object, link.X_BC, link.X_WA, false};
  }
  size_ = 0;
}

int VirtualLinkSet::numRows() const {
  int rows = 0;
  for (int i = 0; i < size_; ++i) rows += links_[static_cast<std::size_t>(i)].num_axes;
  return rows;
}

int VirtualLinkSet::findLink(int body, int object) const {
  for (int i = 0; i < size_; ++i) {
    const VirtualLink& l = links_[static_cast<std::size_t>(i)];
    if (l.body == body && l.object == object) return i;
  }
  return -1;
}

bool VirtualLinkSet::makeLink(const IDynamicsModel& model, const ContactList& candidates,
                              int body, int object, VirtualLink& link) const {
  // Average normal and depth of the pair's points.
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  double depth = 0.0;
  int count = 0;
  for (const ContactCandidate& c : candidates) {
    if (c.body != body || c.object != object) continue;
    n += c.n_W;
    depth += c.depth_m;
    ++count;
  }
  if (count == 0 || n.norm() < 1e-9) return false;
  n.normalize();
  depth /= count;

  const Eigen::Isometry3d X_WB = model.bodyPose(body);
  const Eigen::Vector3d t1 = contactTangent(n, X_WB.linear().col(0));
  const Eigen::Vector3d t2 = n.cross(t1);
  // Farthest pair in the contact plane, centroid of the points.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  const ContactCandidate* first = nullptr;
  const ContactCandidate* far_a = nullptr;
  const ContactCandidate* far_b = nullptr;
  double far_d = -1.0;
  for (const ContactCandidate& a : candidates) {
    if (a.body != body || a.object != object) continue;
    centroid += a.p_WC;
    if (first == nullptr) first = &a;
    for (const ContactCandidate& b : candidates) {
      if (b.body != body || b.object != object) continue;
      const Eigen::Vector3d d = b.p_WC - a.p_WC;
      const double planar = std::hypot(t1.dot(d), t2.dot(d));
      if (planar > far_d) {
        far_d = planar;
        far_a = &a;
        far_b = &b;
      }
    }
  }
  centroid /= count;

  Eigen::Vector3d x_axis = t1;
  Eigen::Vector3d origin = centroid;
  if (far_d < options_.merge_distance_m) {
    link.kind = ContactKind::kPoint;
  } else {
    const Eigen::Vector3d d = far_b->p_WC - far_a->p_WC;
    const Eigen::Vector3d edge = (t1 * t1.dot(d) + t2 * t2.dot(d)).normalized();
    double off_line = 0.0;
    for (const ContactCandidate& c : candidates) {
      if (c.body != body || c.object != object) continue;
      const Eigen::Vector3d r = c.p_WC - far_a->p_WC;
      const Eigen::Vector3d planar = t1 * t1.dot(r) + t2 * t2.dot(r);
      off_line = std::max(off_line, (planar - edge * edge.dot(planar)).norm());
    }
    if (off_line < options_.merge_distance_m) {
      link.kind = ContactKind::kEdge;
      x_axis = edge;
      origin = 0.5 * (far_a->p_WC + far_b->p_WC);
    } else {
      link.kind = ContactKind::kFace;
    }
  }
  // Support rectangle of the points in the link frame's xy, about its origin.
  const Eigen::Vector3d y_axis = n.cross(x_axis);
  link.support_min.setZero();
  link.support_max.setZero();
  if (link.kind != ContactKind::kPoint) {
    link.support_min.setConstant(std::numeric_limits<double>::infinity());
    link.support_max.setConstant(-std::numeric_limits<double>::infinity());
    for (const ContactCandidate& c : candidates) {
      if (c.body != body || c.object != object) continue;
      const Eigen::Vector3d r = c.p_WC - origin;
      const Eigen::Vector2d xy(x_axis.dot(r), link.kind == ContactKind::kFace ? y_axis.dot(r) : 0.0);
      link.support_min = link.support_min.cwiseMin(xy);
      link.support_max = link.support_max.cwiseMax(xy);
    }
  }
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear().col(0) = x_axis;
  X_WC.linear().col(1) = n.cross(x_axis);
  X_WC.linear().col(2) = n;
  X_WC.translation() = origin;
  link.body = body;
  link.object = object;
  link.X_BC = X_WB.inverse() * X_WC;
  link.X_WA = X_WC;
  link.X_WA.translation() = origin + n * depth;  // on the environment's surface
  link.num_axes = constrainedAxes(link.kind, link.axes);
  link.low_force_ticks = 0;
  link.created_this_tick = true;
  link.normal_force_n = 0.0;
  link.releasing = false;
  link.release_elapsed_s = 0.0;
  link.release_start_force_n = 0.0;
  link.torsion_n_m = 0.0;
  link.yaw_slip = 0;
  return true;
}

void VirtualLinkSet::makeFace(int i, const Eigen::Isometry3d& X_BC, const Eigen::Isometry3d& X_WA,
                              const Eigen::Vector2d& support_min, const Eigen::Vector2d& support_max) {
  VirtualLink& link = links_[static_cast<std::size_t>(i)];
  link.kind = ContactKind::kFace;
  link.X_BC = X_BC;
  link.X_WA = X_WA;
  link.support_min = support_min;
  link.support_max = support_max;
  link.num_axes = constrainedAxes(link.kind, link.axes);
  link.rolling = false;
  link.yaw_slip = 0;
  link.created_this_tick = true;
}

void VirtualLinkSet::makeRollingEdge(int i, const Eigen::Isometry3d& X_BC, const Eigen::Isometry3d& X_WA,
                                     double x_min, double x_max) {
  VirtualLink& link = links_[static_cast<std::size_t>(i)];
  link.kind = ContactKind::kEdge;
  link.X_BC = X_BC;
  link.X_WA = X_WA;
  link.support_min = Eigen::Vector2d(x_min, 0.0);
  link.support_max = Eigen::Vector2d(x_max, 0.0);
  link.num_axes = constrainedAxes(link.kind, link.axes);
  link.rolling = true;
  link.yaw_slip = 0;
  link.created_this_tick = true;
}

bool VirtualLinkSet::isReleased(int body, int object) const {
  for (int r = 0; r < num_released_; ++r) {
    const ReleasedPair& pair = released_[static_cast<std::size_t>(r)];
    if (pair.body == body && pair.object == object) return true;
  }
  return false;
}

int VirtualLinkSet::update(const IDynamicsModel& model, const ContactList& candidates,
                           std::uint32_t& status) {
  for (int i = 0; i < size_; ++i) links_[static_cast<std::size_t>(i)].created_this_tick = false;

  // Released pairs: forget those that no longer touch, and those that penetrate again.
  int kept = 0;
  for (int r = 0; r < num_released_; ++r) {
    const ReleasedPair pair = released_[static_cast<std::size_t>(r)];
    double depth = -1.0;
    bool approaching = false;
    for (const ContactCandidate& c : candidates) {
      if (c.body != pair.body || c.object != pair.object) continue;
      depth = std::max(depth, c.depth_m);
      if (pair.reference_lifted && !approaching)  // only a lifted pair asks
        approaching = c.n_W.dot(model.pointVelocity(c.body, c.p_WC)) < -kApproachSpeed;
    }
    // A pair the reference lifts stays free while it does not move into the surface, unless it
    // sinks deeper than kLiftedPairMaxDepth: no body passes through the floor.
    if (depth >= 0.0 && (depth < options_.reengage_depth_m ||
                         (pair.reference_lifted && !approaching && depth < kLiftedPairMaxDepth)))
      released_[static_cast<std::size_t>(kept++)] = pair;
  }
  num_released_ = kept;

  const std::size_t n = std::min(candidates.size(), grouped_.size());
  std::fill(grouped_.begin(), grouped_.begin() + static_cast<std::ptrdiff_t>(n), 0);
  int created = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (grouped_[i]) continue;
    const int body = candidates[i].body;
    const int object = candidates[i].object;
    for (std::size_t j = i; j < n; ++j)
      if (candidates[j].body == body && candidates[j].object == object) grouped_[j] = 1;
    if (isReleased(body, object)) continue;
    VirtualLink fresh;
    if (!makeLink(model, candidates, body, object, fresh)) continue;
    const int existing = findLink(body, object);
    if (existing >= 0) {
      VirtualLink& held = links_[static_cast<std::size_t>(existing)];
      // A rolling sole keeps its edge unless the rest of the sole sinks into the surface:
      // then it has landed and rolls no more (its points near the surface join next tick).
      if (held.rolling)
        for (const ContactCandidate& c : candidates)
          if (c.body == body && c.object == object && c.depth_m > kRollingSinkDepth) held.rolling = false;
      if (static_cast<int>(fresh.kind) > static_cast<int>(held.kind) && !held.rolling) {  // upgrade
        fresh.reference_stance = held.reference_stance;
        fresh.stance_seen = held.stance_seen;
        held = fresh;
        ++created;
      }
    } else if (size_ < static_cast<int>(links_.size())) {
      fresh.reference_stance = inReferenceStance(body);
      fresh.stance_seen = fresh.reference_stance;
      links_[static_cast<std::size_t>(size_++)] = fresh;
      ++created;
    } else {
      status |= kStatusContactOverflow;
    }
  }
  if (candidates.overflow() > 0 || candidates.size() > grouped_.size())
    status |= kStatusContactOverflow;
  return created;
}

void VirtualLinkSet::assemble(const IDynamicsModel& model, Eigen::Ref<Eigen::MatrixXd> H_C,
                              Eigen::Ref<Eigen::VectorXd> u_C) {
  const Eigen::Ref<const Eigen::VectorXd> v = model.v();
  int row = 0;
  for (int i = 0; i < size_; ++i) {
    VirtualLink& link = links_[static_cast<std::size_t>(i)];
    const Eigen::Vector3d& p_BC = link.X_BC.translation();
    model.pointJacobian(link.body, p_BC, J_);
    const Vector6d drift_W = model.pointJacobianDotTimesV(link.body, p_BC);
    const Eigen::Isometry3d X_WC = model.bodyPose(link.body) * link.X_BC;
    if (link.yaw_slip != 0) {
      // A pivot moves the anchor's yaw with the body (the yaw row below then has no error).
      const Eigen::Matrix3d R_AC = link.X_WA.linear().transpose() * X_WC.linear();
      const double yaw = std::atan2(R_AC(1, 0) - R_AC(0, 1), R_AC(0, 0) + R_AC(1, 1));
      link.X_WA.linear() = link.X_WA.linear() * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    }
    if (sliding_enabled_) decideSlide(link, X_WC.translation(), J_.topRows<3>() * v);
    const Eigen::Matrix3d R_AW = link.X_WA.linear().transpose();
    Vector6d error_A, drift_A;
    error_A.head<3>() = R_AW * (X_WC.translation() - link.X_WA.translation());
    error_A.tail<3>() = logSO3(R_AW * X_WC.linear());
    drift_A.head<3>() = R_AW * drift_W.head<3>();
    drift_A.tail<3>() = R_AW * drift_W.tail<3>();
    for (int k = 0; k < link.num_axes; ++k) {
      const int axis = link.axes[static_cast<std::size_t>(k)];
      const Eigen::Matrix3d& R = R_AW;
      if (axis < 3) {
        H_C.row(row).noalias() = R.row(axis) * J_.topRows<3>();
      } else {
        H_C.row(row).noalias() = R.row(axis - 3) * J_.bottomRows<3>();
      }
      const double velocity = H_C.row(row).dot(v);
      // A pivot goes on while the body still turns against the twist friction gives.
      if (axis == 5 && link.yaw_slip != 0)
        link.yaw_slip = velocity * link.yaw_slip < -kPivotRestRate ? (velocity > 0.0 ? -1 : 1) : 0;
      const bool slides = axis < 2 && !link.slide_A.isZero();
      const double desired = slides ? 0.0
                                    : -options_.stabilization_kd * velocity -
                                          options_.stabilization_kp * error_A[axis];
      u_C[row] = desired - drift_A[axis];
      ++row;
    }
  }
}

bool VirtualLinkSet::anySliding() const {
  for (int i = 0; i < size_; ++i)
    if (!links_[static_cast<std::size_t>(i)].slide_A.isZero()) return true;
  return false;
}

void VirtualLinkSet::decideSlide(VirtualLink& link, const Eigen::Vector3d& p_WC,
                                 const Eigen::Vector3d& v_WC) const {
  const Eigen::Matrix3d R_AW = link.X_WA.linear().transpose();
  const Eigen::Vector2d v_t = (R_AW * v_WC).head<2>();
  const double speed = v_t.norm();
  const bool was_sliding = !link.slide_A.isZero();
  const bool slides = speed > (link.reference_stance ? (was_sliding ? kStickSpeed : kInfinity) : kSlideSpeed);
  link.slide_A = slides ? Eigen::Vector2d(v_t / speed) : Eigen::Vector2d::Zero();
  // Sliding, or stopping: the anchor's origin is where the point is (no pull back).
  if (slides || was_sliding) {
    Eigen::Vector3d offset_A = R_AW * (p_WC - link.X_WA.translation());
    offset_A.z() = 0.0;
    link.X_WA.translation() += link.X_WA.linear() * offset_A;
  }
}

int VirtualLinkSet::impactRows(const Eigen::Ref<const Eigen::MatrixXd>& H_C,
                               Eigen::Ref<Eigen::MatrixXd> H_out) const {
  int row = 0, kept = 0;
  for (int i = 0; i < size_; ++i) {
    const VirtualLink& link = links_[static_cast<std::size_t>(i)];
    for (int k = 0; k < link.num_axes; ++k, ++row) {
      if (k < 2 && !link.slide_A.isZero()) continue;
      H_out.row(kept++) = H_C.row(row);
    }
  }
  return kept;
}

void VirtualLinkSet::applyReferenceSchedule(const BodySet& stance_bodies) {
  schedule_applied_ = true;
  stance_bodies_ = stance_bodies;
  // A link the reference lifts is let go only once another held link carries the load
  // the reference puts on its stance bodies (or the reference has none: flight): the
  // figure does not lose all support while its next foot is still in the air.
  bool other_support = stance_bodies.none();
  for (int i = 0; i < size_; ++i)
    other_support = other_support || inReferenceStance(links_[static_cast<std::size_t>(i)].body);
  for (int i = 0; i < size_; ++i) {
    VirtualLink& link = links_[static_cast<std::size_t>(i)];
    link.reference_stance = inReferenceStance(link.body);
    link.stance_seen = link.stance_seen || link.reference_stance;
    if (link.releasing || !link.stance_seen || link.reference_stance || !other_support) continue;
    link.releasing = true;
    link.release_elapsed_s = 0.0;
    link.release_start_force_n = link.normal_force_n;
  }
  for (int r = 0; r < num_released_; ++r) {
    ReleasedPair& pair = released_[static_cast<std::size_t>(r)];
    pair.reference_lifted = !inReferenceStance(pair.body);
  }
}

int VirtualLinkSet::startLiftoffReleases(const IDynamicsModel& model, double clearance_m) {
  for (int r = 0; r < num_released_; ++r) {
    ReleasedPair& pair = released_[static_cast<std::size_t>(r)];
    if (!pair.reference_lifted) continue;
    const Eigen::Vector3d p_WC = (model.bodyPose(pair.body) * pair.X_BC).translation();
    pair.reference_lifted =
        pair.X_WA.linear().col(2).dot(p_WC - pair.X_WA.translation()) > 0.5 * clearance_m;
  }
  int started = 0;
  for (int i = 0; i < size_; ++i) {
    VirtualLink& link = links_[static_cast<std::size_t>(i)];
    if (link.releasing) continue;
    const Eigen::Vector3d p_WC = (model.bodyPose(link.body) * link.X_BC).translation();
    const double height = link.X_WA.linear().col(2).dot(p_WC - link.X_WA.translation());
    if (height > clearance_m) {
      link.releasing = true;
      link.release_elapsed_s = 0.0;
      link.release_start_force_n = link.normal_force_n;
      ++started;
    }
  }
  return started;
}

double VirtualLinkSet::normalForceUpperBound(int i, double min_force_n, double transition_s) const {
  const VirtualLink& link = links_[static_cast<std::size_t>(i)];
  if (!link.releasing) return std::numeric_limits<double>::infinity();
  const double remaining =
      transition_s > 0.0 ? std::max(0.0, 1.0 - link.release_elapsed_s / transition_s) : 0.0;
  return std::max(min_force_n, link.release_start_force_n * remaining);
}

int VirtualLinkSet::finishTick(const IDynamicsModel& model,
                               const Eigen::Ref<const Eigen::VectorXd>& tau_C,
                               std::vector<ContactOutput>& contacts, bool allow_release,
                               double low_force_n, double dt_s, double transition_s) {
  int row = 0;
  int written = 0;
  int kept = 0;
  for (int i = 0; i < size_; ++i) {
    VirtualLink& link = links_[static_cast<std::size_t>(i)];
    Vector6d wrench_A = Vector6d::Zero();
    for (int k = 0; k < link.num_axes; ++k) wrench_A[link.axes[static_cast<std::size_t>(k)]] = tau_C[row++];
    if (written < static_cast<int>(contacts.size())) {
      ContactOutput& out = contacts[static_cast<std::size_t>(written++)];
      const Eigen::Matrix3d& R_WA = link.X_WA.linear();
      out.body = link.body;
      out.object = link.object;
      out.kind = link.kind;
      out.p_WC = (model.bodyPose(link.body) * link.X_BC).translation();
      out.n_W = R_WA.col(2);
      out.wrench_W.head<3>() = R_WA * wrench_A.head<3>();
      out.wrench_W.tail<3>() = R_WA * wrench_A.tail<3>();
      out.normal_force_n = wrench_A[2];
      out.support_min_A = link.support_min;
      out.support_max_A = link.support_max;
      out.pivot = link.yaw_slip;
      out.slide_W = R_WA.leftCols<2>() * link.slide_A;
      out.cop_A.setZero();
      if (link.kind != ContactKind::kPoint && wrench_A[2] > 1e-9)
        out.cop_A = Eigen::Vector2d(-wrench_A[4] / wrench_A[2], wrench_A[3] / wrench_A[2]);
    }
    link.normal_force_n = wrench_A[2];
    link.torsion_n_m = wrench_A[5];
    link.low_force_ticks = wrench_A[2] < low_force_n ? link.low_force_ticks + 1 : 0;
    bool ramp_done = false;
    if (link.releasing) {
      link.release_elapsed_s += dt_s;
      // Done once a solve has run with the bound at the minimum (elapsed = transition).
      ramp_done = link.release_elapsed_s >= transition_s + 0.5 * dt_s;
    }
    const bool release =
        allow_release &&
        ((link.low_force_ticks >= options_.release_ticks && !link.reference_stance) || ramp_done);
    if (release && num_released_ < static_cast<int>(released_.size())) {
      released_[static_cast<std::size_t>(num_released_++)] = {link.body, link.object, link.X_BC,
                                                               link.X_WA, link.releasing};
      continue;
    }
    links_[static_cast<std::size_t>(kept++)] = link;
  }
  size_ = kept;
  return written;
}

}  // namespace dynfilter
