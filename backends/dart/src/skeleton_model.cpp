#include "dynfilter/dart/skeleton_model.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <dart/collision/CollisionDetector.hpp>
#include <dart/collision/CollisionFilter.hpp>
#include <dart/collision/CollisionGroup.hpp>
#include <dart/collision/CollisionObject.hpp>
#include <dart/collision/CollisionResult.hpp>
#include <dart/collision/bullet/BulletCollisionGroup.hpp>
#include <BulletCollision/Gimpact/btGImpactCollisionAlgorithm.h>
#include <dart/constraint/ConstraintSolver.hpp>
#include <dart/dynamics/CylinderShape.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/MeshShape.hpp>
#include <dart/dynamics/ShapeNode.hpp>

#include "dynfilter/core/ball_joint.hpp"
#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "skeleton_model_setup.hpp"

namespace dynfilter::dart_backend {
namespace {

using dart::dynamics::Frame;

// Keeps only pairs with exactly one shape on the robot's skeleton, in the one collision
// group that holds the whole world. (DART's two-group collide() builds a temporary Bullet
// world on every call: ~300 µs.) The built world's ground is two shapes: a slab for
// primitives (box-box gives the full contact polygon) and a plane for convex-hull meshes
// (Bullet reports each hull vertex below a plane, but only the closest point per triangle
// against a box). Without @p engine_ground_contacts, hulls and cylinders meet neither
// (their ground contacts are computed from their geometry).
class RobotVersusOthersFilter final : public dart::collision::CollisionFilter {
 public:
  RobotVersusOthersFilter(const dart::dynamics::Skeleton* robot,
                          const dart::dynamics::ShapeFrame* ground_slab,
                          const dart::dynamics::ShapeFrame* ground_plane, bool engine_ground_contacts)
      : robot_(robot),
        ground_slab_(ground_slab),
        ground_plane_(ground_plane),
        engine_ground_contacts_(engine_ground_contacts) {}
  bool ignoresCollision(const dart::collision::CollisionObject* a,
                        const dart::collision::CollisionObject* b) const override {
    const bool robot_a = isRobot(a);
    if (robot_a == isRobot(b)) return true;
    const auto* robot_object = robot_a ? a : b;
    const auto* other_frame = (robot_a ? b : a)->getShapeFrame();
    const bool hull = robot_object->getShape()->is<dart::dynamics::MeshShape>();
    const bool own = hull || robot_object->getShape()->is<dart::dynamics::CylinderShape>();
    if (own && !engine_ground_contacts_ && (other_frame == ground_plane_ || other_frame == ground_slab_))
      return true;
    return other_frame == (hull ? ground_slab_ : ground_plane_);
  }

 private:
  bool isRobot(const dart::collision::CollisionObject* o) const {
    const auto* node = o->getShapeFrame()->asShapeNode();
    return node != nullptr && node->getSkeleton().get() == robot_;
  }
  const dart::dynamics::Skeleton* robot_;
  const dart::dynamics::ShapeFrame* ground_slab_;
  const dart::dynamics::ShapeFrame* ground_plane_;
  bool engine_ground_contacts_;
};

// DART 6.12 keeps a group's Bullet world protected; a derived class may name it.
struct BulletWorldAccess : dart::collision::BulletCollisionGroup {
  static btCollisionWorld* of(dart::collision::BulletCollisionGroup* group) {
    btCollisionWorld* (dart::collision::BulletCollisionGroup::*get)() =
        &BulletWorldAccess::getBulletCollisionWorld;
    return (group->*get)();
  }
};

class DartSkeletonModel final : public SkeletonModel {
 public:
  explicit DartSkeletonModel(SkeletonModelSetup setup)
      : s_(std::move(setup)),
        q_(s_.info.neutralConfiguration()),
        v_(Eigen::VectorXd::Zero(s_.info.nv)),
        dart_q_(s_.skeleton->getNumDofs()),
        dart_v_(s_.skeleton->getNumDofs()),
        dart_a_(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(s_.skeleton->getNumDofs()))),
        dart_tau_(s_.skeleton->getNumDofs()),
        read_q_(s_.skeleton->getNumDofs()),
        read_v_(s_.skeleton->getNumDofs()),
        inertia_times_J_(6, s_.skeleton->getNumDofs()),
        ball_cols_(s_.info.nv, kBallJointDofs),
        ball_rows_(kBallJointDofs, s_.info.nv),
        A_scratch_(s_.info.nv, s_.info.nv),
        b_scratch_(s_.info.nv),
        llt_(s_.info.nv) {
    const std::size_t ndofs = s_.skeleton->getNumDofs();
    if (s_.v_of_dof.empty()) {  // no mimic joints: the inverse of dof_of_v
      s_.v_of_dof.assign(ndofs, -1);
      s_.factor_of_dof.assign(ndofs, 1.0);
      s_.offset_of_dof.assign(ndofs, 0.0);
      for (int i = 0; i < s_.info.nv; ++i) s_.v_of_dof[static_cast<std::size_t>(s_.dof_of_v[i])] = i;
    }
    if (s_.v_of_dof.size() != ndofs || s_.factor_of_dof.size() != ndofs ||
        s_.offset_of_dof.size() != ndofs)
      throw std::logic_error("SkeletonModelSetup: DoF maps do not match the skeleton");
    // One collision group over every skeleton in the world, made by a detector of the
    // world's kind and subscribed to the skeletons so that it follows their shapes. Not
    // the world's detector instance itself: its groups share one engine object per shape,
    // and a Bullet object in two collision worlds keeps only the last one's broadphase
    // handle, so the world's own contacts would go stale.
    detector_ = s_.world->getConstraintSolver()->getCollisionDetector()->cloneWithoutCollisionObjects();
    collision_group_ = detector_->createCollisionGroup();
    for (std::size_t k = 0; k < s_.world->getNumSkeletons(); ++k)
      collision_group_->subscribeTo(s_.world->getSkeleton(k));
    collision_filter_ = makeRobotVersusOthersFilter(s_.skeleton.get(), s_.ground_slab,
                                                    s_.ground_plane, s_.ground_shapes.empty());
    if (s_.ground_plane != nullptr) enableHullContacts(collision_group_.get());
    if (!pullSkeletonState())
      throw InvalidStateError("skeleton \"" + s_.skeleton->getName() +
                              "\": its current state is not finite");
  }

  const ModelInfo& info() const override { return s_.info; }
  std::string_view backendName() const override { return "dart"; }
  const Environment& environment() const override { return s_.environment; }
  const dart::dynamics::SkeletonPtr& skeleton() const override { return s_.skeleton; }
  const dart::simulation::WorldPtr& world() const override { return s_.world; }

  void setState(const Eigen::Ref<const Eigen::VectorXd>& q,
                const Eigen::Ref<const Eigen::VectorXd>& v) override {
    s_.info.requireValidState(q, v);
    q_ = q;
    v_ = v;
    if (s_.info.floating_base) q_.segment<4>(3).normalize();
    pushState();
  }
  const Eigen::VectorXd& q() const override { return q_; }
  const Eigen::VectorXd& v() const override { return v_; }

  bool pullSkeletonState() override {
    if (!readSkeletonState(q_, v_)) return false;
    pushState();  // accelerations: the drift values the queries rely on
    return true;
  }

  bool readSkeletonState(Eigen::Ref<Eigen::VectorXd> q,
                         Eigen::Ref<Eigen::VectorXd> v) const override {
    if (q.size() != s_.info.nq || v.size() != s_.info.nv) return false;
    // Per DoF: Skeleton::getPositions() returns a new vector (allocates).
    for (Eigen::Index i = 0; i < read_q_.size(); ++i) {
      const auto dof = static_cast<std::size_t>(i);
      read_q_[i] = s_.skeleton->getPosition(dof);
      read_v_[i] = s_.skeleton->getVelocity(dof);
    }
    if (!read_q_.allFinite() || !read_v_.allFinite()) return false;
    int base_q = 0;
    if (s_.info.floating_base) {
      setBasePoseInConfiguration(
          dart::dynamics::FreeJoint::convertToTransform(read_q_.head<6>()), q);
      base_q = kFloatingBaseNq;
    }
    const int base_v = baseV();
    for (int j = 0; j < s_.info.nj; ++j) q[base_q + j] = read_q_[s_.dof_of_v[base_v + j]];
    for (int i = 0; i < s_.info.nv; ++i) v[i] = read_v_[s_.dof_of_v[i]];
    for (const int i : s_.ball_v) {
      // DART's ball velocity is the child's angular velocity ω_C = J_r(θ) θ̇.
      const Eigen::Matrix3d J_r = rightJacobianSO3(q.segment<3>(i - base_v + base_q));
      v.segment<3>(i) = J_r.partialPivLu().solve(Eigen::Vector3d(v.segment<3>(i)));
    }
    return true;
  }

  void setSkeletonForces(const Eigen::Ref<const Eigen::VectorXd>& tau_J) const override {
    if (tau_J.size() != s_.info.nj)
      throw InvalidStateError("torque vector has " + std::to_string(tau_J.size()) +
                              " entries, expected nj = " + std::to_string(s_.info.nj));
    dart_tau_.setZero();
    const int base_v = baseV();
    for (int j = 0; j < s_.info.nj; ++j) dart_tau_[s_.dof_of_v[base_v + j]] = tau_J[j];
    for (const int i : s_.ball_v) {
      // τ = J_rᵀ t_C: the joint torque t_C in the child frame is J_r⁻ᵀ τ.
      const Eigen::Matrix3d J_r = rightJacobianSO3(ballAngle(i));
      const Eigen::Vector3d tau(tau_J.segment<3>(i - base_v));
      dart_tau_.segment<3>(s_.dof_of_v[i]) = J_r.transpose().partialPivLu().solve(tau);
    }
    s_.skeleton->setForces(dart_tau_);
  }

  Eigen::Isometry3d bodyPose(int body) const override {
    const LinkFrame& f = s_.links[static_cast<std::size_t>(body)];
    return f.node->getWorldTransform() * f.X_NL;
  }

  Vector6d bodyVelocity(int body) const override {
    const LinkFrame& f = s_.links[static_cast<std::size_t>(body)];
    Vector6d V;
    V.head<3>() = f.node->getLinearVelocity(f.X_NL.translation(), Frame::World(), Frame::World());
    V.tail<3>() = f.node->getAngularVelocity(Frame::World(), Frame::World());
    return V;
  }

  void pointJacobian(int body, const Eigen::Vector3d& p_BP,
                     Eigen::Ref<Matrix6Xd> J_out) const override {
    // From DART's cached world Jacobian of the body origin ([angular; linear], dependent
    // coordinates only): shift to the point, ṗ_P = ṗ_O + ω × r, and scatter.
    const LinkFrame& f = s_.links[static_cast<std::size_t>(body)];
    const auto& J_O = f.node->getWorldJacobian();
    const auto& dofs = f.node->getDependentGenCoordIndices();
    const Eigen::Vector3d r_W = f.node->getWorldTransform().linear() * (f.X_NL * p_BP);
    // A mimic follower's column adds to its leader's, times the multiplier.
    J_out.setZero();
    for (std::size_t k = 0; k < dofs.size(); ++k) {
      const int i = s_.v_of_dof[dofs[k]];
      const double factor = s_.factor_of_dof[dofs[k]];
      const Eigen::Vector3d omega = J_O.col(static_cast<Eigen::Index>(k)).head<3>();
      J_out.col(i).head<3>() +=
          factor * (J_O.col(static_cast<Eigen::Index>(k)).tail<3>() + omega.cross(r_W));
      J_out.col(i).tail<3>() += factor * omega;
    }
    for (const int i : s_.ball_v) {  // columns for θ̇ = columns for ω_C times J_r
      const Eigen::Matrix<double, 6, 3> J_ball = J_out.middleCols<3>(i) * rightJacobianSO3(ballAngle(i));
      J_out.middleCols<3>(i) = J_ball;
    }
  }

  Vector6d pointJacobianDotTimesV(int body, const Eigen::Vector3d& p_BP) const override {
    // The skeleton's accelerations are zero but for ball joints, which hold J̇_r θ̇: DART's
    // classical point acceleration is then exactly the drift J̇·v in our coordinates.
    const LinkFrame& f = s_.links[static_cast<std::size_t>(body)];
    const Eigen::Vector3d p_N = f.X_NL * p_BP;
    Vector6d out;
    out.head<3>() = f.node->getLinearAcceleration(p_N, Frame::World(), Frame::World());
    out.tail<3>() = f.node->getAngularAcceleration(Frame::World(), Frame::World());
    return out;
  }

  void massMatrix(Eigen::Ref<Eigen::MatrixXd> A_out) const override {
    A_out.setZero();
    if (s_.mass_matrix == DartMassMatrix::kSkeleton) {
      // A = Gᵀ M G with G the DoF ← v map (one entry per DoF, its factor).
      const Eigen::MatrixXd& M = s_.skeleton->getMassMatrix();
      for (Eigen::Index b = 0; b < M.cols(); ++b) {
        const auto dof_b = static_cast<std::size_t>(b);
        for (Eigen::Index a = 0; a < M.rows(); ++a) {
          const auto dof_a = static_cast<std::size_t>(a);
          A_out(s_.v_of_dof[dof_a], s_.v_of_dof[dof_b]) +=
              s_.factor_of_dof[dof_a] * s_.factor_of_dof[dof_b] * M(a, b);
        }
      }
    } else {
      // A = Σ_k J_kᵀ M_k J_k over bodies, with DART's cached body Jacobians and spatial
      // inertias (both in the body frame): no allocation, ~10× faster than
      // Skeleton::getMassMatrix on the human figure.
      for (std::size_t k = 0; k < s_.skeleton->getNumBodyNodes(); ++k) {
        const auto* node = s_.skeleton->getBodyNode(k);
        const auto& J = node->getJacobian();
        const auto& dofs = node->getDependentGenCoordIndices();
        const Eigen::Index d = J.cols();
        auto MJ = inertia_times_J_.leftCols(d);
        MJ.noalias() = node->getSpatialInertia() * J;
        // Gᵀ (Jᵀ M J) G: a DoF pair (a, b) adds f_a f_b (Jᵀ M J)_ab at (v(a), v(b)) and,
        // for a ≠ b, its transpose (twice onto the diagonal when a mimic follower and
        // its leader share one v).
        for (Eigen::Index b = 0; b < d; ++b) {
          const std::size_t dof_b = dofs[static_cast<std::size_t>(b)];
          const int col = s_.v_of_dof[dof_b];
          for (Eigen::Index a = 0; a <= b; ++a) {
            const std::size_t dof_a = dofs[static_cast<std::size_t>(a)];
            const int row = s_.v_of_dof[dof_a];
            const double value =
                s_.factor_of_dof[dof_a] * s_.factor_of_dof[dof_b] * J.col(a).dot(MJ.col(b));
            A_out(row, col) += value;
            if (a != b) A_out(col, row) += value;
          }
        }
      }
    }
    for (const int i : s_.ball_v) {  // A = Sᵀ A_DART S, S = J_r on the ball's block
      const Eigen::Matrix3d J_r = rightJacobianSO3(ballAngle(i));
      ball_cols_.noalias() = A_out.middleCols<3>(i) * J_r;
      A_out.middleCols<3>(i) = ball_cols_;
      ball_rows_.noalias() = J_r.transpose() * A_out.middleRows<3>(i);
      A_out.middleRows<3>(i) = ball_rows_;
    }
  }

  void bias(Eigen::Ref<Eigen::VectorXd> b_out) const override {
    // b = Gᵀ h, h at the full velocities G v (G is constant, so no Ġ v term).
    b_out.setZero();
    if (s_.ball_v.empty()) {
      const Eigen::VectorXd& h = s_.skeleton->getCoriolisAndGravityForces();
      for (Eigen::Index d = 0; d < h.size(); ++d) {
        const auto dof = static_cast<std::size_t>(d);
        b_out[s_.v_of_dof[dof]] += s_.factor_of_dof[dof] * h[d];
      }
      return;
    }
    // With ball joints v̇_DART = S v̇ + Ṡ v: b = Sᵀ (C + g + M Ṡ v), the inverse dynamics
    // at the drift accelerations the skeleton holds.
    s_.skeleton->computeInverseDynamics(false, false, false);
    for (std::size_t dof = 0; dof < s_.v_of_dof.size(); ++dof)
      b_out[s_.v_of_dof[dof]] += s_.factor_of_dof[dof] * s_.skeleton->getForce(dof);
    for (const int i : s_.ball_v) {
      const Eigen::Vector3d b_ball = rightJacobianSO3(ballAngle(i)).transpose() * b_out.segment<3>(i);
      b_out.segment<3>(i) = b_ball;
    }
  }

  void forwardDynamics(const Eigen::Ref<const Eigen::VectorXd>& tau_J,
                       Eigen::Ref<Eigen::VectorXd> vdot_out) const override {
    if (s_.has_mimic) {
      // DART's articulated-body algorithm knows no coupling: solve A v̇ = τ − b in the
      // reduced coordinates (followers are passive; the coupling acts on the leader).
      if (tau_J.size() != s_.info.nj)
        throw InvalidStateError("torque vector has " + std::to_string(tau_J.size()) +
                                " entries, expected nj = " + std::to_string(s_.info.nj));
      massMatrix(A_scratch_);
      bias(b_scratch_);
      b_scratch_ = -b_scratch_;
      b_scratch_.tail(s_.info.nj) += tau_J;
      llt_.compute(A_scratch_);
      llt_.solveInPlace(b_scratch_);
      vdot_out = b_scratch_;
      return;
    }
    setSkeletonForces(tau_J);
    s_.skeleton->computeForwardDynamics();
    for (int i = 0; i < s_.info.nv; ++i)
      vdot_out[i] = s_.skeleton->getAcceleration(static_cast<std::size_t>(s_.dof_of_v[i]));
    for (const int i : s_.ball_v) {  // v̇_DART = J_r θ̈ + J̇_r θ̇
      const Eigen::Vector3d rhs =
          vdot_out.segment<3>(i) - dart_a_.segment<3>(s_.dof_of_v[i]);
      vdot_out.segment<3>(i) = rightJacobianSO3(ballAngle(i)).partialPivLu().solve(rhs);
    }
    setSkeletonAccelerations();  // pointJacobianDotTimesV relies on them
  }

  void detectContacts(ContactList& out) const override {
    out.clear();
    collision_result_.clear();
    // One more than fits, so that truncation shows up as an overflow.
    dart::collision::CollisionOption option(true, out.capacity() + 1, collision_filter_);
    collision_group_->collide(option, &collision_result_);
    for (const auto& c : collision_result_.getContacts()) {
      // A persistent Bullet group keeps contact manifolds between calls; points that
      // have separated (negative depth) linger until the breaking threshold: skip them.
      if (!(c.penetrationDepth >= 0.0)) continue;
      const auto* node1 = c.collisionObject1->getShapeFrame()->asShapeNode();
      const auto* node2 = c.collisionObject2->getShapeFrame()->asShapeNode();
      if (node1 == nullptr || node2 == nullptr) continue;
      const bool robot_first = node1->getSkeleton() == s_.skeleton;
      const auto body = s_.body_of_shape.find(robot_first ? node1 : node2);
      if (body == s_.body_of_shape.end()) continue;  // a shape added after attaching
      const auto object = s_.object_of_body.find((robot_first ? node2 : node1)->getBodyNodePtr().get());
      ContactCandidate cand;
      cand.body = body->second;
      cand.object = object == s_.object_of_body.end() ? kGroundObject : object->second;
      // DART's normal points from object 2 to object 1.
      cand.n_W = (robot_first ? c.normal : -c.normal).normalized();
      cand.depth_m = c.penetrationDepth;
      cand.p_WC = c.point;
      cand.p_BC = bodyPose(cand.body).inverse() * cand.p_WC;
      out.push(cand);
    }
    appendGroundContacts(s_.ground_shapes, *this, s_.environment.ground, out);
  }

  void simulateStep(const Eigen::Ref<const Eigen::VectorXd>& tau_J, double dt_s) override {
    if (!(dt_s > 0.0) || !std::isfinite(dt_s))
      throw std::invalid_argument("simulateStep: dt must be positive and finite");
    if (s_.world->getTimeStep() != dt_s) s_.world->setTimeStep(dt_s);
    // DART asserts (aborts) on NaN inside a step; refuse input that would get there.
    if (!tau_J.allFinite() || !(v_.cwiseAbs().maxCoeff() < kMaxSimulatedSpeed))
      throw std::runtime_error("DART simulation refused: non-finite torque or runaway velocity");
    setSkeletonForces(tau_J);
    if (s_.has_mimic) separateExactMimicFollowers();
    s_.world->step();
    // A diverged step would reach DART's live assertions on the next call: keep the last
    // finite state and say so.
    if (!pullSkeletonState()) {
      pushState();
      throw std::runtime_error("DART simulation diverged (non-finite state); state kept");
    }
  }

 private:
  int baseV() const { return s_.info.floating_base ? kFloatingBaseNv : 0; }
  int baseQ() const { return s_.info.floating_base ? kFloatingBaseNq : 0; }
  // θ of the ball joint whose first velocity coordinate is @p i.
  Eigen::Vector3d ballAngle(int i) const { return q_.segment<3>(i - baseV() + baseQ()); }

  // Our (q, v) → DART positions, velocities, and the drift accelerations (zero but for
  // ball joints, J̇_r θ̇).
  void pushState() {
    if (s_.info.floating_base)
      dart_q_.head<6>() =
          dart::dynamics::FreeJoint::convertToPositions(basePoseFromConfiguration(q_));
    const int base_q = baseQ(), base_v = baseV();
    for (Eigen::Index d = 0; d < dart_q_.size(); ++d) {
      const auto dof = static_cast<std::size_t>(d);
      const int i = s_.v_of_dof[dof];
      const double factor = s_.factor_of_dof[dof];
      dart_v_[d] = factor * v_[i];
      if (i >= base_v) dart_q_[d] = factor * q_[base_q + i - base_v] + s_.offset_of_dof[dof];
    }
    for (const int i : s_.ball_v) {
      const Eigen::Vector3d theta = ballAngle(i);
      const Eigen::Vector3d theta_dot = v_.segment<3>(i);
      dart_v_.segment<3>(s_.dof_of_v[i]) = rightJacobianSO3(theta) * theta_dot;
      dart_a_.segment<3>(s_.dof_of_v[i]) = rightJacobianSO3DotTimes(theta, theta_dot);
    }
    s_.skeleton->setPositions(dart_q_);
    s_.skeleton->setVelocities(dart_v_);
    setSkeletonAccelerations();
  }

  // DART 6.12's mimic motor constraint counts itself active but has no rows when its
  // follower moves exactly as its leader commands (a velocity error of 0.0, as after every
  // setState), and World::step then aborts on an assertion (BoxedLcpConstraintSolver,
  // getDimension() > 0; seen on Talos and Tiago Pro). A follower 1e-12 rad/s (or m/s) off
  // is not exact, and moves nothing measurable.
  void separateExactMimicFollowers() const {
    for (std::size_t j = 0; j < s_.skeleton->getNumJoints(); ++j) {
      dart::dynamics::Joint* joint = s_.skeleton->getJoint(j);
      const dart::dynamics::Joint* leader = joint->getMimicJoint();
      if (joint->getActuatorType() != dart::dynamics::Joint::MIMIC || leader == nullptr) continue;
      for (std::size_t i = 0; i < joint->getNumDofs(); ++i)
        if (joint->getVelocity(i) == joint->getMimicMultiplier() * leader->getVelocity(i))
          joint->setVelocity(i, joint->getVelocity(i) + 1e-12);
    }
  }

  // Per DoF: Skeleton::setAccelerations allocates (DART 6.12).
  void setSkeletonAccelerations() const {
    for (Eigen::Index i = 0; i < dart_a_.size(); ++i)
      s_.skeleton->setAcceleration(static_cast<std::size_t>(i), dart_a_[i]);
  }

  SkeletonModelSetup s_;
  std::shared_ptr<dart::collision::CollisionDetector> detector_;
  std::unique_ptr<dart::collision::CollisionGroup> collision_group_;
  std::shared_ptr<dart::collision::CollisionFilter> collision_filter_;
  mutable dart::collision::CollisionResult collision_result_;
  Eigen::VectorXd q_, v_;
  Eigen::VectorXd dart_q_, dart_v_, dart_a_;
  mutable Eigen::VectorXd dart_tau_;
  mutable Eigen::VectorXd read_q_, read_v_;  // readSkeletonState scratch
  mutable Matrix6Xd inertia_times_J_;    // scratch, 6 × ndofs
  mutable Eigen::MatrixXd ball_cols_, ball_rows_;  // scratch, nv × 3 and 3 × nv
  mutable Eigen::MatrixXd A_scratch_;    // forward dynamics with mimic joints
  mutable Eigen::VectorXd b_scratch_;
  mutable Eigen::LLT<Eigen::MatrixXd> llt_;
};

}  // namespace

std::shared_ptr<dart::collision::CollisionFilter> makeRobotVersusOthersFilter(
    const dart::dynamics::Skeleton* robot, const dart::dynamics::ShapeFrame* ground_slab,
    const dart::dynamics::ShapeFrame* ground_plane, bool engine_ground_contacts) {
  return std::make_shared<RobotVersusOthersFilter>(robot, ground_slab, ground_plane,
                                                   engine_ground_contacts);
}

void enableHullContacts(dart::collision::CollisionGroup* group) {
  auto* bullet = dynamic_cast<dart::collision::BulletCollisionGroup*>(group);
  if (bullet == nullptr) throw std::logic_error("DART backend: collision group is not Bullet's");
  btCollisionWorld* world = BulletWorldAccess::of(bullet);
  btGImpactCollisionAlgorithm::registerAlgorithm(
      static_cast<btCollisionDispatcher*>(world->getDispatcher()));
  // Without the meshes' default 1 cm margin a hull reports its vertices below the ground
  // plane at their true depth.
  for (int i = 0; i < world->getNumCollisionObjects(); ++i) {
    btCollisionShape* shape = world->getCollisionObjectArray()[i]->getCollisionShape();
    if (shape->getShapeType() != GIMPACT_SHAPE_PROXYTYPE) continue;
    shape->setMargin(0.0);
    static_cast<btGImpactShapeInterface*>(shape)->updateBound();
  }
}

std::unique_ptr<SkeletonModel> makeSkeletonModel(SkeletonModelSetup setup) {
  return std::make_unique<DartSkeletonModel>(std::move(setup));
}

}  // namespace dynfilter::dart_backend
