// DART against ODE: two backends that share no kinematics or dynamics code (only the URDF
// parse and core's Lie-group helpers) must agree on every dynamics quantity the filter
// uses, state by state: A, b, the foot and hand point Jacobians and their drifts J̇·v, and
// forward dynamics under random torques. relative = max |ODE − DART| / max(1, max |DART|).
// The worst figure per quantity is recorded as a test property (worst_<quantity>).
#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

constexpr int kStates = 100;
constexpr double kCrossTolerance = 1e-9;
constexpr double kVelocityScale = 2.0;  // |v_i| ≤ this (m/s, rad/s)
constexpr double kTorqueScale = 100.0;  // |τ_j| ≤ min(this, tau_max_j)

struct TrackedPoint {
  const char* quantity;  // "foot" or "hand": J and J̇v are reported under this name
  const char* link;
  Eigen::Vector3d p_LP;
};

struct CrossCase {
  std::string name;
  std::string model;  // path relative to the source tree
  bool floating_base;
  std::vector<TrackedPoint> points;
};

void PrintTo(const CrossCase& c, std::ostream* os) { *os << c.name; }

// Sole centre (bottom face of the sole box) and a point between the fingers.
const Eigen::Vector3d kSoleCentre(0.0726, 0.0, -0.068);
const Eigen::Vector3d kHandPoint(0.0, 0.0, -0.1);

std::vector<CrossCase> cases() {
  const std::vector<TrackedPoint> figure = {{"foot", "l_foot", kSoleCentre},
                                            {"foot", "r_foot", kSoleCentre},
                                            {"hand", "l_hand", kHandPoint},
                                            {"hand", "r_hand", kHandPoint}};
  // The chain's last link; its sphere sits at (0.03, 0, 0).
  const std::vector<TrackedPoint> chain = {{"hand", "hand", Eigen::Vector3d(0.03, 0.0, 0.0)},
                                           {"hand", "slider", Eigen::Vector3d(0.05, 0.02, 0.01)}};
  // Points on the mimic followers (one inside its leader's subtree) and the prismatic one.
  const std::vector<TrackedPoint> gripper = {{"hand", "left_tip", Eigen::Vector3d(0.01, 0.0, 0.02)},
                                             {"hand", "right_finger", Eigen::Vector3d(0.0, 0.01, 0.05)},
                                             {"hand", "pusher", Eigen::Vector3d(0.0, 0.0, 0.01)}};
  // The mesh soles' centres (bottom face of the hull).
  const std::vector<TrackedPoint> biped = {{"foot", "l_foot", Eigen::Vector3d(0.03, 0.0, -0.06)},
                                           {"foot", "r_foot", Eigen::Vector3d(0.03, 0.0, -0.06)}};
  return {{"human_figure_floating", "models/human_figure.urdf", true, figure},
          {"mimic_gripper_fixed", "tests/models/mimic_gripper.urdf", false, gripper},
          {"mimic_gripper_floating", "tests/models/mimic_gripper.urdf", true, gripper},
          {"mesh_sole_biped_floating", "tests/models/mesh_sole_biped.urdf", true, biped},
          {"floating_chain_floating", "tests/models/floating_chain.urdf", true, chain},
          {"floating_chain_fixed", "tests/models/floating_chain.urdf", false, chain}};
}

class CrossBackend : public testing::TestWithParam<CrossCase> {};

TEST_P(CrossBackend, DartAndOdeAgreeOnRandomStates) {
  const CrossCase& c = GetParam();
  const auto robot = urdf::loadUrdfFile(test::sourcePath(c.model),
                                        {{test::testModelPath("")}, {}});  // package:// meshes
  ModelOptions options;
  options.floating_base = c.floating_base;
  auto dart = test::makeModel("dart", robot, options);
  auto ode = test::makeModel("ode", robot, options);
  ASSERT_EQ(dart->backendName(), "dart");
  ASSERT_EQ(ode->backendName(), "ode");
  ASSERT_EQ(dart->nv(), ode->nv());
  const ModelInfo& info = dart->info();
  const int nv = info.nv;

  std::vector<int> bodies;
  for (const TrackedPoint& p : c.points) {
    bodies.push_back(info.findBody(p.link));
    ASSERT_GE(bodies.back(), 0) << p.link;
  }

  std::map<std::string, double> worst;
  auto track = [&](const std::string& quantity, const Eigen::MatrixXd& from_ode,
                   const Eigen::MatrixXd& from_dart, int state) {
    const double e = test::relativeError(from_ode, from_dart);
    double& w = worst[quantity];
    w = std::max(w, e);
    EXPECT_LT(e, kCrossTolerance) << quantity << ", state " << state;
  };

  std::mt19937 rng(20240611);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Eigen::VectorXd q, v, tau(info.nj), b_dart(nv), b_ode(nv), vdot_dart(nv), vdot_ode(nv);
  Eigen::MatrixXd A_dart(nv, nv), A_ode(nv, nv);
  Matrix6Xd J_dart(6, nv), J_ode(6, nv);
  for (int state = 0; state < kStates; ++state) {
    test::randomState(*dart, rng, kVelocityScale, q, v);
    for (int j = 0; j < info.nj; ++j) tau[j] = std::min(kTorqueScale, info.tau_max[j]) * unit(rng);
    dart->setState(q, v);
    ode->setState(q, v);

    dart->massMatrix(A_dart);
    ode->massMatrix(A_ode);
    track("A", A_ode, A_dart, state);
    dart->bias(b_dart);
    ode->bias(b_ode);
    track("b", b_ode, b_dart, state);
    for (std::size_t i = 0; i < c.points.size(); ++i) {
      const TrackedPoint& p = c.points[i];
      dart->pointJacobian(bodies[i], p.p_LP, J_dart);
      ode->pointJacobian(bodies[i], p.p_LP, J_ode);
      track(std::string(p.quantity) + "_J", J_ode, J_dart, state);
      track(std::string(p.quantity) + "_Jdot_v", ode->pointJacobianDotTimesV(bodies[i], p.p_LP),
            dart->pointJacobianDotTimesV(bodies[i], p.p_LP), state);
    }
    dart->forwardDynamics(tau, vdot_dart);
    ode->forwardDynamics(tau, vdot_ode);
    track("forward_dynamics", vdot_ode, vdot_dart, state);
  }

  for (const auto& [quantity, value] : worst) {
    RecordProperty("worst_" + quantity, testing::PrintToString(value));
    std::cout << "[ cross-backend ] " << c.name << "  " << quantity << "  worst relative "
              << value << "\n";
  }
}

INSTANTIATE_TEST_SUITE_P(DartVersusOde, CrossBackend, testing::ValuesIn(cases()),
                         [](const testing::TestParamInfo<CrossCase>& i) { return i.param.name; });

}  // namespace
}  // namespace dynfilter
