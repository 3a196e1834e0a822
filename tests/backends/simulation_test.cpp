// The engine's own simulator (simulateStep): conservation laws and a closed-form ODE.
#include <cmath>
#include <tuple>

#include <gtest/gtest.h>

#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

class Simulation : public testing::TestWithParam<std::string> {};

TEST_P(Simulation, FreeFloatingChainWithoutGravityConservesMomentumAndEnergy) {
  // A time-stepping engine conserves momentum and energy only up to its integration
  // error. So: the drift over 1 s is small, and it shrinks in proportion to the step
  // (first-order convergence towards exact conservation).
  const auto robot = urdf::loadUrdfFile(test::testModelPath("floating_chain.urdf"));
  ModelOptions options;
  options.gravity_W.setZero();
  options.environment.has_ground = false;
  const auto masses = test::linkMasses(robot);

  struct Drift {
    double linear, angular, energy;
  };
  auto simulate = [&](double dt) {
    auto model = test::makeModel(GetParam(), robot, options);
    Eigen::VectorXd q = model->info().neutralConfiguration(), v(model->nv());
    q[model->info().configurationIndex(1)] = 0.1;  // prismatic joint mid-range
    v << 0.3, -0.2, 0.5, 1.0, -2.0, 1.5, 3.0, 0.4, -5.0;
    model->setState(q, v);
    auto energy = [&model]() {
      Eigen::MatrixXd A(model->nv(), model->nv());
      model->massMatrix(A);
      return 0.5 * model->v().dot(A * model->v());
    };
    Eigen::Vector3d p0, L0, p1, L1;
    test::momentum(*model, masses, p0, L0);
    const double E0 = energy();
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model->nj());
    const int steps = static_cast<int>(std::lround(1.0 / dt));
    for (int k = 0; k < steps; ++k) model->simulateStep(zero, dt);
    test::momentum(*model, masses, p1, L1);
    EXPECT_GT((model->q() - q).tail(model->nj()).norm(), 0.5) << "the joints must really move";
    return Drift{(p1 - p0).norm() / p0.norm(), (L1 - L0).norm() / L0.norm(),
                 std::abs(energy() - E0) / E0};
  };
  const Drift coarse = simulate(4e-4);
  const Drift fine = simulate(2e-4);
  for (const auto& [name, c, f] : {std::tuple{"linear momentum", coarse.linear, fine.linear},
                                   std::tuple{"angular momentum", coarse.angular, fine.angular},
                                   std::tuple{"energy", coarse.energy, fine.energy}}) {
    SCOPED_TRACE(name);
    EXPECT_LT(f, 1e-3);
    EXPECT_NEAR(c / f, 2.0, 0.3) << "drift " << c << " at 0.4 ms, " << f << " at 0.2 ms";
  }
}

TEST_P(Simulation, PendulumFollowsTheClosedFormOde) {
  const auto robot = urdf::loadUrdfFile(test::testModelPath("pendulum.urdf"));
  ModelOptions options;
  options.floating_base = false;
  options.environment.has_ground = false;
  auto model = test::makeModel(GetParam(), robot, options);
  const double m = 2.0, l = 0.5, I = 0.03, g = 9.81, tau = 0.5;
  auto accel = [&](double th) { return (tau - m * g * l * std::sin(th)) / (I + m * l * l); };
  Eigen::VectorXd q(1), v(1), torque(1);
  q << 1.0;
  v << 0.0;
  torque << tau;
  model->setState(q, v);
  // Reference: RK4 of θ̈ = (τ − m g l sin θ) / (I + m l²) with a much smaller step.
  double th = 1.0, w = 0.0;
  const double dt = 1e-4, T = 1.0;
  const int sub = 10;
  for (int k = 0; k < static_cast<int>(T / dt); ++k) {
    model->simulateStep(torque, dt);
    for (int s = 0; s < sub; ++s) {
      const double h = dt / sub;
      const double k1t = w, k1w = accel(th);
      const double k2t = w + 0.5 * h * k1w, k2w = accel(th + 0.5 * h * k1t);
      const double k3t = w + 0.5 * h * k2w, k3w = accel(th + 0.5 * h * k2t);
      const double k4t = w + h * k3w, k4w = accel(th + h * k3t);
      th += h / 6 * (k1t + 2 * k2t + 2 * k3t + k4t);
      w += h / 6 * (k1w + 2 * k2w + 2 * k3w + k4w);
    }
  }
  EXPECT_NEAR(model->q()[0], th, 2e-3);
  EXPECT_NEAR(model->v()[0], w, 5e-3);
  EXPECT_GT(std::abs(model->q()[0] - 1.0), 0.3);  // it really swung
}

TEST_P(Simulation, BoxDroppedOnTheGroundComesToRestOnIt) {
  ModelOptions options;
  auto model = test::makeModel(GetParam(),
                               urdf::loadUrdfFile(test::testModelPath("floating_box.urdf")), options);
  Eigen::VectorXd q(7);
  q << 0, 0, 0.3, 1, 0, 0, 0;
  model->setState(q, Eigen::VectorXd::Zero(6));
  for (int k = 0; k < 1500; ++k) model->simulateStep(Eigen::VectorXd(0), 1e-3);
  EXPECT_NEAR(model->q()[2], 0.025, 1e-3);  // resting on its 5 cm face
  EXPECT_LT(model->v().norm(), 1e-2);
}

INSTANTIATE_TEST_SUITE_P(AllBackends, Simulation, testing::ValuesIn(test::allBackends()),
                         test::BackendName());

}  // namespace
}  // namespace dynfilter
