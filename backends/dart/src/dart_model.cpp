#include "dynfilter/dart/dart_model.hpp"

#include <cmath>
#include <algorithm>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include <dart/collision/CollisionFilter.hpp>
#include <dart/collision/CollisionGroup.hpp>
#include <dart/collision/CollisionObject.hpp>
#include <dart/collision/CollisionResult.hpp>
#include <dart/collision/bullet/BulletCollisionDetector.hpp>
#include <dart/constraint/ConstraintSolver.hpp>
#include <dart/dynamics/FreeJoint.hpp>
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
class RobotVersusEnvironmentFilter final : public dart::collision::CollisionFilter {
 public:
  explicit RobotVersusEnvironmentFilter(const BuiltRobot& robot) : robot_(robot) {}
  bool ignoresCollision(const dart::collision::CollisionObject* a,
                        const dart::collision::CollisionObject* b) const override {
    return isRobot(a) == isRobot(b);
  }

 private:
  bool isRobot(const dart::collision::CollisionObject* o) const {
    return robot_.link_of_shape.count(o->getShapeFrame()) != 0;
  }
  const BuiltRobot& robot_;
};

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
        v_of_dof_(robot_.skeleton->getNumDofs(), -1),
        inertia_times_J_(6, robot_.skeleton->getNumDofs()) {
    for (int i = 0; i < info_.nv; ++i) v_of_dof_[static_cast<std::size_t>(robot_.dof_of_v[i])] = i;
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
    world_->setGravity(options.gravity_W);
    world_->addSkeleton(robot_.skeleton);
    world_->addSkeleton(env_.skeleton);
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
    J_out.setZero();
    for (std::size_t k = 0; k < dofs.size(); ++k) {
      const int i = v_of_dof_[dofs[k]];
      const Eigen::Vector3d omega = J_O.col(static_cast<Eigen::Index>(k)).head<3>();
      J_out.col(i).head<3>() = J_O.col(static_cast<Eigen::Index>(k)).tail<3>() + omega.cross(r_W);
      J_out.col(i).tail<3>() = omega;
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
      const Eigen::MatrixXd& M = robot_.skeleton->getMassMatrix();
      for (int j = 0; j < info_.nv; ++j)
        for (int i = 0; i < info_.nv; ++i)
          A_out(i, j) = M(robot_.dof_of_v[i], robot_.dof_of_v[j]);
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
      for (Eigen::Index b = 0; b < d; ++b) {
        const int col = v_of_dof_[dofs[static_cast<std::size_t>(b)]];
        for (Eigen::Index a = 0; a <= b; ++a) {
          const int row = v_of_dof_[dofs[static_cast<std::size_t>(a)]];
          const double value = J.col(a).dot(MJ.col(b));
          A_out(row, col) += value;
          if (row != col) A_out(col, row) += value;
        }
      }
    }
  }

  void bias(Eigen::Ref<Eigen::VectorXd> b_out) const override {
    const Eigen::VectorXd& h = robot_.skeleton->getCoriolisAndGravityForces();
    for (int i = 0; i < info_.nv; ++i) b_out[i] = h[robot_.dof_of_v[i]];
  }

  void forwardDynamics(const Eigen::Ref<const Eigen::VectorXd>& tau_J,
                       Eigen::Ref<Eigen::VectorXd> vdot_out) const override {
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
    for (int j = 0; j < info_.nj; ++j) dart_q_[robot_.dof_of_v[base_v + j]] = q_[base_q + j];
    for (int i = 0; i < info_.nv; ++i) dart_v_[robot_.dof_of_v[i]] = v_[i];
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
  std::vector<int> v_of_dof_;            // inverse of dof_of_v
  mutable Matrix6Xd inertia_times_J_;    // scratch, 6 × ndofs
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
