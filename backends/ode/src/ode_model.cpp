#include "dynfilter/ode/ode_model.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <ode/ode.h>

#include "dynfilter/core/ball_joint.hpp"
#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "ode_bodies.hpp"
#include "ode_world.hpp"

namespace dynfilter::ode_backend {
namespace {

// Contact points ODE may report for one robot-shape/environment-object pair (box-box
// face contact clips to at most 8; cylinders to a few more).
constexpr int kMaxContactsPerPair = 16;
// Contact joints the simulator creates per step at most.
constexpr int kMaxSimulationContacts = 256;
// Fraction of a mimic follower's position error its motor removes per step.
constexpr double kMimicErrorReduction = 0.2;

/// World state of one ODE body: origin (= CoM) position, rotation, and the velocities of
/// the origin. A body-less node (fixed-base root) is the world at rest.
struct BodyState {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  Eigen::Vector3d w = Eigen::Vector3d::Zero();

  /// World velocity of the body point at world position @p x.
  Eigen::Vector3d pointVelocity(const Eigen::Vector3d& x) const { return v + w.cross(x - p); }
};

/// ODE's own state of one body, kept between simulation steps.
struct SavedBody {
  std::array<dReal, 3> p{}, v{}, w{};
  std::array<dReal, 4> quat{};
};

class OdeModel;

/// What one dSpaceCollide2 pass does with the pairs it finds.
struct CollisionPass {
  const OdeModel* model = nullptr;
  ContactList* out = nullptr;  // detection: the candidates
  bool simulate = false;       // simulation: create contact joints
  int joints_created = 0;
};

// The bodies the backend builds from a URDF: OdeWorld, with its two spaces (robot,
// environment) and every geom tagged with its role.
class UrdfBodies final : public OdeBodies {
 public:
  UrdfBodies(const urdf::RobotDescription& robot, const ModelOptions& options)
      : world_(robot, options.floating_base, options.gravity_W, options.environment,
               options.enforce_joint_limits_in_simulation) {
    if (options.environment.has_ground) ground_shapes_ = urdf::groundContactShapes(robot);
  }
  dWorldID world() const override { return world_.world(); }
  dJointGroupID contactGroup() const override { return world_.contactGroup(); }
  const std::vector<OdeNode>& nodes() const override { return world_.nodes(); }
  const std::vector<OdeLinkFrame>& links() const override { return world_.links(); }
  int maxPathCoordinates() const override { return world_.maxDepth(); }
  void collide(void* data, dNearCallback* callback) const override {
    dSpaceCollide2(reinterpret_cast<dGeomID>(world_.robotSpace()),
                   reinterpret_cast<dGeomID>(world_.environmentSpace()), data, callback);
  }
  bool role(dGeomID geom, GeomRole& out) const override {
    const auto* tag = static_cast<const OdeGeomTag*>(dGeomGetData(geom));
    if (tag == nullptr) return false;
    out.robot = tag->robot;
    out.link = tag->link;
    out.object = tag->object;
    out.friction = tag->friction;
    return true;
  }
  const GroundContactShapes& groundShapes() const override { return ground_shapes_; }

 private:
  OdeWorld world_;
  GroundContactShapes ground_shapes_;
};

class OdeModel final : public OdeBodyModel {
 public:
  OdeModel(std::unique_ptr<OdeBodies> bodies, ModelInfo info, Environment environment,
           const Eigen::Vector3d& gravity_W, bool pull_initial_state)
      : info_(std::move(info)),
        environment_(std::move(environment)),
        gravity_W_(gravity_W),
        bodies_(std::move(bodies)),
        ode_(*bodies_),
        base_v_(info_.floating_base ? kFloatingBaseNv : 0),
        q_(info_.neutralConfiguration()),
        v_(Eigen::VectorXd::Zero(info_.nv)),
        R_WN_(ode_.nodes().size()),
        p_WN_(ode_.nodes().size()),
        w_WN_(ode_.nodes().size()),
        v_WN_(ode_.nodes().size()),
        J_compact_(6, kFloatingBaseNv + ode_.maxPathCoordinates()),
        MJ_compact_(6, kFloatingBaseNv + ode_.maxPathCoordinates()),
        columns_(static_cast<std::size_t>(kFloatingBaseNv + ode_.maxPathCoordinates())),
        A_scratch_(info_.nv, info_.nv),
        b_scratch_(info_.nv),
        llt_(info_.nv),
        contact_geoms_(kMaxContactsPerPair),
        saved_(ode_.nodes().size()) {
    node_of_coordinate_.assign(static_cast<std::size_t>(info_.nj), -1);
    for (std::size_t k = 0; k < ode_.nodes().size(); ++k) {
      const OdeNode& node = ode_.nodes()[k];
      body_ids_.push_back(node.body);
      if (node.coordinate >= 0 && !node.follower)
        node_of_coordinate_[static_cast<std::size_t>(node.coordinate)] = static_cast<int>(k);
    }
    if (pull_initial_state) {  // read, not posed: attaching leaves the user's bodies alone
      if (!readBodyState(q_, v_)) throw InvalidStateError("ODE bodies: the current state is not finite");
    } else {
      pushState();
    }
  }

  bool pullBodyState() override {
    for (const OdeNode& node : ode_.nodes()) {
      if (node.body == nullptr) continue;
      for (const dReal* x : {dBodyGetPosition(node.body), dBodyGetQuaternion(node.body),
                             dBodyGetLinearVel(node.body), dBodyGetAngularVel(node.body)})
        for (int i = 0; i < 3; ++i)
          if (!std::isfinite(x[i])) return false;
      if (!std::isfinite(dBodyGetQuaternion(node.body)[3])) return false;
    }
    simulation_state_saved_ = false;
    pullState();
    pushState();
    return true;
  }

  bool readBodyState(Eigen::Ref<Eigen::VectorXd> q, Eigen::Ref<Eigen::VectorXd> v) const override {
    if (q.size() != info_.nq || v.size() != info_.nv) return false;
    q = q_;  // hinge angles continue from the model's
    readBodies(q, v);
    return q.allFinite() && v.allFinite();
  }

  void addJointTorques(const Eigen::Ref<const Eigen::VectorXd>& tau_J) const override {
    requireTorques(tau_J);
    for (const OdeNode& node : ode_.nodes()) {
      // A mimic follower is passive: its motor holds the coupling (driveMimicFollowers).
      if (node.joint == nullptr || node.fixed || node.follower || node.coordinate < 0) continue;
      if (node.ball) {
        // t_C = J_r⁻ᵀ τ in the child's frame N, on the child; its opposite on the parent.
        const Eigen::Vector3d theta = q_.segment<3>(info_.configurationIndex(node.coordinate));
        const Eigen::Vector3d tau = tau_J.segment<3>(node.coordinate);
        const Eigen::Vector3d t_W = rotationFromOde(dBodyGetRotation(node.body)) *
                                    rightJacobianSO3(theta).transpose().partialPivLu().solve(tau);
        dBodyAddTorque(node.body, t_W.x(), t_W.y(), t_W.z());
        const dBodyID parent = ode_.nodes()[static_cast<std::size_t>(node.parent)].body;
        if (parent != nullptr) dBodyAddTorque(parent, -t_W.x(), -t_W.y(), -t_W.z());
        continue;
      }
      // The child moves along axis_sign × ODE's axis; ODE's torque acts on body 1 along
      // its axis: the same for either order (axis_sign flips both).
      const double tau = tau_J[node.coordinate];
      if (node.prismatic)
        dJointAddSliderForce(node.joint, tau);
      else
        dJointAddHingeTorque(node.joint, tau);
    }
  }

  const std::vector<dBodyID>& bodies() const override { return body_ids_; }

  const ModelInfo& info() const override { return info_; }
  std::string_view backendName() const override { return "ode"; }
  const Environment& environment() const override { return environment_; }

  void setState(const Eigen::Ref<const Eigen::VectorXd>& q,
                const Eigen::Ref<const Eigen::VectorXd>& v) override {
    info_.requireValidState(q, v);
    q_ = q;
    v_ = v;
    if (info_.floating_base) q_.segment<4>(3).normalize();
    simulation_state_saved_ = false;  // the bodies now follow (q, v), not the last step
    pushState();
  }
  const Eigen::VectorXd& q() const override { return q_; }
  const Eigen::VectorXd& v() const override { return v_; }

  Eigen::Isometry3d bodyPose(int body) const override {
    const OdeLinkFrame& f = ode_.links()[static_cast<std::size_t>(body)];
    return bodyPoseOfNode(f.node) * f.X_BL;
  }

  Vector6d bodyVelocity(int body) const override {
    const OdeLinkFrame& f = ode_.links()[static_cast<std::size_t>(body)];
    const BodyState s = state(f.node);
    const Eigen::Vector3d p_WL = s.p + s.R * f.X_BL.translation();
    Vector6d V;
    V << s.pointVelocity(p_WL), s.w;
    return V;
  }

  void pointJacobian(int body, const Eigen::Vector3d& p_BP,
                     Eigen::Ref<Matrix6Xd> J_out) const override {
    const OdeLinkFrame& f = ode_.links()[static_cast<std::size_t>(body)];
    const Eigen::Vector3d p = bodyPoseOfNode(f.node) * (f.X_BL * p_BP);
    J_out.setZero();
    const int d = compactJacobian(f.node, p);
    for (int i = 0; i < d; ++i)  // a mimic follower's column adds to its leader's
      J_out.col(columns_[static_cast<std::size_t>(i)]) += J_compact_.col(i);
  }

  Vector6d pointJacobianDotTimesV(int body, const Eigen::Vector3d& p_BP) const override {
    const OdeLinkFrame& f = ode_.links()[static_cast<std::size_t>(body)];
    const Eigen::Vector3d p = bodyPoseOfNode(f.node) * (f.X_BL * p_BP);
    return drift(f.node, p);
  }

  void massMatrix(Eigen::Ref<Eigen::MatrixXd> A_out) const override {
    // A = Σ_k J_kᵀ diag(m_k I₃, R_k I_k R_kᵀ) J_k over the ODE bodies, J_k the Jacobian of
    // body k's origin (its CoM), m_k and I_k (body axes) from dBodyGetMass.
    A_out.setZero();
    const auto& nodes = ode_.nodes();
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      const dBodyID body = nodes[k].body;
      if (body == nullptr || !(nodes[k].mass_kg > 0.0)) continue;  // world or massless
      double m = 0.0;
      Eigen::Matrix3d I_W;
      massProperties(nodes[k], m, I_W);
      const int d = compactJacobian(static_cast<int>(k), toEigen(dBodyGetPosition(body)));
      auto J = J_compact_.leftCols(d);
      auto MJ = MJ_compact_.leftCols(d);
      MJ.topRows<3>() = m * J.topRows<3>();
      MJ.bottomRows<3>().noalias() = I_W * J.bottomRows<3>();
      for (int b = 0; b < d; ++b) {
        const int col = columns_[static_cast<std::size_t>(b)];
        for (int a = 0; a <= b; ++a) {
          const int row = columns_[static_cast<std::size_t>(a)];
          const double value = J.col(a).dot(MJ.col(b));
          A_out(row, col) += value;
          if (a != b) A_out(col, row) += value;  // twice on the diagonal for a follower
                                                 // and its leader in one chain
        }
      }
    }
  }

  void bias(Eigen::Ref<Eigen::VectorXd> b_out) const override {
    // b = Σ_k J_kᵀ [m_k (a_k − g); I_W α_k + ω_k × I_W ω_k] with (a_k, α_k) = J̇_k v at the
    // CoM: the Newton–Euler wrench each body needs at v̇ = 0, mapped to the coordinates.
    b_out.setZero();
    const auto& nodes = ode_.nodes();
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      const dBodyID body = nodes[k].body;
      if (body == nullptr || !(nodes[k].mass_kg > 0.0)) continue;  // world or massless
      double m = 0.0;
      Eigen::Matrix3d I_W;
      massProperties(nodes[k], m, I_W);
      const Eigen::Vector3d c = toEigen(dBodyGetPosition(body));
      const Eigen::Vector3d w = toEigen(dBodyGetAngularVel(body));
      const Vector6d a = drift(static_cast<int>(k), c);
      Vector6d wrench;
      wrench.head<3>() = m * (a.head<3>() - gravity_W_);
      wrench.tail<3>() = I_W * a.tail<3>() + w.cross(I_W * w);
      const int d = compactJacobian(static_cast<int>(k), c);
      for (int i = 0; i < d; ++i)
        b_out[columns_[static_cast<std::size_t>(i)]] += J_compact_.col(i).dot(wrench);
    }
  }

  void forwardDynamics(const Eigen::Ref<const Eigen::VectorXd>& tau_J,
                       Eigen::Ref<Eigen::VectorXd> vdot_out) const override {
    requireTorques(tau_J);
    massMatrix(A_scratch_);
    bias(b_scratch_);
    b_scratch_ = -b_scratch_;
    b_scratch_.tail(info_.nj) += tau_J;
    llt_.compute(A_scratch_);
    llt_.solveInPlace(b_scratch_);
    vdot_out = b_scratch_;
  }

  void detectContacts(ContactList& out) const override {
    out.clear();
    CollisionPass pass;
    pass.model = this;
    pass.out = &out;
    collide(pass);
    appendGroundContacts(ode_.groundShapes(), *this, environment_.ground, out);
  }

  void simulateStep(const Eigen::Ref<const Eigen::VectorXd>& tau_J, double dt_s) override {
    if (!(dt_s > 0.0) || !std::isfinite(dt_s))
      throw std::invalid_argument("simulateStep: dt must be positive and finite");
    requireTorques(tau_J);
    // ODE asserts (aborts) on a non-finite rotation inside a step; refuse a diverged start.
    if (!(v_.cwiseAbs().maxCoeff() < kMaxSimulatedSpeed))
      throw std::runtime_error("ODE simulation refused: runaway velocity (state kept)");
    // Continue from ODE's own state after the previous step (its bodies satisfy the joint
    // constraints only up to the stepper's drift); after setState the bodies are (q, v).
    if (simulation_state_saved_) restoreSimulationState();
    driveMimicFollowers(dt_s);
    addJointTorques(tau_J);
    CollisionPass pass;
    pass.model = this;
    pass.simulate = true;
    collide(pass);
    q_before_step_ = q_;
    v_before_step_ = v_;
    dWorldStep(ode_.world(), dt_s);
    dJointGroupEmpty(ode_.contactGroup());
    pullState();
    if (!q_.allFinite() || !v_.allFinite()) {
      q_ = q_before_step_;
      v_ = v_before_step_;
      simulation_state_saved_ = false;
      pushState();
      throw std::runtime_error("ODE simulation diverged (non-finite state); state kept");
    }
    saveSimulationState();
    simulation_state_saved_ = true;
    // Queries answer for (q, v): pose the bodies by forward kinematics again.
    pushState();
  }

  // Called by the collision callback for each potentially touching pair.
  void handlePair(dGeomID g1, dGeomID g2, CollisionPass& pass) const {
    GeomRole r1, r2;
    if (!ode_.role(g1, r1) || !ode_.role(g2, r2) || r1.robot == r2.robot) return;
    const bool robot_first = r1.robot;
    const dGeomID robot_geom = robot_first ? g1 : g2;
    const dGeomID env_geom = robot_first ? g2 : g1;
    const GeomRole& robot = robot_first ? r1 : r2;
    const GeomRole& env = robot_first ? r2 : r1;
    // The hulls' and cylinders' ground contacts come from detectContacts itself
    // (engine-independent).
    if (!pass.simulate && !ode_.groundShapes().empty() && dGeomGetClass(env_geom) == dPlaneClass &&
        (dGeomGetClass(robot_geom) == dConvexClass || dGeomGetClass(robot_geom) == dCylinderClass))
      return;
    // dCollide(robot, environment): ODE's normal then points out of the environment into
    // the robot shape, i.e. it pushes the body out, and it is the right normal for a
    // contact joint attached (robot body, world).
    const int n = dCollide(robot_geom, env_geom, kMaxContactsPerPair, contact_geoms_.data(),
                           sizeof(dContactGeom));
    if (pass.simulate) {
      const dBodyID body = dGeomGetBody(robot_geom);
      if (body == nullptr) return;  // a shape on the fixed root: the world touching itself
      for (int i = 0; i < n && pass.joints_created < kMaxSimulationContacts; ++i) {
        dContact contact;
        contact.surface.mode = dContactApprox1;
        contact.surface.mu = env.friction;
        contact.surface.bounce = 0.0;
        contact.geom = contact_geoms_[static_cast<std::size_t>(i)];
        contact.fdir1[0] = contact.fdir1[1] = contact.fdir1[2] = 0.0;
        dJointID joint = dJointCreateContact(ode_.world(), ode_.contactGroup(), &contact);
        dJointAttach(joint, body, dGeomGetBody(env_geom));  // null: static geometry
        ++pass.joints_created;
      }
      return;
    }
    for (int i = 0; i < n; ++i) {
      const dContactGeom& g = contact_geoms_[static_cast<std::size_t>(i)];
      ContactCandidate c;
      c.body = robot.link;
      c.object = env.object;
      c.n_W = toEigen(g.normal).normalized();
      c.depth_m = std::max(0.0, static_cast<double>(g.depth));
      // ODE's `pos` is on the robot shape for some primitive pairs (box/plane vertices)
      // and on the environment's surface for others (box/box, sphere/box). The point on
      // the body is the one that lies depth_m deep in the environment: shift pos along
      // the normal by what it lacks.
      const double pos_depth = std::clamp(environmentDepth(env_geom, g.pos), 0.0, c.depth_m);
      c.p_WC = toEigen(g.pos) - c.n_W * (c.depth_m - pos_depth);
      c.p_BC = bodyPose(c.body).inverse() * c.p_WC;
      pass.out->push(c);
    }
  }

 private:
  static void nearCallback(void* data, dGeomID g1, dGeomID g2) {
    auto* pass = static_cast<CollisionPass*>(data);
    pass->model->handlePair(g1, g2, *pass);
  }

  void collide(CollisionPass& pass) const {
    ensureOdeInitialised();  // ODE's per-thread collision data for this thread
    ode_.collide(&pass, &nearCallback);
  }

  /// Depth of the world point @p x inside the environment geom (positive inside).
  static double environmentDepth(dGeomID env_geom, const dReal* x) {
    switch (dGeomGetClass(env_geom)) {
      case dPlaneClass:
        return dGeomPlanePointDepth(env_geom, x[0], x[1], x[2]);
      case dBoxClass:
        return dGeomBoxPointDepth(env_geom, x[0], x[1], x[2]);
      default:
        return 0.0;
    }
  }

  /// Sets each mimic follower's motor velocity for the coming dWorldStep: it drives the
  /// follower to factor · q_leader + offset (velocity target with a Baumgarte-style
  /// position correction, unbounded motor force).
  void driveMimicFollowers(double dt_s) const {
    for (const OdeNode& node : ode_.nodes()) {
      if (!node.follower) continue;
      const OdeNode& leader = ode_.nodes()[static_cast<std::size_t>(
          node_of_coordinate_[static_cast<std::size_t>(node.coordinate)])];
      const double q_l = jointPosition(leader), v_l = jointRate(leader);
      const double error = node.factor * q_l + node.offset - jointPosition(node);
      const double target = node.factor * v_l + kMimicErrorReduction * error / dt_s;
      if (node.prismatic)
        dJointSetLMotorParam(node.mimic_motor, dParamVel, target);
      else
        dJointSetAMotorParam(node.mimic_motor, dParamVel, target);
    }
  }

  // A joint's position and rate as ODE measures them (zero at the creation pose, q = 0).
  static double jointPosition(const OdeNode& n) {
    return n.prismatic ? dJointGetSliderPosition(n.joint) : dJointGetHingeAngle(n.joint);
  }
  static double jointRate(const OdeNode& n) {
    return n.prismatic ? dJointGetSliderPositionRate(n.joint) : dJointGetHingeAngleRate(n.joint);
  }

  void requireTorques(const Eigen::Ref<const Eigen::VectorXd>& tau_J) const {
    if (tau_J.size() != info_.nj)
      throw InvalidStateError("torque vector has " + std::to_string(tau_J.size()) +
                              " entries, expected nj = " + std::to_string(info_.nj));
  }

  BodyState state(int node) const {
    BodyState s;
    const OdeNode& n = ode_.nodes()[static_cast<std::size_t>(node)];
    if (n.body == nullptr) {
      s.p = n.p_NCom;  // the world-fixed root: body frame at its (static) CoM
      return s;
    }
    s.R = rotationFromOde(dBodyGetRotation(n.body));
    s.p = toEigen(dBodyGetPosition(n.body));
    s.v = toEigen(dBodyGetLinearVel(n.body));
    s.w = toEigen(dBodyGetAngularVel(n.body));
    return s;
  }

  /// X_WB of the ODE body of @p node (for the body-less fixed root: at its CoM).
  Eigen::Isometry3d bodyPoseOfNode(int node) const {
    const OdeNode& n = ode_.nodes()[static_cast<std::size_t>(node)];
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    if (n.body == nullptr) {
      X.translation() = n.p_NCom;
      return X;
    }
    X.linear() = rotationFromOde(dBodyGetRotation(n.body));
    X.translation() = toEigen(dBodyGetPosition(n.body));
    return X;
  }

  static void massProperties(const OdeNode& node, double& m, Eigen::Matrix3d& I_W) {
    const dBodyID body = node.body;
    dMass mass;
    dBodyGetMass(body, &mass);
    m = mass.mass;
    Eigen::Matrix3d I_B = rotationFromOde(mass.I);  // same 3 × 4 layout
    I_B.diagonal().array() -= node.inertia_lift;
    const Eigen::Matrix3d R = rotationFromOde(dBodyGetRotation(body));
    I_W.noalias() = R * I_B * R.transpose();
  }

  /// Jacobian of the world point @p p moving with @p node, from ODE's joints in world
  /// coordinates: its nonzero columns into J_compact_, their indices in v into columns_.
  /// Returns the number of columns.
  int compactJacobian(int node, const Eigen::Vector3d& p) const {
    const auto& nodes = ode_.nodes();
    int d = 0;
    for (int k = node; nodes[static_cast<std::size_t>(k)].parent >= 0;
         k = nodes[static_cast<std::size_t>(k)].parent) {
      const OdeNode& n = nodes[static_cast<std::size_t>(k)];
      if (n.fixed) continue;
      if (n.ball) {
        // ω_rel = R_WN J_r(θ) θ̇ about the anchor o.
        dVector3 anchor;
        dJointGetBallAnchor(n.joint, anchor);
        const Eigen::Matrix3d R_WN = rotationFromOde(dBodyGetRotation(n.body));
        const Eigen::Matrix3d columns =
            R_WN * rightJacobianSO3(q_.segment<3>(info_.configurationIndex(n.coordinate)));
        const Eigen::Vector3d r = p - toEigen(anchor);
        for (int i = 0; i < kBallJointDofs; ++i) {
          columns_[static_cast<std::size_t>(d)] = base_v_ + n.coordinate + i;
          J_compact_.col(d) << columns.col(i).cross(r), columns.col(i);
          ++d;
        }
        continue;
      }
      columns_[static_cast<std::size_t>(d)] = base_v_ + n.coordinate;
      dVector3 axis;
      if (n.prismatic) {
        dJointGetSliderAxis(n.joint, axis);
        J_compact_.col(d) << n.factor * n.axis_sign * toEigen(axis), Eigen::Vector3d::Zero();
      } else {
        dVector3 anchor;
        dJointGetHingeAxis(n.joint, axis);
        dJointGetHingeAnchor(n.joint, anchor);
        const Eigen::Vector3d a = n.factor * n.axis_sign * toEigen(axis);
        J_compact_.col(d) << a.cross(p - toEigen(anchor)), a;
      }
      ++d;
    }
    if (info_.floating_base) {
      // ṗ = R v_B + (R ω_B) × (p − p_B), ω = R ω_B.
      const OdeNode& root = nodes.front();
      const Eigen::Matrix3d R = rotationFromOde(dBodyGetRotation(root.body));
      const Eigen::Vector3d p_B = toEigen(dBodyGetPosition(root.body)) - R * root.p_NCom;
      const Eigen::Vector3d r = p - p_B;
      for (int i = 0; i < 3; ++i) {
        columns_[static_cast<std::size_t>(d)] = i;
        J_compact_.col(d) << R.col(i), Eigen::Vector3d::Zero();
        ++d;
      }
      for (int i = 0; i < 3; ++i) {
        columns_[static_cast<std::size_t>(d)] = 3 + i;
        J_compact_.col(d) << R.col(i).cross(r), R.col(i);
        ++d;
      }
    }
    return d;
  }

  /// J̇·v of the world point @p p moving with @p node: [p̈; ω̇] at v̇ = 0, from the ODE
  /// bodies' velocities. A joint's world axis a turns with its parent body (ȧ = ω_P × a);
  /// a hinge's anchor o moves with the parent.
  Vector6d drift(int node, const Eigen::Vector3d& p) const {
    const auto& nodes = ode_.nodes();
    const Eigen::Vector3d p_dot = state(node).pointVelocity(p);
    Eigen::Vector3d acc = Eigen::Vector3d::Zero();
    Eigen::Vector3d alpha = Eigen::Vector3d::Zero();
    for (int k = node; nodes[static_cast<std::size_t>(k)].parent >= 0;
         k = nodes[static_cast<std::size_t>(k)].parent) {
      const OdeNode& n = nodes[static_cast<std::size_t>(k)];
      if (n.fixed) continue;
      const BodyState parent = state(n.parent);
      if (n.ball) {
        // d/dt(R_WN J_r θ̇) at θ̈ = 0 = ω_P × ω_rel + R_WN J̇_r θ̇, about the anchor o.
        dVector3 anchor;
        dJointGetBallAnchor(n.joint, anchor);
        const Eigen::Vector3d o = toEigen(anchor);
        const Eigen::Vector3d theta = q_.segment<3>(info_.configurationIndex(n.coordinate));
        const Eigen::Vector3d theta_dot = v_.segment<3>(info_.velocityIndex(n.coordinate));
        const Eigen::Matrix3d R_WN = rotationFromOde(dBodyGetRotation(n.body));
        const Eigen::Vector3d w_rel = R_WN * (rightJacobianSO3(theta) * theta_dot);
        const Eigen::Vector3d w_rel_dot =
            parent.w.cross(w_rel) + R_WN * rightJacobianSO3DotTimes(theta, theta_dot);
        alpha += w_rel_dot;
        acc += w_rel_dot.cross(p - o) + w_rel.cross(p_dot - parent.pointVelocity(o));
        continue;
      }
      const double qd = n.factor * v_[base_v_ + n.coordinate];
      dVector3 axis;
      if (n.prismatic) {
        dJointGetSliderAxis(n.joint, axis);
        acc += parent.w.cross(n.axis_sign * toEigen(axis)) * qd;
      } else {
        dVector3 anchor;
        dJointGetHingeAxis(n.joint, axis);
        dJointGetHingeAnchor(n.joint, anchor);
        const Eigen::Vector3d a = n.axis_sign * toEigen(axis);
        const Eigen::Vector3d o = toEigen(anchor);
        const Eigen::Vector3d a_dot_qd = parent.w.cross(a) * qd;
        alpha += a_dot_qd;
        acc += a_dot_qd.cross(p - o) + (a * qd).cross(p_dot - parent.pointVelocity(o));
      }
    }
    if (info_.floating_base) {
      // d/dt [R v_B + ω_W × (p − p_B)] = ω_W × ṗ_B + ω_W × (ṗ − ṗ_B), ṗ_B = R v_B.
      const OdeNode& root = nodes.front();
      const BodyState s = state(0);
      const Eigen::Vector3d p_B = s.p - s.R * root.p_NCom;
      const Eigen::Vector3d p_B_dot = s.pointVelocity(p_B);
      acc += s.w.cross(p_B_dot) + s.w.cross(p_dot - p_B_dot);
    }
    Vector6d out;
    out << acc, alpha;
    return out;
  }

  /// (q, v) → ODE bodies: forward kinematics and the velocity recursion over the joint
  /// tree (node frames N), then each body at its CoM with N's axes.
  void pushState() {
    const auto& nodes = ode_.nodes();
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      const OdeNode& n = nodes[k];
      if (n.parent < 0) {
        if (info_.floating_base) {
          const Eigen::Quaterniond quat(q_[3], q_[4], q_[5], q_[6]);
          R_WN_[k] = quat.toRotationMatrix();
          p_WN_[k] = q_.head<3>();
          w_WN_[k] = R_WN_[k] * v_.segment<3>(3);
          v_WN_[k] = R_WN_[k] * v_.head<3>();
        } else {
          // Welded to the world at X_PJ (identity for a URDF's fixed root: the world).
          R_WN_[k] = n.X_PJ.linear();
          p_WN_[k] = n.X_PJ.translation();
          w_WN_[k].setZero();
          v_WN_[k].setZero();
        }
      } else {
        const auto P = static_cast<std::size_t>(n.parent);
        const Eigen::Matrix3d R_WJ = R_WN_[P] * n.X_PJ.linear();
        const Eigen::Vector3d p_WJ = p_WN_[P] + R_WN_[P] * n.X_PJ.translation();
        const Eigen::Vector3d a = R_WJ * n.axis_J;
        const int iq = n.coordinate < 0 ? 0 : info_.configurationIndex(n.coordinate);
        const int iv = n.coordinate < 0 ? 0 : info_.velocityIndex(n.coordinate);
        const double qj = n.coordinate < 0 ? 0.0 : n.factor * q_[iq] + n.offset;
        const double qd = n.coordinate < 0 ? 0.0 : n.factor * v_[iv];
        if (n.fixed) {
          R_WN_[k] = R_WJ;
          p_WN_[k] = p_WJ;
          w_WN_[k] = w_WN_[P];
          v_WN_[k] = v_WN_[P] + w_WN_[P].cross(p_WN_[k] - p_WN_[P]);
        } else if (n.ball) {
          const Eigen::Vector3d theta = q_.segment<3>(iq);
          R_WN_[k] = R_WJ * expSO3(theta);
          p_WN_[k] = p_WJ;
          w_WN_[k] = w_WN_[P] + R_WN_[k] * (rightJacobianSO3(theta) * v_.segment<3>(iv));
          v_WN_[k] = v_WN_[P] + w_WN_[P].cross(p_WN_[k] - p_WN_[P]);
        } else if (n.prismatic) {
          R_WN_[k] = R_WJ;
          p_WN_[k] = p_WJ + a * qj;
          w_WN_[k] = w_WN_[P];
          v_WN_[k] = v_WN_[P] + w_WN_[P].cross(p_WN_[k] - p_WN_[P]) + a * qd;
        } else {
          R_WN_[k] = R_WJ * Eigen::AngleAxisd(qj, n.axis_J).toRotationMatrix();
          p_WN_[k] = p_WJ;
          w_WN_[k] = w_WN_[P] + a * qd;
          v_WN_[k] = v_WN_[P] + w_WN_[P].cross(p_WN_[k] - p_WN_[P]);
        }
      }
      if (n.body == nullptr) continue;
      const Eigen::Vector3d r = R_WN_[k] * n.p_NCom;
      const Eigen::Vector3d c = p_WN_[k] + r;
      const Eigen::Vector3d v_c = v_WN_[k] + w_WN_[k].cross(r);
      dBodySetPosition(n.body, c.x(), c.y(), c.z());
      if (n.parent < 0 && info_.floating_base) {
        // The base by its quaternion, so that ODE keeps our sign and integrates it on
        // continuously (from a matrix ODE would choose the sign itself).
        const dQuaternion quat = {q_[3], q_[4], q_[5], q_[6]};
        dBodySetQuaternion(n.body, quat);
      } else {
        dMatrix3 R;
        toOdeRotation(R_WN_[k], R);
        dBodySetRotation(n.body, R);
      }
      dBodySetLinearVel(n.body, v_c.x(), v_c.y(), v_c.z());
      dBodySetAngularVel(n.body, w_WN_[k].x(), w_WN_[k].y(), w_WN_[k].z());
    }
  }

  /// ODE bodies → (q, v) after a step: the base from the root body (its CoM offset taken
  /// off), each joint coordinate from its child's pose and velocity relative to the
  /// parent's joint frame.
  void pullState() { readBodies(q_, v_); }

  /// Reads (q, v) into @p q and @p v (hinge angles continued from @p q's values).
  void readBodies(Eigen::Ref<Eigen::VectorXd> q, Eigen::Ref<Eigen::VectorXd> v) const {
    const auto& nodes = ode_.nodes();
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      const OdeNode& n = nodes[k];
      const BodyState s = state(static_cast<int>(k));
      // The node frame N from the body: same axes, origin off by the CoM.
      R_WN_[k] = s.R;
      p_WN_[k] = s.p - s.R * n.p_NCom;
      w_WN_[k] = s.w;
      v_WN_[k] = s.pointVelocity(p_WN_[k]);
      if (n.parent < 0) {
        if (!info_.floating_base) continue;
        const dReal* quat = dBodyGetQuaternion(n.body);  // (w, x, y, z), unit
        Eigen::Vector4d wxyz(quat[0], quat[1], quat[2], quat[3]);
        wxyz.normalize();
        q.head<3>() = p_WN_[k];
        q.segment<4>(3) = wxyz;
        // R from the stored quaternion, so that q and the base velocity agree exactly.
        const Eigen::Matrix3d R =
            Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]).toRotationMatrix();
        v.head<3>() = R.transpose() * v_WN_[k];
        v.segment<3>(3) = R.transpose() * w_WN_[k];
        continue;
      }
      if (n.fixed || n.follower) continue;  // a follower's position follows from its leader's
      const auto P = static_cast<std::size_t>(n.parent);
      const BodyState parent = state(n.parent);
      const Eigen::Matrix3d R_WJ = R_WN_[P] * n.X_PJ.linear();
      const Eigen::Vector3d p_WJ = p_WN_[P] + R_WN_[P] * n.X_PJ.translation();
      if (n.ball) {
        const Eigen::Vector3d theta = logSO3(R_WJ.transpose() * R_WN_[k]);
        q.segment<3>(info_.configurationIndex(n.coordinate)) = theta;
        v.segment<3>(info_.velocityIndex(n.coordinate)) = rightJacobianSO3(theta).partialPivLu().solve(
            Eigen::Vector3d(R_WN_[k].transpose() * (w_WN_[k] - parent.w)));
        continue;
      }
      const Eigen::Vector3d a = R_WJ * n.axis_J;
      double& qj = q[info_.configurationIndex(n.coordinate)];
      double& qd = v[info_.velocityIndex(n.coordinate)];
      if (n.prismatic) {
        qj = n.axis_J.dot(R_WJ.transpose() * (p_WN_[k] - p_WJ));
        qd = a.dot(v_WN_[k] - parent.pointVelocity(p_WN_[k]));
      } else {
        // R_JN = Rot(u, θ): u · vee(R − Rᵀ) = 2 sin θ, tr R − uᵀ R u = 2 cos θ.
        const Eigen::Matrix3d R_JN = R_WJ.transpose() * R_WN_[k];
        const Eigen::Vector3d& u = n.axis_J;
        const Eigen::Vector3d vee(R_JN(2, 1) - R_JN(1, 2), R_JN(0, 2) - R_JN(2, 0),
                                  R_JN(1, 0) - R_JN(0, 1));
        const double s2 = u.dot(vee);
        const double c2 = R_JN.trace() - u.dot(R_JN * u);
        const double theta = std::atan2(s2, c2);
        qj += std::remainder(theta - qj, 2.0 * M_PI);  // continuous across ±π
        qd = a.dot(w_WN_[k] - parent.w);
      }
    }
  }

  void saveSimulationState() {
    const auto& nodes = ode_.nodes();
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      const dBodyID body = nodes[k].body;
      if (body == nullptr) continue;
      SavedBody& s = saved_[k];
      std::copy_n(dBodyGetPosition(body), 3, s.p.begin());
      std::copy_n(dBodyGetQuaternion(body), 4, s.quat.begin());
      std::copy_n(dBodyGetLinearVel(body), 3, s.v.begin());
      std::copy_n(dBodyGetAngularVel(body), 3, s.w.begin());
    }
  }

  void restoreSimulationState() {
    const auto& nodes = ode_.nodes();
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      const dBodyID body = nodes[k].body;
      if (body == nullptr) continue;
      const SavedBody& s = saved_[k];
      dBodySetPosition(body, s.p[0], s.p[1], s.p[2]);
      dBodySetQuaternion(body, s.quat.data());
      dBodySetLinearVel(body, s.v[0], s.v[1], s.v[2]);
      dBodySetAngularVel(body, s.w[0], s.w[1], s.w[2]);
    }
  }

  ModelInfo info_;
  Environment environment_;
  Eigen::Vector3d gravity_W_;
  std::unique_ptr<OdeBodies> bodies_;
  const OdeBodies& ode_;
  std::vector<dBodyID> body_ids_;
  std::vector<int> node_of_coordinate_;  // the node joint coordinate c moves (its leader's)
  int base_v_;
  Eigen::VectorXd q_, v_;
  Eigen::VectorXd q_before_step_, v_before_step_;  // kept when a step diverges
  // Forward / inverse kinematics scratch per node: frame N in world and its velocities.
  mutable std::vector<Eigen::Matrix3d> R_WN_;
  mutable std::vector<Eigen::Vector3d> p_WN_, w_WN_, v_WN_;
  // Query scratch (the queries are const and must not allocate).
  mutable Matrix6Xd J_compact_, MJ_compact_;
  mutable std::vector<int> columns_;
  mutable Eigen::MatrixXd A_scratch_;
  mutable Eigen::VectorXd b_scratch_;
  mutable Eigen::LLT<Eigen::MatrixXd> llt_;
  mutable std::vector<dContactGeom> contact_geoms_;
  // ODE's body state after the last simulateStep (valid until the next setState).
  std::vector<SavedBody> saved_;
  bool simulation_state_saved_ = false;
};

}  // namespace

std::unique_ptr<IDynamicsModel> makeOdeModel(const urdf::RobotDescription& robot,
                                             const ModelOptions& options) {
  urdf::validateForDynamics(robot, options.floating_base);
  options.environment.validate();
  if (!options.gravity_W.allFinite()) throw std::invalid_argument("gravity is not finite");
  ensureOdeInitialised();
  return makeOdeBodyModel(std::make_unique<UrdfBodies>(robot, options),
                          urdf::makeModelInfo(robot, options.floating_base), options.environment,
                          options.gravity_W, false);
}

std::unique_ptr<OdeBodyModel> makeOdeBodyModel(std::unique_ptr<OdeBodies> bodies, ModelInfo info,
                                               Environment environment,
                                               const Eigen::Vector3d& gravity_W,
                                               bool pull_initial_state) {
  return std::make_unique<OdeModel>(std::move(bodies), std::move(info), std::move(environment),
                                    gravity_W, pull_initial_state);
}

std::unique_ptr<IDynamicsModel> loadOdeModel(const std::string& urdf_path,
                                             const ModelOptions& options) {
  return makeOdeModel(urdf::loadUrdfFile(urdf_path), options);
}

}  // namespace dynfilter::ode_backend
