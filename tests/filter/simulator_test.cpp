// The simulator mode (Eq. 14) and the plastic impact.
#include <memory>
#include <random>

#include <gtest/gtest.h>

#include "dynfilter/core/constrained_dynamics.hpp"
#include "dynfilter/core/dynamics_simulator.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/reference_motions.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

TEST(Simulator, FreeFlightIsReproducedByTheBackendsForwardDynamics) {
  // Same integrator, accelerations from Eq. 14 (no contact) vs the engine's own forward
  // dynamics: the two trajectories agree to rounding.
  ModelOptions options;
  options.environment.has_ground = false;
  const auto robot = urdf::loadUrdfFile(test::testModelPath("floating_chain.urdf"));
  auto model = test::makeModel("dart", robot, options);
  auto reference = test::makeModel("dart", robot, options);
  std::mt19937 rng(3);
  Eigen::VectorXd q, v;
  test::randomState(*model, rng, 1.0, q, v);
  const double dt = 1e-3;
  DynamicsSimulator sim(*model, ContactOptions{}, dt);
  sim.reset(q, v);
  Eigen::VectorXd q_ref = q, v_ref = v, vdot_ref(model->nv()), tau(model->nj());
  for (int k = 0; k < 500; ++k) {
    tau << 2.0 * std::sin(0.01 * k), -5.0, 0.3 * std::cos(0.02 * k);
    sim.step(tau);
    reference->setState(q_ref, v_ref);
    reference->forwardDynamics(tau, vdot_ref);
    EXPECT_LT((sim.vdot() - vdot_ref).cwiseAbs().maxCoeff(), 1e-9) << "step " << k;
    v_ref += dt * vdot_ref;
    integrateConfiguration(true, q_ref, v_ref, dt, q_ref);
  }
  EXPECT_LT((sim.q() - q_ref).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_GT((sim.q() - q).norm(), 0.5);  // it moved
}

TEST(Simulator, BoxRestsOnTheGroundWithItsWeightInTheContact) {
  ModelOptions options;
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::testModelPath("floating_box.urdf")),
                               options);
  Eigen::VectorXd q(7);
  q << 0, 0, 0.06, 1, 0, 0, 0;  // 3.5 cm above the ground
  DynamicsSimulator sim(*model, ContactOptions{}, 1e-3);
  sim.reset(q, Eigen::VectorXd::Zero(6));
  bool impact = false;
  for (int k = 0; k < 1000; ++k) impact |= (sim.step(Eigen::VectorXd(0)) & kStatusImpact) != 0;
  EXPECT_TRUE(impact);
  ASSERT_EQ(sim.numContacts(), 1);
  EXPECT_EQ(sim.contacts()[0].kind, ContactKind::kFace);
  EXPECT_NEAR(sim.contacts()[0].normal_force_n, 3.0 * 9.81, 1e-6);
  EXPECT_NEAR(sim.q()[2], 0.025, 2e-4);  // resting on its face; fell ~1 mm/tick at impact
  EXPECT_LT(sim.v().norm(), 1e-6);
  // The engine's own simulator agrees on where it rests.
  model->setState(q, Eigen::VectorXd::Zero(6));
  for (int k = 0; k < 1000; ++k) model->simulateStep(Eigen::VectorXd(0), 1e-3);
  EXPECT_NEAR(model->q()[2], sim.q()[2], 1e-3);
}

TEST(Simulator, StandingSwayKeepsBothFeetOnTheGroundAndSatisfiesEq14) {
  auto model = test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{});
  const auto frames = test::simulateStandingSway(*model, 1.0, 1e-3);
  ASSERT_EQ(frames.size(), 1000u);
  const double z0 = frames.front().q[2];
  double lowest = 1e9;
  for (const auto& f : frames) lowest = std::min(lowest, f.q[2]);
  EXPECT_LT(lowest, z0 - 0.01);  // the squat really went down
  EXPECT_GT(lowest, z0 - 0.2);
  // Feet stayed where they were (bilateral face links).
  model->setState(frames.front().q, frames.front().v);
  const Eigen::Vector3d foot0 = model->bodyPose(model->info().findBody("l_foot")).translation();
  model->setState(frames.back().q, frames.back().v);
  const Eigen::Vector3d foot1 = model->bodyPose(model->info().findBody("l_foot")).translation();
  EXPECT_LT((foot1 - foot0).norm(), 1e-3);
}

// The human figure at a random state (@p seed), its mass matrix A and the six rows J of a
// point on its right sole.
struct FootAtRandomState {
  std::unique_ptr<IDynamicsModel> model;
  Eigen::VectorXd q, v;
  Eigen::MatrixXd A;
  Matrix6Xd J;

  explicit FootAtRandomState(unsigned seed)
      : model(test::makeModel("dart", urdf::loadUrdfFile(test::humanFigurePath()), ModelOptions{})) {
    std::mt19937 rng(seed);
    test::randomState(*model, rng, 1.0, q, v);
    model->setState(q, v);
    A.resize(model->nv(), model->nv());
    model->massMatrix(A);
    J.resize(6, model->nv());
    model->pointJacobian(model->info().findBody("r_foot"), Eigen::Vector3d(0.1, 0, -0.06), J);
  }
};

TEST(ConstrainedDynamics, PlasticImpactStopsTheConstrainedMotionAndLosesEnergy) {
  const FootAtRandomState s(8);
  const Eigen::VectorXd& v = s.v;
  const Eigen::MatrixXd& A = s.A;
  const int nv = s.model->nv();
  const Eigen::MatrixXd H = s.J;
  ConstrainedDynamics cd(nv, 6, 48);
  Eigen::VectorXd v_plus = v, impulse(6);
  ASSERT_TRUE(cd.plasticImpact(A, H, v_plus, impulse));
  EXPECT_LT((H * v_plus).norm(), 1e-10);
  EXPECT_LT(v_plus.dot(A * v_plus), v.dot(A * v));
  // The change is the impulse through the contact: A (v⁺ − v) = Hᵀ λ.
  EXPECT_LT((A * (v_plus - v) - H.transpose() * impulse).norm(), 1e-9);
}

// Rows that depend on others ask nothing more: with the foot's six rows given twice, and a
// seventh row that is a sum of two of them, the impact is the one of the six rows alone
// (the velocity is unique; the dependent rows get no impulse).
TEST(ConstrainedDynamics, DependentImpactRowsGiveTheImpactOfTheIndependentOnes) {
  const FootAtRandomState s(9);
  const Eigen::VectorXd& v = s.v;
  const Eigen::MatrixXd& A = s.A;
  const Matrix6Xd& J = s.J;
  const int nv = s.model->nv();
  Eigen::MatrixXd H(13, nv);
  H << J, J, J.row(0) + 2.0 * J.row(4);
  ConstrainedDynamics cd(nv, 6, 48);
  Eigen::VectorXd v_six = v, v_all = v, impulse_six(6), impulse_all(13);
  ASSERT_TRUE(cd.plasticImpact(A, J, v_six, impulse_six));
  ASSERT_TRUE(cd.plasticImpact(A, H, v_all, impulse_all));
  EXPECT_LT((v_all - v_six).norm(), 1e-9 * v.norm());
  EXPECT_LT((impulse_all.head(6) - impulse_six).norm(), 1e-9 * impulse_six.norm());
  EXPECT_EQ(impulse_all.tail(7).norm(), 0.0);
  EXPECT_LT((H * v_all).norm(), 1e-9);
}

TEST(ConstrainedDynamics, AppendIndependentRowKeepsARankRevealingBasis) {
  Eigen::MatrixXd basis = Eigen::MatrixXd::Zero(4, 4);
  int kept = 0;
  Eigen::RowVectorXd a(4), b(4);
  a << 1, 2, 0, 0;
  b << 0, 1, 1, 0;
  EXPECT_TRUE(appendIndependentRow(basis, kept, a));
  EXPECT_TRUE(appendIndependentRow(basis, kept, b));
  EXPECT_FALSE(appendIndependentRow(basis, kept, 3.0 * a - b));
  EXPECT_FALSE(appendIndependentRow(basis, kept, a + (1e-8 * b)));  // within 1e-6 of the span
  EXPECT_FALSE(appendIndependentRow(basis, kept, Eigen::RowVectorXd::Zero(4)));
  EXPECT_TRUE(appendIndependentRow(basis, kept, a + Eigen::RowVectorXd::Unit(4, 3) * 1e-3));
  EXPECT_EQ(kept, 3);
  EXPECT_LT((basis.leftCols(3).transpose() * basis.leftCols(3) - Eigen::Matrix3d::Identity()).norm(), 1e-12);
}

}  // namespace
}  // namespace dynfilter
