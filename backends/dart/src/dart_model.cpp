#include "dynfilter/dart/dart_model.hpp"

#include <cmath>
#include <algorithm>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include <Eigen/Cholesky>

#include <dart/collision/CollisionFilter.hpp>
#include <dart/collision/CollisionGroup.hpp>
#include <dart/collision/CollisionObject.hpp>
#include <dart/collision/CollisionResult.hpp>
#include <dart/collision/bullet/BulletCollisionDetector.hpp>
#include <dart/collision/bullet/BulletCollisionGroup.hpp>
#include <BulletCollision/Gimpact/btGImpactCollisionAlgorithm.h>
#include <dart/constraint/ConstraintSolver.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/MeshShape.hpp>
#include <dart/dynamics/PlaneShape.hpp>
#include <dart/dynamics/ShapeFrame.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <dart/simulation/World.hpp>

#include "dart_skeleton_builder.hpp"
#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"

namespace dynfilter::dart_backend {
namespace {

using dart::dynamics::Frame;


// Keeps only robot-versus-environment pairs in the one collision group that holds both.
// (DART's two-group collide() builds a temporary Bullet world on every call: ~300 µs.)
// The ground is two shapes: a slab for primitives (box-box gives the full contact polygon)
// and a plane for convex-hull meshes (Bullet reports each hull vertex below a plane, but
// only the closest point per triangle against a box).
class RobotVersusEnvironmentFilter final : public dart::collision::CollisionFilter {
 public:
  explicit RobotVersusEnvironmentFilter(const BuiltRobot& robot) : robot_(robot) {}
  bool ignoresCollision(const dart::collision::CollisionObject* a,
                        const dart::collision::CollisionObject* b) const override {
    const bool robot_a = isRobot(a);
    if (robot_a == isRobot(b)) return true;
    const auto* robot_object = robot_a ? a : b;
    const auto* env_object = robot_a ? b : a;
    const bool hull = robot_object->getShape()->is<dart::dynamics::MeshShape>();
    const auto* env_frame = env_object->getShapeFrame();
    const bool ground_plane = env_frame->getShape()->is<dart::dynamics::PlaneShape>();
    const bool ground_slab = env_frame->getName() == kGroundSlabShapeName;
    return hull ? ground_slab : ground_plane;
  }

 private:
  bool isRobot(const dart::collision::CollisionObject* o) const {
    return robot_.link_of_shape.count(o->getShapeFrame()) != 0;
  }
  const BuiltRobot& robot_;
};

// DART hands a MeshShape to Bullet as a btGImpactMeshShape but registers no collision
// algorithm for it (such a mesh then touches nothing): register Bullet's GImpact
// algorithm on the group's dispatcher and take the meshes' default 1 cm margin off, so a
// hull reports its vertices below the ground plane at their true depth.
// (DART 6.12 keeps the group's Bullet world protected; a derived class may name it.)
struct BulletWorldAccess : dart::collision::BulletCollisionGroup {
  static btCollisionWorld* of(dart::collision::BulletCollisionGroup* group) {
    btCollisionWorld* (dart::collision::BulletCollisionGroup::*get)() =
        &BulletWorldAccess::getBulletCollisionWorld;
    return (group->*get)();
  }
};

void enableHullContacts(dart::collision::CollisionGroup* group) {
  auto* bullet = dynamic_cast<dart::collision::BulletCollisionGroup*>(group);
  if (bullet == nullptr) throw std::logic_error("DART backend: collision group is not Bullet's");
  btCollisionWorld* world = BulletWorldAccess::of(bullet);
  btGImpactCollisionAlgorithm::registerAlgorithm(
      static_cast<btCollisionDispatcher*>(world->getDispatcher()));
  for (int i = 0; i < world->getNumCollisionObjects(); ++i) {
    btCollisionShape* shape = world->getCollisionObjectArray()[i]->getCollisionShape();
    if (shape->getShapeType() != GIMPACT_SHAPE_PROXYTYPE) continue;
    shape->setMargin(0.0);
    static_cast<btGImpactShapeInterface*>(shape)->updateBound();
  }
}

// Above this speed (m/s or rad/s in any coordinate) a state is treated as diverged.
constexpr double kMaxSimulatedSpeed = 1e3;

class DartModel final : public IDynamicsModel {
 public:
  DartModel(const urdf::RobotDescription& robot, const ModelOptions& options,
            DartMassMatrix mass_matrix)
      : info_(urdf::makeModelInfo(robot, options.floating_base)),
        environment_(options.environment),
        robot_(buildRobotSkeleton(robot, options.floating_base)),
        env_(buildEnvironmentSkeleton(options.environment)),
        q_(info_.neutralConfiguration()),
        v_(Eigen::VectorXd::Zero(info_.nv)),
        dart_q_(robot_.skeleton->getNumDofs()),
        dart_v_(robot_.skeleton->getNumDofs()),
        dart_tau_(robot_.skeleton->getNumDofs()),
        mass_matrix_(mass_matrix),
        v_of_dof_(robot_.v_of_dof),
        factor_of_dof_(robot_.factor_of_dof),
        inertia_times_J_(6, robot_.skeleton->getNumDofs()),
        A_scratch_(info_.nv, info_.nv),
        b_scratch_(info_.nv),
        llt_(info_.nv) {
    robot_.skeleton->setGravity(options.gravity_W);
    for (std::size_t k = 0; k < env_.skeleton->getNumBodyNodes(); ++k)
      env_object_[env_.skeleton->getBodyNode(k)] = env_.object_of_body[k];

    detector_ = dart::collision::BulletCollisionDetector::create();
    collision_group_ =
        detector_->createCollisionGroup(robot_.skeleton.get(), env_.skeleton.get());
    collision_filter_ = std::make_shared<RobotVersusEnvironmentFilter>(robot_);

    world_ = dart::simulation::World::create("dynfilter");
    world_->getConstraintSolver()->setCollisionDetector(
        dart::collision::BulletCollisionDetector::create());
    world_->getConstraintSolver()->getCollisionOption().collisionFilter = collision_filter_;
    world_->setGravity(options.gravity_W);
    world_->addSkeleton(robot_.skeleton);
    world_->addSkeleton(env_.skeleton);
    enableHullContacts(collision_group_.get());
    enableHullContacts(world_->getConstraintSolver()->getCollisionGroup().get());
    for (std::size_t i = 0; i < robot_.skeleton->getNumJoints(); ++i)
      robot_.skeleton->getJoint(i)->setLimitEnforcement(options.enforce_joint_limits_in_simulation);
    pushState();
  }

  const ModelInfo& info() const override { return info_; }
  std::string_view backendName() const override { return "dart"; }
  const Environment& environment() const override { return environment_; }

  void setState(const Eigen::Ref<const Eigen::VectorXd>& q,
                const Eigen::Ref<const Eigen::VectorXd>& v) override {
    info_.requireValidState(q, v);
    q_ = q;
    v_ = v;
    if (info_.floating_base) q_.segment<4>(3).normalize();
    pushState();
  }
  const Eigen::VectorXd& q() const override { return q_; }
  const Eigen::VectorXd& v() const override { return v_; }

  Eigen::Isometry3d bodyPose(int body) const override {
    const LinkFrame& f = robot_.links[body];
    return f.node->getWorldTransform() * f.X_NL;
  }

  Vector6d bodyVelocity(int body) const override {
    const LinkFrame& f = robot_.links[body];
    Vector6d V;
    V.head<3>() = f.node->getLinearVelocity(f.X_NL.translation(), Frame::World(), Frame::World());
    V.tail<3>() = f.node->getAngularVelocity(Frame::World(), Frame::World());
    return V;
  }

  void pointJacobian(int body, const Eigen::Vector3d& p_BP,
                     Eigen::Ref<Matrix6Xd> J_out) const override {
    // From DART's cached world Jacobian of the body origin ([angular; linear], dependent
    // coordinates only): shift to the point, ṗ_P = ṗ_O + ω × r, and scatter.
    const LinkFrame& f = robot_.links[body];
    const auto& J_O = f.node->getWorldJacobian();
    const auto& dofs = f.node->getDependentGenCoordIndices();
    const Eigen::Vector3d r_W = f.node->getWorldTransform().linear() * (f.X_NL * p_BP);
    // A mimic follower's column adds to its leader's, times the multiplier.
    J_out.setZero();
    for (std::size_t k = 0; k < dofs.size(); ++k) {
      const int i = v_of_dof_[dofs[k]];
      const double factor = factor_of_dof_[dofs[k]];
      const Eigen::Vector3d omega = J_O.col(static_cast<Eigen::Index>(k)).head<3>();
      J_out.col(i).head<3>() += factor * (J_O.col(static_cast<Eigen::Index>(k)).tail<3>() + omega.cross(r_W));
      J_out.col(i).tail<3>() += factor * omega;
    }
  }

  Vector6d pointJacobianDotTimesV(int body, const Eigen::Vector3d& p_BP) const override {
    // The skeleton's accelerations are kept at zero, so DART's classical point
    // acceleration is exactly the drift J̇·v.
    const LinkFrame& f = robot_.links[body];
    const Eigen::Vector3d p_N = f.X_NL * p_BP;
    Vector6d out;
    out.head<3>() = f.node->getLinearAcceleration(p_N, Frame::World(), Frame::World());
    out.tail<3>() = f.node->getAngularAcceleration(Frame::World(), Frame::World());
    return out;
  }

  void massMatrix(Eigen::Ref<Eigen::MatrixXd> A_out) const override {
    if (mass_matrix_ == DartMassMatrix::kSkeleton) {
      // A = Gᵀ M G with G the dof ← v map (one entry per dof, its factor).
      const Eigen::MatrixXd& M = robot_.skeleton->getMassMatrix();
      A_out.setZero();
      for (Eigen::Index b = 0; b < M.cols(); ++b)
        for (Eigen::Index a = 0; a < M.rows(); ++a)
          A_out(v_of_dof_[static_cast<std::size_t>(a)], v_of_dof_[static_cast<std::size_t>(b)]) +=
              factor_of_dof_[static_cast<std::size_t>(a)] * factor_of_dof_[static_cast<std::size_t>(b)] * M(a, b);
      return;
    }
    // A = Σ_k J_kᵀ M_k J_k over bodies, with DART's cached body Jacobians and spatial
    // inertias (both in the body frame): no allocation, ~10× faster than
    // Skeleton::getMassMatrix on the human figure.
    A_out.setZero();
    for (std::size_t k = 0; k < robot_.skeleton->getNumBodyNodes(); ++k) {
      const auto* node = robot_.skeleton->getBodyNode(k);
      const auto& J = node->getJacobian();
      const auto& dofs = node->getDependentGenCoordIndices();
      const Eigen::Index d = J.cols();
      auto MJ = inertia_times_J_.leftCols(d);
      MJ.noalias() = node->getSpatialInertia() * J;
      // Gᵀ (Jᵀ M J) G: a dof pair (a, b) adds f_a f_b (Jᵀ M J)_ab at (v(a), v(b)) and,
      // for a ≠ b, its transpose (twice onto the diagonal when a mimic follower and
      // its leader share one v).
      for (Eigen::Index b = 0; b < d; ++b) {
        const std::size_t dof_b = dofs[static_cast<std::size_t>(b)];
        const int col = v_of_dof_[dof_b];
        for (Eigen::Index a = 0; a <= b; ++a) {
          const std::size_t dof_a = dofs[static_cast<std::size_t>(a)];
          const int row = v_of_dof_[dof_a];
          const double value = factor_of_dof_[dof_a] * factor_of_dof_[dof_b] * J.col(a).dot(MJ.col(b));
          A_out(row, col) += value;
          if (a != b) A_out(col, row) += value;
        }
      }
    }
  }

  void bias(Eigen::Ref<Eigen::VectorXd> b_out) const override {
    // b = Gᵀ h, h at the full velocities G v (G is constant, so no Ġ v term).
    const Eigen::VectorXd& h = robot_.skeleton->getCoriolisAndGravityForces();
    b_out.setZero();
    for (Eigen::Index d = 0; d < h.size(); ++d)
      b_out[v_of_dof_[static_cast<std::size_t>(d)]] += factor_of_dof_[static_cast<std::size_t>(d)] * h[d];
  }

  void forwardDynamics(const Eigen::Ref<const Eigen::VectorXd>& tau_J,
                       Eigen::Ref<Eigen::VectorXd> vdot_out) const override {
    if (robot_.has_mimic) {
      // DART's articulated-body algorithm knows no coupling: solve A v̇ = τ − b in the
      // reduced coordinates (followers are passive; the coupling acts on the leader).
      if (tau_J.size() != info_.nj)
        throw InvalidStateError("torque vector has " + std::to_string(tau_J.size()) +
                                " entries, expected nj = " + std::to_string(info_.nj));
      massMatrix(A_scratch_);
      bias(b_scratch_);
      b_scratch_ = -b_scratch_;
      b_scratch_.tail(info_.nj) += tau_J;
      llt_.compute(A_scratch_);
      llt_.solveInPlace(b_scratch_);
      vdot_out = b_scratch_;
      return;
    }
    setJointForces(tau_J);
    robot_.skeleton->computeForwardDynamics();
    const Eigen::VectorXd& ddq = robot_.skeleton->getAccelerations();
    for (int i = 0; i < info_.nv; ++i) vdot_out[i] = ddq[robot_.dof_of_v[i]];
    robot_.skeleton->resetAccelerations();  // pointJacobianDotTimesV relies on zero
  }

  void detectContacts(ContactList& out) const override {
    out.clear();
    collision_result_.clear();
    // One more than fits, so that truncation shows up as an overflow.
    dart::collision::CollisionOption option(true, out.capacity() + 1, collision_filter_);
    collision_group_->collide(option, &collision_result_);
    for (const auto& c : collision_result_.getContacts()) {
      // The persistent group keeps Bullet's contact manifolds between calls; points that
      // have separated (negative depth) linger until the breaking threshold: skip them.
      if (!(c.penetrationDepth >= 0.0)) continue;
      const auto* frame1 = c.collisionObject1->getShapeFrame();
      const auto* frame2 = c.collisionObject2->getShapeFrame();
      const auto* node1 = frame1->asShapeNode();
      const auto* node2 = frame2->asShapeNode();
      if (node1 == nullptr || node2 == nullptr) continue;
      const bool robot_first = node1->getSkeleton() == robot_.skeleton;
      const auto* robot_shape = robot_first ? node1 : node2;
      const auto* env_body = (robot_first ? node2 : node1)->getBodyNodePtr().get();
      ContactCandidate cand;
      cand.body = robot_.link_of_shape.at(robot_shape);
      cand.object = env_object_.at(env_body);
      // DART's normal points from object 2 to object 1.
      cand.n_W = (robot_first ? c.normal : -c.normal).normalized();
      cand.depth_m = c.penetrationDepth;
      cand.p_WC = c.point;
      if (robot_shape->getShape()->is<dart::dynamics::MeshShape>() &&
          cand.object == kGroundObject) {
        // Bullet's GImpact-versus-plane contact puts the point one depth beyond the hull
        // vertex: move it back to the vertex, which lies depth_m below the plane.
        const GroundPlane& g = environment_.ground;
        const double below = g.offset_m - g.n_W.dot(cand.p_WC);
        cand.p_WC += cand.n_W * (below - cand.depth_m);
      }
      cand.p_BC = bodyPose(cand.body).inverse() * cand.p_WC;
      out.push(cand);
    }
  }

  void simulateStep(const Eigen::Ref<const Eigen::VectorXd>& tau_J, double dt_s) override {
    if (!(dt_s > 0.0) || !std::isfinite(dt_s))
      throw std::invalid_argument("simulateStep: dt must be positive and finite");
    if (world_->getTimeStep() != dt_s) world_->setTimeStep(dt_s);
    // DART asserts (aborts) on NaN inside a step; refuse input that would get there.
    if (!tau_J.allFinite() || !(v_.cwiseAbs().maxCoeff() < kMaxSimulatedSpeed))
      throw std::runtime_error("DART simulation refused: non-finite torque or runaway velocity");
    setJointForces(tau_J);
    world_->step();
    robot_.skeleton->resetAccelerations();
    // A diverged step would reach DART's live assertions on the next call: keep the last
    // finite state and say so.
    if (!robot_.skeleton->getPositions().allFinite() ||
        !robot_.skeleton->getVelocities().allFinite()) {
      pushState();
      throw std::runtime_error("DART simulation diverged (non-finite state); state kept");
    }
    pullState();
  }

 private:
  void setJointForces(const Eigen::Ref<const Eigen::VectorXd>& tau_J) const {
    if (tau_J.size() != info_.nj)
      throw InvalidStateError("torque vector has " + std::to_string(tau_J.size()) +
                              " entries, expected nj = " + std::to_string(info_.nj));
    dart_tau_.setZero();
    const int base = info_.floating_base ? 6 : 0;
    for (int j = 0; j < info_.nj; ++j) dart_tau_[robot_.dof_of_v[base + j]] = tau_J[j];
    robot_.skeleton->setForces(dart_tau_);
  }

  // Our (q, v) → DART positions and velocities.
  void pushState() {
    int base_q = 0;
    if (info_.floating_base) {
      dart_q_.head<6>() = dart::dynamics::FreeJoint::convertToPositions(
          basePoseFromConfiguration(q_));
      base_q = 7;
    }
    const int base_v = info_.floating_base ? 6 : 0;
    for (Eigen::Index d = 0; d < dart_q_.size(); ++d) {
      const auto k = static_cast<std::size_t>(d);
      const int i = v_of_dof_[k];
      dart_v_[d] = factor_of_dof_[k] * v_[i];
      if (i >= base_v) dart_q_[d] = factor_of_dof_[k] * q_[base_q + i - base_v] + robot_.offset_of_dof[k];
    }
    robot_.skeleton->setPositions(dart_q_);
    robot_.skeleton->setVelocities(dart_v_);
  }

  // DART → our (q, v), after the engine advanced the state.
  void pullState() {
    dart_q_ = robot_.skeleton->getPositions();
    dart_v_ = robot_.skeleton->getVelocities();
    int base_q = 0;
    if (info_.floating_base) {
      setBasePoseInConfiguration(
          dart::dynamics::FreeJoint::convertToTransform(dart_q_.head<6>()), q_);
      base_q = 7;
    }
    const int base_v = info_.floating_base ? 6 : 0;
    for (int j = 0; j < info_.nj; ++j) q_[base_q + j] = dart_q_[robot_.dof_of_v[base_v + j]];
    for (int i = 0; i < info_.nv; ++i) v_[i] = dart_v_[robot_.dof_of_v[i]];
  }

  ModelInfo info_;
  Environment environment_;
  BuiltRobot robot_;
  BuiltEnvironment env_;
  std::unordered_map<const dart::dynamics::BodyNode*, int> env_object_;
  std::shared_ptr<dart::collision::CollisionDetector> detector_;
  std::unique_ptr<dart::collision::CollisionGroup> collision_group_;
  std::shared_ptr<dart::collision::CollisionFilter> collision_filter_;
  mutable dart::collision::CollisionResult collision_result_;
  dart::simulation::WorldPtr world_;
  Eigen::VectorXd q_, v_;
  Eigen::VectorXd dart_q_, dart_v_;
  mutable Eigen::VectorXd dart_tau_;
  DartMassMatrix mass_matrix_;
  std::vector<int> v_of_dof_;            // dof → v index (mimic followers: their leader's)
  std::vector<double> factor_of_dof_;    // dof → mimic multiplier (1 otherwise)
  mutable Matrix6Xd inertia_times_J_;    // scratch, 6 × ndofs
  mutable Eigen::MatrixXd A_scratch_;    // forward dynamics with mimic joints
  mutable Eigen::VectorXd b_scratch_;
  mutable Eigen::LLT<Eigen::MatrixXd> llt_;
};

}  // namespace

std::unique_ptr<IDynamicsModel> makeDartModel(const urdf::RobotDescription& robot,
                                              const ModelOptions& options,
                                              DartMassMatrix mass_matrix) {
  urdf::validateForDynamics(robot, options.floating_base);
  options.environment.validate();
  if (!options.gravity_W.allFinite()) throw std::invalid_argument("gravity is not finite");
  return std::make_unique<DartModel>(robot, options, mass_matrix);
}

std::unique_ptr<IDynamicsModel> loadDartModel(const std::string& urdf_path,
                                              const ModelOptions& options,
                                              DartMassMatrix mass_matrix) {
  return makeDartModel(urdf::loadUrdfFile(urdf_path), options, mass_matrix);
}

}  // namespace dynfilter::dart_backend
