#include "dynfilter/core/balance.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "dynfilter/core/kinematic_tree.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/core/polygon.hpp"

namespace dynfilter {
namespace {

using polygon::clampToHull;
using polygon::convexHull;

constexpr double kMinHeight = 0.2;  // m: the LIPM height never below this
constexpr double kInfeasibleAfterS = 0.25;  // s the reference must look infeasible
constexpr double kReferenceFlatRad = 0.1;  // a reference sole this close to its surface is flat
constexpr double kRollLookaheadS = 0.25;   // a face rolls only when the reference lifts it this soon

// Poses @p model at rest in its neutral configuration standing on the ground plane, turned
// so that its up is the plane's normal, and sunk @p depth_m into it along the normal: the
// collision engine then reports every point of a level sole within that depth of its lowest.
// (Sunk by a leg's length, engines reported a thin sole's top face with garbage depths and
// filled the candidate list.) Leaves the model there with its contacts in @p scratch.
constexpr double kStandsOnDepth_m = 0.01;    // a body this close to the lowest point is stood on
constexpr double kFootprintDepth_m = 0.0025;  // the face: points within 2 mm of a sole's lowest
constexpr double kAnkleOffCentre = 0.05;      // of the sole's length: an ankle this far from its middle marks the heel
void poseNeutralOnGround(IDynamicsModel& model, double depth_m, ContactList& scratch) {
  const ModelInfo& info = model.info();
  const GroundPlane& ground = model.environment().ground;
  Eigen::VectorXd q = info.neutralConfiguration();
  const Eigen::Quaterniond up_to_normal = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), ground.n_W);
  q[3] = up_to_normal.w();
  q[4] = up_to_normal.x();
  q[5] = up_to_normal.y();
  q[6] = up_to_normal.z();
  q[2] = standingBaseHeightOnGround(model, q);
  q.head<3>() -= depth_m * ground.n_W;
  model.setState(q, Eigen::VectorXd::Zero(info.nv));
  model.detectContacts(scratch);
}

}  // namespace

CentroidalState centroidalState(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                const Eigen::Ref<const Eigen::VectorXd>& q,
                                const Eigen::Ref<const Eigen::VectorXd>& v, double mass_kg) {
  // A's top-left 6×6 is the composite spatial inertia at the base origin in base axes:
  // [[m I, −m [c]×], [m [c]×, Ī]]; A's first six rows times v are the spatial momentum.
  CentroidalState s;
  const Eigen::Matrix3d S = A.block<3, 3>(3, 0) / mass_kg;  // [c_B]×
  const Eigen::Vector3d c_B(0.5 * (S(2, 1) - S(1, 2)), 0.5 * (S(0, 2) - S(2, 0)),
                            0.5 * (S(1, 0) - S(0, 1)));
  const Eigen::Matrix3d R_WB =
      Eigen::Quaterniond(q[3], q[4], q[5], q[6]).normalized().toRotationMatrix();
  const Eigen::Vector3d h_lin = A.topRows<3>() * v;
  const Eigen::Vector3d h_ang = A.middleRows<3>(3) * v;
  s.c_W = q.head<3>() + R_WB * c_B;
  s.cdot_W = R_WB * h_lin / mass_kg;
  s.L_W = R_WB * (h_ang - c_B.cross(h_lin));
  return s;
}

const char* toString(InfeasibleReason reason) {
  switch (reason) {
    case InfeasibleReason::kNone: return "";
    case InfeasibleReason::kNoSupport:
      return "the reference needs a supporting force and no body of it is near the ground "
             "(hanging in the air)";
    case InfeasibleReason::kOutsideCone:
      return "the force the reference needs lies outside the friction cone of its support "
             "(ground too steep or too slippery)";
  }
  return "unknown";
}

BalanceLayer::BalanceLayer(IDynamicsModel& model, const BalanceOptions& options)
    : options_(options),
      info_(model.info()),
      mass_kg_(std::max(model.info().total_mass, 1e-9)),
      soles_(options.soles),
      ring_(static_cast<std::size_t>(options.preview_capacity)),
      A_(Eigen::MatrixXd::Zero(model.nv(), model.nv())),
      J_(Matrix6Xd::Zero(6, model.nv())),
      candidates_(64),
      q_lowered_(Eigen::VectorXd::Zero(model.nq())) {
  const ModelInfo& info = model.info();
  if (!info.floating_base) throw std::invalid_argument("the balance layer needs a floating base");
  if (static_cast<int>(info.body_names.size()) > kMaxSetBodies)
    throw std::invalid_argument("the balance layer tracks the stance of at most " + std::to_string(kMaxSetBodies) +
                                " bodies; model \"" + info.name + "\" has " + std::to_string(info.body_names.size()));
  for (const SoleOptions& sole : soles_) {
    const int body = info.findBody(sole.body);
    if (body < 0)
      throw std::invalid_argument("filter option balance.soles: \"" + sole.body +
                                  "\" is not a link of model \"" + info.name + "\"");
    sole_bodies_.push_back(body);
  }
  if (soles_.empty() && model.environment().has_ground) {
    // The bodies the model stands on: its neutral configuration on the ground, sunk 1 cm.
    const Eigen::VectorXd q_saved = model.q(), v_saved = model.v();
    poseNeutralOnGround(model, kStandsOnDepth_m, candidates_);
    for (const ContactCandidate& c : candidates_) {
      if (c.object != kGroundObject) continue;
      if (std::find(sole_bodies_.begin(), sole_bodies_.end(), c.body) != sole_bodies_.end()) continue;
      SoleOptions sole;
      sole.body = info.body_names[static_cast<std::size_t>(c.body)];
      // Out of the sole: up in the neutral configuration (posed with up on the ground's normal).
      sole.n_B = model.bodyPose(c.body).linear().transpose() * model.environment().ground.n_W;
      soles_.push_back(sole);
      sole_bodies_.push_back(c.body);
    }
    model.setState(q_saved, v_saved);
  }
  for (SoleOptions& sole : soles_) sole.n_B.normalize();
  const KinematicTree tree = kinematicTreeOf(model);
  for (const int body : sole_bodies_)
    sole_free_.push_back(tree.posesFreely(body) ? 1 : 0);
  sole_refs_.resize(soles_.size());
  footprints_.resize(soles_.size());
  if (model.environment().has_ground && !soles_.empty()) {
    // Footprints: the neutral configuration on the ground, sunk 2.5 mm (every corner of a
    // level sole is reported); a sole's face is its points lowest along its normal (within 2 mm).
    const Eigen::VectorXd q_saved = model.q(), v_saved = model.v();
    poseNeutralOnGround(model, kFootprintDepth_m, candidates_);
    for (std::size_t s = 0; s < soles_.size(); ++s) {
      SoleFootprint& f = footprints_[s];
      const Eigen::Vector3d n = soles_[s].n_B;
      const Eigen::Vector3d x = contactTangent(n, Eigen::Vector3d::UnitX());
      const Eigen::Vector3d y = n.cross(x);
      double lowest = std::numeric_limits<double>::infinity();
      for (const ContactCandidate& c : candidates_)
        if (c.body == sole_bodies_[s] && c.object == kGroundObject) lowest = std::min(lowest, n.dot(c.p_BC));
      const auto onFace = [&](const ContactCandidate& c) {
        return c.body == sole_bodies_[s] && c.object == kGroundObject && n.dot(c.p_BC) <= lowest + 0.002;
      };
      Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
      int count = 0;
      for (const ContactCandidate& c : candidates_)
        if (onFace(c)) {
          centroid += c.p_BC;
          ++count;
        }
      if (count < 3) continue;
      centroid /= count;
      f.min.setConstant(std::numeric_limits<double>::infinity());
      f.max.setConstant(-std::numeric_limits<double>::infinity());
      for (const ContactCandidate& c : candidates_)
        if (onFace(c)) {
          const Eigen::Vector2d xy(x.dot(c.p_BC - centroid), y.dot(c.p_BC - centroid));
          f.min = f.min.cwiseMin(xy);
          f.max = f.max.cwiseMax(xy);
        }
      // S's x points to the toes: along the face's longer side, away from the body's origin
      // (the ankle joint stands over the heel's half). An ankle over the middle keeps the body's x.
      const Eigen::Vector2d extent = f.max - f.min;
      const int along = extent.x() >= extent.y() ? 0 : 1;
      const Eigen::Vector3d long_B = along == 0 ? x : y;
      const double ankle = long_B.dot(-centroid) - 0.5 * (f.min[along] + f.max[along]);
      Eigen::Vector3d toes = x;
      if (std::fabs(ankle) >= kAnkleOffCentre * extent[along]) toes = ankle < 0.0 ? long_B : Eigen::Vector3d(-long_B);
      if (toes != x) {  // the extent in the axes turned by a quarter or half turn about n
        const Eigen::Matrix2d R = (Eigen::Matrix2d() << toes.dot(x), toes.dot(y), -toes.dot(y), toes.dot(x)).finished();
        const Eigen::Vector2d a = R * f.min, b = R * f.max;
        f.min = a.cwiseMin(b);
        f.max = a.cwiseMax(b);
      }
      f.X_BS.linear().col(0) = toes;
      f.X_BS.linear().col(1) = n.cross(toes);
      f.X_BS.linear().col(2) = n;
      f.X_BS.translation() = centroid;
      f.valid = (f.max - f.min).minCoeff() > 0.01;  // a face, not a corner or an edge
    }
    model.setState(q_saved, v_saved);
  }
}

int BalanceLayer::flattenLandings(const IDynamicsModel& model, VirtualLinkSet& links) const {
  if (options_.flat_landing_max_tilt_rad <= 0.0) return 0;
  int changed = 0;
  for (int i = 0; i < links.size(); ++i) {
    const VirtualLink& link = links[i];
    if (link.kind == ContactKind::kFace || link.object != kGroundObject) continue;
    const auto it = std::find(sole_bodies_.begin(), sole_bodies_.end(), link.body);
    if (it == sole_bodies_.end()) continue;
    const std::size_t s = static_cast<std::size_t>(it - sole_bodies_.begin());
    const SoleFootprint& f = footprints_[s];
    if (!f.valid || !sole_free_[s]) continue;
    const Eigen::Isometry3d X_WS = model.bodyPose(link.body) * f.X_BS;
    const Eigen::Vector3d n = link.X_WA.linear().col(2);  // the surface's normal
    const double tilt = std::acos(std::clamp(X_WS.linear().col(2).dot(n), -1.0, 1.0));
    if (tilt > options_.flat_landing_max_tilt_rad) continue;
    // Only once the reference has this sole flat too (a heel strike waits for its foot-flat).
    const Eigen::Vector3d n_ref = sole_refs_[s].R * soles_[s].n_B;
    if (std::acos(std::clamp(n_ref.dot(n), -1.0, 1.0)) > kReferenceFlatRad) continue;
    Eigen::Isometry3d X_WA = Eigen::Isometry3d::Identity();
    X_WA.linear().col(0) = contactTangent(n, X_WS.linear().col(0));
    X_WA.linear().col(1) = n.cross(X_WA.linear().col(0));
    X_WA.linear().col(2) = n;
    // The touching point (on the surface) keeps its place in the sole's plane.
    const Eigen::Vector3d r_S = f.X_BS.inverse() * link.X_BC.translation();
    X_WA.translation() = link.X_WA.translation() - X_WA.linear() * Eigen::Vector3d(r_S.x(), r_S.y(), 0.0);
    links.makeFace(i, f.X_BS, X_WA, f.min, f.max);
    ++changed;
  }
  return changed;
}

int BalanceLayer::rollSoles(VirtualLinkSet& links) const {
  if (options_.roll_tilt_rad <= 0.0) return 0;
  int changed = 0;
  for (int i = 0; i < links.size(); ++i) {
    const VirtualLink& link = links[i];
    if (link.object != kGroundObject) continue;
    const auto it = std::find(sole_bodies_.begin(), sole_bodies_.end(), link.body);
    if (it == sole_bodies_.end()) continue;
    const std::size_t s = static_cast<std::size_t>(it - sole_bodies_.begin());
    const Eigen::Matrix3d& R_WA = link.X_WA.linear();
    const Eigen::Vector3d n = R_WA.col(2);
    const Eigen::Vector3d n_ref = sole_refs_[s].R * soles_[s].n_B;
    const double tilt = std::acos(std::clamp(n_ref.dot(n), -1.0, 1.0));
    if (tilt < 0.5 * options_.roll_tilt_rad) {
      if (link.rolling) links.setRolling(i, false);
      continue;
    }
    // Only a heel-off rolls: a sole the reference lifts soon, tilted towards its toes (the
    // normal leaning along the footprint's x, SoleFootprint). A reference sole standing tilted
    // otherwise (a retargeted ankle; a level sole on a slope, toes up downhill) is flattened,
    // not rolled on.
    if (tilt <= options_.roll_tilt_rad || !holds(lifting_soon_, link.body)) continue;
    const Eigen::Vector2d d(n_ref.dot(R_WA.col(0)), n_ref.dot(R_WA.col(1)));
    if (link.kind != ContactKind::kFace) {
      // A link already on an edge or a point is marked when the lean runs along its own x
      // (a point's: the body's x; an edge's: the edge). Toe-edge and toe-side rules measured
      // worse on the walks (docs/balance.md §36).
      if (d.x() > std::fabs(d.y()) && !link.rolling) links.setRolling(i, true);
      continue;
    }
    const Eigen::Vector3d toes_C = link.X_BC.linear().transpose() * footprints_[s].X_BS.linear().col(0);
    const Eigen::Vector2d t = Eigen::Vector2d(toes_C.x(), toes_C.y()).normalized();
    if (d.dot(t) <= std::fabs(d.x() * t.y() - d.y() * t.x())) continue;
    // The edge the reference stays on: the toe edge, the support's side the toes point to.
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();  // edge frame in A (and C)
    const Eigen::Vector2d mid = 0.5 * (link.support_min + link.support_max);
    double lo = 0.0, hi = 0.0;
    if (std::fabs(t.x()) >= std::fabs(t.y())) {  // along A's y at x = max (or min): the edge frame's x is A's y
      T.translation() = Eigen::Vector3d(t.x() > 0.0 ? link.support_max.x() : link.support_min.x(), mid.y(), 0.0);
      T.linear() << 0, -1, 0, 1, 0, 0, 0, 0, 1;
      lo = link.support_min.y() - mid.y();
      hi = link.support_max.y() - mid.y();
    } else {  // along A's x at y = max (or min)
      T.translation() = Eigen::Vector3d(mid.x(), t.y() > 0.0 ? link.support_max.y() : link.support_min.y(), 0.0);
      lo = link.support_min.x() - mid.x();
      hi = link.support_max.x() - mid.x();
    }
    links.makeRollingEdge(i, link.X_BC * T, link.X_WA * T, lo, hi);
    ++changed;
  }
  return changed;
}

std::size_t BalanceLayer::ringIndex(int i) const {
  return static_cast<std::size_t>((head_ + i) % static_cast<int>(ring_.size()));
}

const BalanceLayer::Sample& BalanceLayer::at(int i) const { return ring_[ringIndex(i)]; }

double BalanceLayer::groundHeight(const Eigen::Vector2d& p) const {
  if (environment_ == nullptr || !environment_->has_ground) return 0.0;
  const GroundPlane& g = environment_->ground;
  if (std::abs(g.n_W.z()) < 0.1) return 0.0;
  return g.heightAt(p.x(), p.y());
}

void BalanceLayer::makeSample(IDynamicsModel& model, const ReferenceFrame& frame, Sample& out) {
  out.t = frame.time_s;
  out.excess_key.fill(std::numeric_limits<double>::quiet_NaN());
  model.setState(frame.q, frame.v);
  model.massMatrix(A_);
  const CentroidalState cs = centroidalState(A_, frame.q, frame.v, mass_kg_);
  out.c = cs.c_W;
  out.cdot = cs.cdot_W;
  out.L = cs.L_W;
  // Support: body points within stance_height of the environment and slow. The model is
  // lowered by stance_height so that the collision engine reports them.
  const double h = options_.stance_height_m;
  q_lowered_ = frame.q;
  q_lowered_[2] -= h;
  model.setState(q_lowered_, frame.v);
  model.detectContacts(candidates_);
  int n = 0;
  out.stance.reset();
  for (const ContactCandidate& c : candidates_) {
    if (n >= static_cast<int>(points_.size())) break;
    const Eigen::Vector3d v_point = model.pointVelocity(c.body, c.p_WC);
    // Slow along the surface: a reference foot sinking into the ground is still in stance.
    if ((v_point - c.n_W * c.n_W.dot(v_point)).norm() > options_.stance_speed_mps) continue;
    points_[static_cast<std::size_t>(n++)] = c.p_WC.head<2>();
    out.stance.set(static_cast<std::size_t>(c.body));
  }
  out.num_support = convexHull(points_, n, out.support);
  model.setState(frame.q, frame.v);
}

bool BalanceLayer::pushPreview(IDynamicsModel& model, const ReferenceFrame& frame) {
  if (!info_.checkState(frame.q, frame.v).ok || !std::isfinite(frame.time_s)) return false;
  if (size_ > 0 && frame.time_s <= at(size_ - 1).t) size_ = 0;  // time went back: restart
  const int capacity = static_cast<int>(ring_.size());
  if (size_ == capacity) {
    head_ = (head_ + 1) % capacity;
    --size_;
  }
  makeSample(model, frame, ring_[static_cast<std::size_t>((head_ + size_) % capacity)]);
  ++size_;
  return true;
}

void BalanceLayer::transformPreview(const Eigen::Isometry3d& X_WW) {
  const Eigen::Matrix3d& R = X_WW.linear();
  // A turn about the vertical turns each segment's CoP excess with it: the cache stays.
  const bool about_vertical = (R.col(2) - Eigen::Vector3d::UnitZ()).norm() < 1e-12;
  for (int i = 0; i < size_; ++i) {
    Sample& s = ring_[ringIndex(i)];
    s.c = X_WW * s.c;
    s.cdot = R * s.cdot;
    s.L = R * s.L;
    for (int k = 0; k < s.num_support; ++k) {
      Eigen::Vector2d& p = s.support[static_cast<std::size_t>(k)];
      p = (X_WW * Eigen::Vector3d(p.x(), p.y(), groundHeight(p))).head<2>();
    }
    if (about_vertical)
      s.excess = R.topLeftCorner<2, 2>() * s.excess;
    else
      s.excess_key.fill(std::numeric_limits<double>::quiet_NaN());
  }
}

int BalanceLayer::sampleBefore(int i, double t) const {
  while (i > 0 && at(i).t > t) --i;
  return i;
}

int BalanceLayer::sampleAfter(int i, double t) const {
  while (i + 1 < size_ && at(i).t < t) ++i;
  return i;
}

Eigen::Vector2d BalanceLayer::segmentCop(const Sample& before, const Sample& a, const Sample& b,
                                         const Sample& after, Eigen::Vector3d* cddot,
                                         Eigen::Vector2d* excess) const {
  const double dt = after.t - before.t;
  const Eigen::Vector3d acc = dt > 1e-9 ? Eigen::Vector3d((after.cdot - before.cdot) / dt) : Eigen::Vector3d::Zero();
  const Eigen::Vector3d Ldot = dt > 1e-9 ? Eigen::Vector3d((after.L - before.L) / dt) : Eigen::Vector3d::Zero();
  if (cddot != nullptr) *cddot = acc;
  const Eigen::Vector3d c = 0.5 * (a.c + b.c);
  const double height = std::max(c.z() - groundHeight(c.head<2>()), kMinHeight);
  const double support = kStandardGravity + acc.z();
  Eigen::Vector2d p = c.head<2>();
  // The CoP of the wrench the reference needs: force m (c̈ + g), moment L̇ about c.
  if (support > 0.2 * kStandardGravity)
    p += -height / support * acc.head<2>() + Eigen::Vector2d(-Ldot.y(), Ldot.x()) / (mass_kg_ * support);
  const Eigen::Vector2d clamped = clampToHull(p, a.support, a.num_support);
  if (excess != nullptr) *excess = clamped - p;
  return clamped;
}

void BalanceLayer::prepare(IDynamicsModel& model, const ReferenceFrame& reference, double dt_s) {
  const double t = reference.time_s;
  // Drop preview samples older than the one just before t.
  while (size_ >= 2 && at(1).t <= t) {
    head_ = (head_ + 1) % static_cast<int>(ring_.size());
    --size_;
  }
  // The reference now: interpolated between preview samples when they bracket t.
  if (size_ >= 2 && at(0).t <= t && at(1).t > t) {
    const Sample& a = at(0);
    const Sample& b = at(1);
    const double s = (t - a.t) / (b.t - a.t);
    now_.t = t;
    now_.c = a.c + s * (b.c - a.c);
    now_.cdot = a.cdot + s * (b.cdot - a.cdot);
    now_.L = a.L + s * (b.L - a.L);
    const Sample& nearest = s < 0.5 ? a : b;
    now_.num_support = nearest.num_support;
    now_.support = nearest.support;
    now_.stance = nearest.stance;
  } else {
    makeSample(model, reference, now_);
  }
  // The soles in the reference: pose, motion and clearance (for the swing-sole task).
  model.setState(reference.q, reference.v);
  for (std::size_t s = 0; s < soles_.size(); ++s) {
    SoleReference& r = sole_refs_[s];
    const int body = sole_bodies_[s];
    const Eigen::Isometry3d X_WB = model.bodyPose(body);
    model.pointJacobian(body, Eigen::Vector3d::Zero(), J_);
    const Vector6d V = J_ * reference.v;
    const Vector6d acc = J_ * reference.vdot + model.pointJacobianDotTimesV(body, Eigen::Vector3d::Zero());
    r.p = X_WB.translation();
    r.R = X_WB.linear();
    r.pdot = V.head<3>();
    r.omega = V.tail<3>();
    r.pddot = acc.head<3>();
    r.omegadot = acc.tail<3>();
    r.clearance_m = 1e9;
  }
  q_lowered_ = reference.q;
  q_lowered_[2] -= options_.stance_height_m;
  model.setState(q_lowered_, reference.v);
  model.detectContacts(candidates_);
  model.setState(reference.q, reference.v);
  for (const ContactCandidate& c : candidates_)
    for (std::size_t s = 0; s < soles_.size(); ++s)
      if (c.body == sole_bodies_[s])
        sole_refs_[s].clearance_m = std::min(sole_refs_[s].clearance_m, options_.stance_height_m - c.depth_m);
  state_.reference.c_W = now_.c;
  state_.reference.cdot_W = now_.cdot;
  const Environment& env = model.environment();
  environment_ = &env;
  const double height = std::max(now_.c.z() - groundHeight(now_.c.head<2>()), kMinHeight);
  omega_ = std::sqrt(kStandardGravity / height);

  // Future samples in the window, after t.
  int first = 0;
  while (first < size_ && at(first).t <= t) ++first;
  int last = first;
  // Beyond 14/ω the future weighs less than e⁻¹⁴ ≈ 1e-6 in ξ: the window stops there.
  const double window_s = std::min(options_.preview_s, 14.0 / omega_);
  while (last < size_ && at(last).t <= t + window_s) ++last;
  state_.preview_samples = last - first;
  // Bodies the reference lifts within kRollLookaheadS (push-off): only they roll.
  lifting_soon_.reset();
  for (int i = first; i < size_ && at(i).t <= t + kRollLookaheadS; ++i) lifting_soon_ |= now_.stance & ~at(i).stance;
  if (last > first) {
    // The target is the reference's own DCM, moved by what its support cannot carry: the
    // CoP the reference needs, clamped into its support, differs from it by an excess e;
    // the pendulum's DCM answers e as ξ answers p, so the offset integrates backwards as
    // δξ ← e + exp(−ω Δt) (δξ − e) from 0 at the window's end. Where the reference's CoP
    // stays in its support the target is its DCM, whatever the model's error.
    // Each segment's excess depends on its four samples alone: computed once per set of
    // samples (offline the window holds seconds of them, and the ticks share them).
    if (env.has_ground != cached_ground_.has_ground || env.ground.n_W != cached_ground_.n_W ||
        env.ground.offset_m != cached_ground_.offset_m) {
      for (int i = 0; i < size_; ++i) ring_[ringIndex(i)].excess_key.fill(std::numeric_limits<double>::quiet_NaN());
      cached_ground_ = {env.has_ground, env.ground.n_W, env.ground.offset_m};
    }
    // A cached segment whose before-sample is still held and was not clamped to the front,
    // and whose after-sample was not clamped to the end, keeps them: samples are only
    // dropped from the front and appended at the end.
    const double front_t = at(0).t;
    Eigen::Vector2d dxi = Eigen::Vector2d::Zero(), excess;
    double decay_dt = -1.0, decay = 1.0;
    for (int i = last - 1; i > first; --i) {
      const Sample& a = at(i - 1);
      Sample& b = ring_[ringIndex(i)];
      const std::array<double, 3>& key = b.excess_key;
      const bool settled = key[1] == a.t && key[0] <= a.t - kAccelHalfWindowS && key[0] >= front_t &&
                           key[2] >= b.t + kAccelHalfWindowS;
      if (!settled) {
        const Sample& before = at(sampleBefore(i - 1, a.t - kAccelHalfWindowS));
        const Sample& after = at(sampleAfter(i, b.t + kAccelHalfWindowS));
        const std::array<double, 3> now_key{{before.t, a.t, after.t}};
        if (now_key != key) {
          segmentCop(before, a, b, after, nullptr, &b.excess);
          b.excess_key = now_key;
        }
      }
      if (b.t - a.t != decay_dt) {
        decay_dt = b.t - a.t;
        decay = std::exp(-omega_ * decay_dt);
      }
      dxi = b.excess + decay * (dxi - b.excess);
    }
    const Sample& b = at(first);
    cop_target_ = segmentCop(first > 0 ? at(sampleBefore(first - 1, t - kAccelHalfWindowS)) : now_, now_, b,
                             at(sampleAfter(first, b.t + kAccelHalfWindowS)), &cddot_ref_, &excess);
    dxi = excess + std::exp(-omega_ * (b.t - t)) * (dxi - excess);
    dcm_target_ = now_.c.head<2>() + now_.cdot.head<2>() / omega_ + dxi;
  } else {
    cddot_ref_.setZero();
    cop_target_ = clampToHull(Eigen::Vector2d(now_.c.head<2>()), now_.support, now_.num_support);
    dcm_target_ = now_.c.head<2>() + now_.cdot.head<2>() / omega_;
  }
  state_.dcm_desired = dcm_target_;

  // Can the reference be followed? It needs the contact force m (c̈ − g).
  const Eigen::Vector3d force = mass_kg_ * (cddot_ref_ + Eigen::Vector3d(0.0, 0.0, kStandardGravity));
  InfeasibleReason reason = InfeasibleReason::kNone;
  needs_support_ = force.z() > 0.3 * mass_kg_ * kStandardGravity;
  if (needs_support_) {
    if (now_.num_support == 0) {
      reason = InfeasibleReason::kNoSupport;
    } else if (env.has_ground) {
      const Eigen::Vector3d& n = env.ground.n_W;
      const double fn = force.dot(n);
      const double ft = (force - fn * n).norm();
      if (fn <= 0.0 || ft > env.ground.friction * fn) reason = InfeasibleReason::kOutsideCone;
    }
  }
  if (reason != InfeasibleReason::kNone && reason == pending_) {
    infeasible_s_ += dt_s;
  } else {
    pending_ = reason;
    infeasible_s_ = reason != InfeasibleReason::kNone ? dt_s : 0.0;
  }
  if (infeasible_s_ >= kInfeasibleAfterS) state_.infeasible = pending_;
  else if (reason == InfeasibleReason::kNone) state_.infeasible = InfeasibleReason::kNone;
}

void BalanceLayer::addSoleCandidates(IDynamicsModel& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                                     const Eigen::Ref<const Eigen::VectorXd>& v,
                                     const VirtualLinkSet& links, ContactList& candidates) {
  bool any = false;
  for (int i = 0; i < links.size(); ++i)
    any = any || (links[i].kind != ContactKind::kFace && !links[i].rolling &&
                  std::find(sole_bodies_.begin(), sole_bodies_.end(), links[i].body) != sole_bodies_.end());
  if (!any) return;
  const double margin = options_.sole_margin_m;
  q_lowered_ = q;
  q_lowered_[2] -= margin;
  model.setState(q_lowered_, v);
  model.detectContacts(candidates_);
  model.setState(q, v);
  for (int i = 0; i < links.size(); ++i) {
    const VirtualLink& link = links[i];
    if (link.kind == ContactKind::kFace || link.rolling ||
        std::find(sole_bodies_.begin(), sole_bodies_.end(), link.body) == sole_bodies_.end())
      continue;
    for (const ContactCandidate& c : candidates_) {
      if (c.body != link.body || c.object != link.object) continue;
      ContactCandidate raised = c;
      raised.p_WC.z() += margin;
      raised.depth_m = std::max(0.0, c.depth_m - margin);
      bool known = false;
      for (const ContactCandidate& k : candidates)
        known = known || (k.body == c.body && (k.p_BC - c.p_BC).norm() < 1e-3);
      if (!known) candidates.push(raised);
    }
  }
}

int BalanceLayer::swingSoleRows(const IDynamicsModel& model, const Eigen::Ref<const Eigen::VectorXd>& v,
                                std::size_t s, int rows, QpObjectiveTasks& tasks) {
  // A sole in the air follows the reference's sole (world pose); when the reference has it
  // in stance, to 2 mm below the surface under it, so that it lands and its link forms.
  const SoleReference& r = sole_refs_[s];
  const int body = sole_bodies_[s];
  const int nv = info_.nv;
  const Eigen::Isometry3d X_WB = model.bodyPose(body);
  model.pointJacobian(body, Eigen::Vector3d::Zero(), J_);
  const Vector6d drift = model.pointJacobianDotTimesV(body, Eigen::Vector3d::Zero());
  const Vector6d V = J_ * v;
  Eigen::Vector3d p_target = r.p;
  if (r.clearance_m <= options_.stance_height_m) p_target.z() -= r.clearance_m + 0.002;
  const double kp = options_.sole_kp, kd = options_.sole_kd;
  Vector6d acc;
  acc.head<3>() = r.pddot + kd * (r.pdot - V.head<3>()) + kp * (p_target - X_WB.translation());
  acc.tail<3>() = r.omegadot + kd * (r.omega - V.tail<3>()) + kp * logSO3(r.R * X_WB.linear().transpose());
  tasks.T.block(rows, 0, 6, tasks.T.cols()).setZero();
  tasks.T.block(rows, 0, 6, nv) = J_;
  tasks.r.segment<6>(rows) = acc - drift;
  tasks.w.segment<6>(rows).setConstant(options_.sole_weight);
  return rows + 6;
}

void BalanceLayer::buildTasks(const IDynamicsModel& model, const Eigen::Ref<const Eigen::MatrixXd>& A,
                              const Eigen::Ref<const Eigen::VectorXd>& q,
                              const Eigen::Ref<const Eigen::VectorXd>& v, const VirtualLinkSet& links,
                              QpObjectiveTasks& tasks) {
  tasks.rows = 0;
  state_.active = false;
  const int nv = info_.nv;
  state_.filter = centroidalState(A, q, v, mass_kg_);
  const Eigen::Vector3d& c = state_.filter.c_W;
  const Eigen::Vector3d& cdot = state_.filter.cdot_W;
  state_.dcm = c.head<2>() + cdot.head<2>() / omega_;

  // The filter's support: the held links' support rectangles.
  int n = 0;
  for (int i = 0; i < links.size() && n + 4 <= static_cast<int>(points_.size()); ++i) {
    const VirtualLink& link = links[i];
    for (const double x : {link.support_min.x(), link.support_max.x()})
      for (const double y : {link.support_min.y(), link.support_max.y()})
        points_[static_cast<std::size_t>(n++)] = (link.X_WA * Eigen::Vector3d(x, y, 0.0)).head<2>();
  }
  std::array<Eigen::Vector2d, kMaxSupport> support;
  const int num_support = convexHull(points_, n, support);
  if (num_support == 0 || links.numRows() == 0) return;  // flight: nothing to balance on

  // DCM feedback → CoP command in the support → CoM acceleration.
  const Eigen::Vector2d p_raw =
      cop_target_ + (1.0 + options_.dcm_gain) * (state_.dcm - dcm_target_);
  const Eigen::Vector2d p = clampToHull(p_raw, support, num_support);
  state_.cop_command = p;
  Eigen::Vector3d cddot;
  cddot.head<2>() = omega_ * omega_ * (c.head<2>() - p);
  cddot.z() = cddot_ref_.z() + options_.height_kd * (now_.cdot.z() - cdot.z()) +
              options_.height_kp * (now_.c.z() - c.z());
  state_.com_accel_desired = cddot;

  // Rows on τ_C: m c̈ = Σ_links R_WA f_A + m g, and L̇ = Σ (p − c) × f + moments.
  tasks.T.topRows(6).setZero();
  int slot = 0;
  for (int i = 0; i < links.size(); ++i) {
    const VirtualLink& link = links[i];
    const Eigen::Matrix3d& R = link.X_WA.linear();
    const Eigen::Matrix3d lever = skew(Eigen::Vector3d(link.X_WA.translation() - c)) * R;
    for (int k = 0; k < link.num_axes; ++k) {
      const int axis = link.axes[static_cast<std::size_t>(k)];
      const int col = nv + slot + k;
      if (axis < 3) {
        tasks.T.block<3, 1>(0, col) = R.col(axis) / mass_kg_;
        tasks.T.block<3, 1>(3, col) = lever.col(axis);
      } else {
        tasks.T.block<3, 1>(3, col) = R.col(axis - 3);
      }
    }
    slot += link.num_axes;
  }
  tasks.r.head<3>() = cddot - Eigen::Vector3d(0.0, 0.0, -kStandardGravity);
  tasks.w.head<3>().setConstant(options_.com_weight);
  tasks.r.segment<3>(3) = -options_.angular_momentum_damping * state_.filter.L_W;
  tasks.w.segment<3>(3).setConstant(options_.angular_momentum_weight);
  int rows = 6;

  // Soles flat on the ground while their body holds a link: ω̇ = kp e − kd ω on v̇.
  for (std::size_t s = 0; s < soles_.size(); ++s) {
    const int body = sole_bodies_[s];
    const VirtualLink* held = nullptr;
    for (int i = 0; i < links.size(); ++i)
      if (links[i].body == body) held = &links[i];
    if (held == nullptr) {
      rows = swingSoleRows(model, v, s, rows, tasks);
      continue;
    }
    const Eigen::Isometry3d X_WB = model.bodyPose(body);
    const Eigen::Vector3d n_W = X_WB.linear() * soles_[s].n_B;
    // Flat on the ground; while rolling, tilted as the reference's sole is.
    Eigen::Vector3d n_target = held->X_WA.linear().col(2);
    if (held->rolling) n_target = sole_refs_[s].R * soles_[s].n_B;
    const Eigen::Vector3d axis = n_W.cross(n_target);
    const double angle = std::atan2(axis.norm(), n_W.dot(n_target));
    const Eigen::Vector3d error = axis.norm() > 1e-12 ? Eigen::Vector3d(axis.normalized() * angle)
                                                      : Eigen::Vector3d::Zero();
    model.pointJacobian(body, Eigen::Vector3d::Zero(), J_);
    const Vector6d drift = model.pointJacobianDotTimesV(body, Eigen::Vector3d::Zero());
    const Eigen::Vector3d omega = J_.bottomRows<3>() * v;
    tasks.T.block(rows, 0, 3, tasks.T.cols()).setZero();
    tasks.T.block(rows, 0, 3, nv) = J_.bottomRows<3>();
    // While rolling it also turns as fast as the reference's sole (a push-off is not braked).
    tasks.r.segment<3>(rows) = options_.sole_kp * error - options_.sole_kd * omega - drift.tail<3>();
    if (held->rolling) tasks.r.segment<3>(rows) += sole_refs_[s].omegadot + options_.sole_kd * sole_refs_[s].omega;
    tasks.w.segment<3>(rows).setConstant(options_.sole_weight);
    rows += 3;
  }
  tasks.rows = rows;
  state_.active = true;
}

}  // namespace dynfilter
