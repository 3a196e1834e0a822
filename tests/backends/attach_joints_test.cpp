// Ball, slider and fixed joints of a user's skeleton / bodies (the human figure has only
// hinges): one mechanism — a free base, a ball joint, a hinge (in ODE attached the other way
// round: the child is body 2), a slider, a weld — built in DART and in ODE by hand. The two
// attached models must agree; the ball's coordinates (ball_joint.hpp: q = θ, v = θ̇) must be
// consistent with each engine's own kinematics and energy; torques applied through each
// engine's API must move it as the model's forward dynamics says.
#include <cmath>
#include <random>
#include <type_traits>

#include <dart/dynamics/BallJoint.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/PrismaticJoint.hpp>
#include <dart/dynamics/RevoluteJoint.hpp>
#include <dart/dynamics/UniversalJoint.hpp>
#include <dart/dynamics/WeldJoint.hpp>
#include <dart/simulation/World.hpp>
#include <gtest/gtest.h>
#include <ode/ode.h>

#include "attach_support.hpp"
#include "dynfilter/core/ball_joint.hpp"
#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/dart/skeleton_model.hpp"
#include "dynfilter/ode/body_model.hpp"

namespace dynfilter {
namespace {

Eigen::Isometry3d translation(double x, double y, double z) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() << x, y, z;
  return X;
}

// One body of the mechanism: its joint, where the joint sits on the parent (X_PJ) and on
// the child (X_CJ), mass properties about the CoM c_C (child axes).
struct Part {
  const char* name;
  const char* joint;
  enum Kind { kFree, kBall, kHinge, kSlider, kWeld } kind;
  int parent;
  Eigen::Isometry3d X_PJ, X_CJ;
  Eigen::Vector3d axis;
  double mass;
  Eigen::Vector3d c_C;
  Eigen::Matrix3d I_C;
};

// Where a fixed base is welded to the world.
const Eigen::Isometry3d kBasePose = [] {
  Eigen::Isometry3d X = translation(0.2, -0.1, 1.0);
  X.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  return X;
}();

std::vector<Part> mechanism() {
  Eigen::Matrix3d I;
  I << 0.03, 0.002, -0.001, 0.002, 0.04, 0.003, -0.001, 0.003, 0.05;
  Eigen::Isometry3d weld = translation(0.05, 0.0, -0.1);
  weld.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  return {
      {"base", "root", Part::kFree, -1, Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity(),
       Eigen::Vector3d::UnitZ(), 3.0, Eigen::Vector3d(0.01, 0.02, -0.03), I},
      {"upper", "shoulder", Part::kBall, 0, translation(0.1, 0.0, -0.2), translation(0.0, 0.0, 0.15),
       Eigen::Vector3d::UnitZ(), 1.5, Eigen::Vector3d(0.0, 0.01, -0.02), 0.5 * I},
      {"lower", "elbow", Part::kHinge, 1, translation(0.0, 0.05, -0.2), translation(0.0, 0.0, 0.1),
       Eigen::Vector3d(0.3, 1.0, 0.2).normalized(), 1.0, Eigen::Vector3d(0.02, 0.0, -0.05), 0.3 * I},
      {"slide", "slider", Part::kSlider, 2, translation(0.0, 0.0, -0.2), Eigen::Isometry3d::Identity(),
       Eigen::Vector3d(1.0, 0.0, 0.5).normalized(), 0.5, Eigen::Vector3d(0.0, 0.0, -0.01), 0.2 * I},
      {"tip", "weld", Part::kWeld, 2, weld, Eigen::Isometry3d::Identity(), Eigen::Vector3d::UnitZ(),
       0.4, Eigen::Vector3d(0.01, 0.01, 0.0), 0.1 * I},
  };
}

template <typename JointT>
dart::dynamics::BodyNode* addPart(const dart::dynamics::SkeletonPtr& skeleton,
                                  dart::dynamics::BodyNode* parent, const Part& p,
                                  const dart::dynamics::BodyNode::Properties& body) {
  typename JointT::Properties props;
  props.mName = p.joint;
  props.mT_ParentBodyToJoint = p.X_PJ;
  props.mT_ChildBodyToJoint = p.X_CJ;
  if constexpr (std::is_same_v<JointT, dart::dynamics::RevoluteJoint> ||
                std::is_same_v<JointT, dart::dynamics::PrismaticJoint>)
    props.mAxis = p.axis;
  return skeleton->createJointAndBodyNodePair<JointT>(parent, props, body).second;
}

struct DartMechanism {
  explicit DartMechanism(bool fixed_base = false) : DartMechanism(fixed_base, 0) {}
  template <typename JointT>
  dart::dynamics::BodyNode* add(dart::dynamics::BodyNode* parent, const Part& p,
                                const dart::dynamics::BodyNode::Properties& body) {
    return addPart<JointT>(skeleton, parent, p, body);
  }

  dart::simulation::WorldPtr world = dart::simulation::World::create("user");
  dart::dynamics::SkeletonPtr skeleton = dart::dynamics::Skeleton::create("mechanism");
  DartMechanism(bool fixed_base, int) {
    std::vector<dart::dynamics::BodyNode*> nodes;
    for (Part p : mechanism()) {
      if (fixed_base && p.kind == Part::kFree) {
        p.kind = Part::kWeld;
        p.X_PJ = kBasePose;
      }
      dart::dynamics::BodyNode::Properties body;
      body.mName = p.name;
      body.mInertia = dart::dynamics::Inertia(p.mass, p.c_C, p.I_C);
      auto* parent = p.parent < 0 ? nullptr : nodes[static_cast<std::size_t>(p.parent)];
      dart::dynamics::BodyNode* node = nullptr;
      switch (p.kind) {
        case Part::kFree:
          node = add<dart::dynamics::FreeJoint>(parent, p, body);
          break;
        case Part::kBall:
          node = add<dart::dynamics::BallJoint>(parent, p, body);
          break;
        case Part::kHinge:
          node = add<dart::dynamics::RevoluteJoint>(parent, p, body);
          break;
        case Part::kSlider:
          node = add<dart::dynamics::PrismaticJoint>(parent, p, body);
          break;
        case Part::kWeld:
          node = add<dart::dynamics::WeldJoint>(parent, p, body);
          break;
      }
      nodes.push_back(node);
    }
    world->addSkeleton(skeleton);
  }
};

// The same mechanism in ODE, bodies at their CoM with the DART bodies' axes, at DART's zero
// pose; the hinge attached parent-first (its child is body 2).
struct OdeMechanism {
  dWorldID world;
  dSpaceID space;
  ode_backend::OdeRobotRefs refs;
  explicit OdeMechanism(bool fixed_base = false) {
    dInitODE2(0);
    world = dWorldCreate();
    dWorldSetGravity(world, 0, 0, -9.81);
    space = dSimpleSpaceCreate(nullptr);
    refs.name = "mechanism";
    refs.world = world;
    refs.space = space;
    std::vector<Eigen::Isometry3d> X_WC;
    std::vector<dBodyID> bodies;
    for (const Part& p : mechanism()) {
      Eigen::Isometry3d X = fixed_base ? kBasePose : Eigen::Isometry3d::Identity();
      if (p.parent >= 0) X = X_WC[static_cast<std::size_t>(p.parent)] * p.X_PJ * p.X_CJ.inverse();
      X_WC.push_back(X);
      dBodyID body = dBodyCreate(world);
      dMass m;
      dMassSetParameters(&m, p.mass, 0, 0, 0, p.I_C(0, 0), p.I_C(1, 1), p.I_C(2, 2), p.I_C(0, 1),
                         p.I_C(0, 2), p.I_C(1, 2));
      dBodySetMass(body, &m);
      const Eigen::Vector3d c = X * p.c_C;
      dBodySetPosition(body, c.x(), c.y(), c.z());
      dMatrix3 R;
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) R[4 * i + j] = X.linear()(i, j);
        R[4 * i + 3] = 0;
      }
      dBodySetRotation(body, R);
      bodies.push_back(body);
      refs.bodies.push_back({p.name, body, translation(-p.c_C.x(), -p.c_C.y(), -p.c_C.z())});
      if (p.parent < 0) {
        if (fixed_base) {  // welded to the world where it is
          dJointID weld = dJointCreateFixed(world, nullptr);
          dJointAttach(weld, body, nullptr);
          dJointSetFixed(weld);
          refs.joints.push_back({"base_weld", weld});
        }
        continue;
      }
      const dBodyID parent = bodies[static_cast<std::size_t>(p.parent)];
      const Eigen::Isometry3d X_WJ = X * p.X_CJ;
      const Eigen::Vector3d o = X_WJ.translation();
      const Eigen::Vector3d a = X_WJ.linear() * p.axis;
      dJointID j = nullptr;
      switch (p.kind) {
        case Part::kBall:
          j = dJointCreateBall(world, nullptr);
          dJointAttach(j, body, parent);
          dJointSetBallAnchor(j, o.x(), o.y(), o.z());
          break;
        case Part::kHinge:  // the other way round: ODE's axis flipped to keep the same angle
          j = dJointCreateHinge(world, nullptr);
          dJointAttach(j, parent, body);
          dJointSetHingeAnchor(j, o.x(), o.y(), o.z());
          dJointSetHingeAxis(j, -a.x(), -a.y(), -a.z());
          break;
        case Part::kSlider:
          j = dJointCreateSlider(world, nullptr);
          dJointAttach(j, body, parent);
          dJointSetSliderAxis(j, a.x(), a.y(), a.z());
          break;
        case Part::kWeld:
          j = dJointCreateFixed(world, nullptr);
          dJointAttach(j, body, parent);
          dJointSetFixed(j);
          break;
        case Part::kFree:
          break;
      }
      refs.joints.push_back({p.joint, j});
    }
  }
  ~OdeMechanism() {
    dSpaceDestroy(space);
    dWorldDestroy(world);
  }
};

// A state with the ball's |θ| < π (the range a read-back gives).
void mechanismState(const ModelInfo& info, std::mt19937& rng, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  q.resize(info.nq);
  v.resize(info.nv);
  for (int i = 0; i < info.nq; ++i) q[i] = u(rng);
  for (int i = 0; i < info.nv; ++i) v[i] = 2.0 * u(rng);
  if (info.floating_base) q.segment<4>(3).normalize();
}

TEST(AttachJoints, DartAndOdeAgreeOnBallHingeSliderAndWeld) {
  DartMechanism dart;
  OdeMechanism ode;
  auto d = dart_backend::attachDartModel(dart.skeleton, dart.world);
  auto o = ode_backend::attachOdeModel(ode.refs);
  ASSERT_EQ(d->nv(), 6 + 3 + 1 + 1);
  ASSERT_EQ(o->nv(), d->nv());
  EXPECT_EQ(d->info().joint_names, o->info().joint_names);  // shoulder_x.._z, elbow, slider
  EXPECT_EQ(d->info().joint_names[0], "shoulder_x");
  std::mt19937 rng(7);
  Eigen::VectorXd q, v;
  Eigen::MatrixXd A_d(d->nv(), d->nv()), A_o(o->nv(), o->nv());
  Eigen::VectorXd b_d(d->nv()), b_o(o->nv());
  Matrix6Xd J_d(6, d->nv()), J_o(6, o->nv());
  const Eigen::Vector3d p(0.02, -0.03, 0.04);
  double worst = 0.0;
  for (int s = 0; s < 30; ++s) {
    mechanismState(d->info(), rng, q, v);
    d->setState(q, v);
    o->setState(q, v);
    d->massMatrix(A_d);
    o->massMatrix(A_o);
    d->bias(b_d);
    o->bias(b_o);
    worst = std::max({worst, relative(A_o, A_d), relative(b_o, b_d)});
    for (int body = 0; body < 5; ++body) {
      EXPECT_LT(relative(o->bodyPose(body).matrix(), d->bodyPose(body).matrix()), kTolerance) << body;
      d->pointJacobian(body, p, J_d);
      o->pointJacobian(body, p, J_o);
      worst = std::max({worst, relative(J_o, J_d),
                        relative(o->pointJacobianDotTimesV(body, p), d->pointJacobianDotTimesV(body, p)),
                        relative(o->bodyVelocity(body), d->bodyVelocity(body))});
    }
  }
  RecordProperty("worst_dart_vs_ode", test::scientific(worst));
  EXPECT_LT(worst, kTolerance);
}

TEST(AttachJoints, BallCoordinatesAreConsistentWithDartsKinematicsAndEnergy) {
  DartMechanism dart;
  auto d = dart_backend::attachDartModel(dart.skeleton, dart.world);
  const ModelInfo& info = d->info();
  std::mt19937 rng(11);
  Eigen::VectorXd q, v, q_plus(info.nq), q_minus(info.nq), b(info.nv), b0(info.nv);
  Eigen::MatrixXd A(info.nv, info.nv);
  Matrix6Xd J_plus(6, info.nv), J_minus(6, info.nv);
  const Eigen::Vector3d p(0.02, -0.03, 0.04);
  const double h = 1e-6;
  for (int s = 0; s < 10; ++s) {
    mechanismState(info, rng, q, v);
    // J̇·v = d/dt (J v) along q(t) = q ⊕ v t (q̇ = v for the ball's θ).
    integrateConfiguration(true, q, v, h, q_plus);
    integrateConfiguration(true, q, v, -h, q_minus);
    for (int body = 1; body < 5; ++body) {
      d->setState(q_plus, v);
      d->pointJacobian(body, p, J_plus);
      d->setState(q_minus, v);
      d->pointJacobian(body, p, J_minus);
      d->setState(q, v);
      const Vector6d fd = (J_plus - J_minus) * v / (2 * h);
      EXPECT_LT(relative(d->pointJacobianDotTimesV(body, p), fd), 1e-6) << "body " << body;
    }
    // Kinetic energy: DART's own, from the velocities the model gave it, = ½ vᵀ A v.
    d->setState(q, v);
    d->massMatrix(A);
    EXPECT_NEAR(0.5 * v.dot(A * v), dart.skeleton->computeKineticEnergy(),
                1e-10 * std::max(1.0, dart.skeleton->computeKineticEnergy()));
    // Gravity: b(q, 0) = ∂V/∂q along every coordinate, V = −Σ m g·c from DART's body CoMs
    // (DART 6.12's computePotentialEnergy uses body origins, not CoMs).
    auto potential = [&] {
      double V = 0.0;
      for (std::size_t k = 0; k < dart.skeleton->getNumBodyNodes(); ++k) {
        const auto* node = dart.skeleton->getBodyNode(k);
        V -= node->getMass() * dart.world->getGravity().dot(node->getCOM());
      }
      return V;
    };
    d->setState(q, Eigen::VectorXd::Zero(info.nv));
    d->bias(b0);
    for (int i = 0; i < info.nv; ++i) {
      Eigen::VectorXd e = Eigen::VectorXd::Zero(info.nv);
      e[i] = 1.0;
      integrateConfiguration(true, q, e, h, q_plus);
      integrateConfiguration(true, q, e, -h, q_minus);
      d->setState(q_plus, Eigen::VectorXd::Zero(info.nv));
      const double V_plus = potential();
      d->setState(q_minus, Eigen::VectorXd::Zero(info.nv));
      const double V_minus = potential();
      EXPECT_NEAR(b0[i], (V_plus - V_minus) / (2 * h), 1e-6) << "coordinate " << i;
    }
    // Read-back: the skeleton's own state gives the same (q, v).
    d->setState(q, v);
    Eigen::VectorXd q_read(info.nq), v_read(info.nv);
    ASSERT_TRUE(d->readSkeletonState(q_read, v_read));
    Eigen::VectorXd dq(info.nv);
    differenceConfiguration(true, q, q_read, dq);
    EXPECT_LT(dq.cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((v_read - v).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(AttachJoints, TorquesThroughEachEnginesApiMoveItAsForwardDynamicsSays) {
  // One engine step from rest without gravity: Δv = v̇ dt exactly for both engines' first
  // order steppers, with v̇ the model's forward dynamics under the same torques.
  DartMechanism dart;
  OdeMechanism ode;
  dart.world->setGravity(Eigen::Vector3d::Zero());
  dWorldSetGravity(ode.world, 0, 0, 0);
  auto d = dart_backend::attachDartModel(dart.skeleton, dart.world);
  auto o = ode_backend::attachOdeModel(ode.refs);
  std::mt19937 rng(3);
  Eigen::VectorXd q, v, tau(d->nj()), vdot(d->nv()), q_read(d->nq()), v_read(d->nv());
  const double dt = 1e-4;
  dart.world->setTimeStep(dt);
  for (int s = 0; s < 5; ++s) {
    mechanismState(d->info(), rng, q, v);
    for (int j = 0; j < d->nj(); ++j) tau[j] = std::sin(1.0 + j + s);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(d->nv());
    d->setState(q, zero);
    d->forwardDynamics(tau, vdot);
    d->setState(q, zero);
    d->setSkeletonForces(tau);
    dart.world->step();
    ASSERT_TRUE(d->readSkeletonState(q_read, v_read));
    EXPECT_LT(relative(v_read / dt, vdot), 1e-6) << "DART, state " << s;

    o->setState(q, zero);
    o->addJointTorques(tau);
    dWorldStep(ode.world, dt);
    ASSERT_TRUE(o->readBodyState(q_read, v_read));
    EXPECT_LT(relative(v_read / dt, vdot), 1e-3) << "ODE, state " << s;  // ODE's joint ERP
  }
}

TEST(AttachJoints, AFixedBaseAgreesToo) {
  DartMechanism dart(true);
  OdeMechanism ode(true);
  auto d = dart_backend::attachDartModel(dart.skeleton, dart.world);
  auto o = ode_backend::attachOdeModel(ode.refs);
  EXPECT_FALSE(d->info().floating_base);
  EXPECT_FALSE(o->info().floating_base);
  ASSERT_EQ(d->nv(), 5);
  ASSERT_EQ(o->nv(), 5);
  std::mt19937 rng(5);
  Eigen::VectorXd q, v;
  Eigen::MatrixXd A_d(5, 5), A_o(5, 5);
  Eigen::VectorXd b_d(5), b_o(5);
  Matrix6Xd J_d(6, 5), J_o(6, 5);
  const Eigen::Vector3d p(0.02, -0.03, 0.04);
  double worst = 0.0;
  for (int s = 0; s < 10; ++s) {
    mechanismState(d->info(), rng, q, v);
    d->setState(q, v);
    o->setState(q, v);
    d->massMatrix(A_d);
    o->massMatrix(A_o);
    d->bias(b_d);
    o->bias(b_o);
    worst = std::max({worst, relative(A_o, A_d), relative(b_o, b_d)});
    for (int body = 0; body < 5; ++body) {
      EXPECT_LT(relative(o->bodyPose(body).matrix(), d->bodyPose(body).matrix()), kTolerance) << body;
      d->pointJacobian(body, p, J_d);
      o->pointJacobian(body, p, J_o);
      worst = std::max({worst, relative(J_o, J_d),
                        relative(o->pointJacobianDotTimesV(body, p), d->pointJacobianDotTimesV(body, p))});
    }
  }
  RecordProperty("worst_dart_vs_ode", test::scientific(worst));
  EXPECT_LT(worst, kTolerance);
}

TEST(AttachJoints, UnsupportedJointsAreRefusedByName) {
  {
    DartMechanism dart;
    dart::dynamics::UniversalJoint::Properties props;
    props.mName = "wrist_universal";
    dart.skeleton->createJointAndBodyNodePair<dart::dynamics::UniversalJoint>(
        dart.skeleton->getBodyNode(2), props, dart::dynamics::BodyNode::AspectProperties("hand"));
    try {
      dart_backend::attachDartModel(dart.skeleton, dart.world);
      ADD_FAILURE() << "a UniversalJoint was accepted";
    } catch (const ModelError& e) {
      EXPECT_NE(std::string(e.what()).find("wrist_universal"), std::string::npos) << e.what();
    }
  }
  {
    OdeMechanism ode;
    dBodyID extra = dBodyCreate(ode.world);
    dMass m;
    dMassSetSphereTotal(&m, 1.0, 0.1);
    dBodySetMass(extra, &m);
    dJointID universal = dJointCreateUniversal(ode.world, nullptr);
    dJointAttach(universal, extra, ode.refs.bodies[2].body);
    ode.refs.bodies.push_back({"hand", extra});
    ode.refs.joints.push_back({"wrist_universal", universal});
    try {
      ode_backend::attachOdeModel(ode.refs);
      ADD_FAILURE() << "a universal joint was accepted";
    } catch (const ModelError& e) {
      EXPECT_NE(std::string(e.what()).find("wrist_universal"), std::string::npos) << e.what();
    }
    ode.refs.joints.pop_back();  // now "hand" is listed but connected to nothing
    try {
      ode_backend::attachOdeModel(ode.refs);
      ADD_FAILURE() << "an unconnected body was accepted";
    } catch (const ModelError& e) {
      EXPECT_NE(std::string(e.what()).find("hand"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace dynfilter
