// Every backend, every test model: A, b, Jacobians and J̇·v against finite differences
// and an independent Newton–Euler sum; forward dynamics against the equation of motion.
#include <random>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

struct Case {
  std::string backend;
  std::string model;  // path relative to the source tree
  bool floating_base;
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << c.backend << " " << c.model << (c.floating_base ? " floating" : " fixed");
}

std::string caseName(const testing::TestParamInfo<Case>& info) {
  std::string model = info.param.model.substr(info.param.model.rfind('/') + 1);
  model = model.substr(0, model.find('.'));
  std::string name = info.param.backend + "_" + model +
                     (info.param.floating_base ? "_floating" : "_fixed");
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
}

class DynamicsConsistency : public testing::TestWithParam<Case> {
 protected:
  void SetUp() override {
    robot_ = urdf::loadUrdfFile(test::sourcePath(GetParam().model),
                                {{test::testModelPath("")}, {}});  // package:// meshes
    ModelOptions options;
    options.floating_base = GetParam().floating_base;
    model_ = test::makeModel(GetParam().backend, robot_, options);
    masses_ = test::linkMasses(robot_);
  }

  // Pose of a point and its body orientation at configuration q (v unchanged).
  void kinematicsAt(const Eigen::VectorXd& q, int body, const Eigen::Vector3d& p_BP,
                    Eigen::Vector3d& p_WP, Eigen::Matrix3d& R_WB) {
    model_->setState(q, Eigen::VectorXd::Zero(model_->nv()));
    const Eigen::Isometry3d X = model_->bodyPose(body);
    p_WP = X * p_BP;
    R_WB = X.linear();
  }

  urdf::RobotDescription robot_;
  std::unique_ptr<IDynamicsModel> model_;
  std::vector<test::LinkMass> masses_;
  std::mt19937 rng_{12345};
};

TEST_P(DynamicsConsistency, MassMatrixIsSymmetricPositiveDefinite) {
  Eigen::VectorXd q, v;
  Eigen::MatrixXd A(model_->nv(), model_->nv());
  for (int trial = 0; trial < 20; ++trial) {
    test::randomState(*model_, rng_, 1.0, q, v);
    model_->setState(q, v);
    model_->massMatrix(A);
    EXPECT_LT(test::relativeError(A, A.transpose()), 1e-14);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(A);
    EXPECT_GT(eig.eigenvalues().minCoeff(), 1e-6) << "A is not positive definite";
  }
}

TEST_P(DynamicsConsistency, PointJacobianMatchesFiniteDifferences) {
  const int nv = model_->nv();
  const double eps = 1e-6;
  Eigen::VectorXd q, v, q_plus(model_->nq()), q_minus(model_->nq()), dq(nv);
  Matrix6Xd J(6, nv), J_fd(6, nv);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  for (int trial = 0; trial < 3; ++trial) {
    test::randomState(*model_, rng_, 1.0, q, v);
    for (int body = 0; body < static_cast<int>(robot_.links.size()); ++body) {
      const Eigen::Vector3d p_BP(u(rng_), u(rng_), u(rng_));
      model_->setState(q, v);
      model_->pointJacobian(body, p_BP, J);
      for (int i = 0; i < nv; ++i) {
        dq.setZero();
        dq[i] = eps;
        integrateConfiguration(model_->info().floating_base, q, dq, 1.0, q_plus);
        integrateConfiguration(model_->info().floating_base, q, dq, -1.0, q_minus);
        Eigen::Vector3d p_plus, p_minus;
        Eigen::Matrix3d R_plus, R_minus;
        kinematicsAt(q_plus, body, p_BP, p_plus, R_plus);
        kinematicsAt(q_minus, body, p_BP, p_minus, R_minus);
        J_fd.col(i).head<3>() = (p_plus - p_minus) / (2 * eps);
        J_fd.col(i).tail<3>() = logSO3(R_plus * R_minus.transpose()) / (2 * eps);
      }
      EXPECT_LT(test::relativeError(J, J_fd), 1e-8) << "body " << robot_.links[body].name;
    }
  }
}

TEST_P(DynamicsConsistency, JacobianDotTimesVMatchesFiniteDifferences) {
  // Along the curve q(t) = q ⊕ v t with v constant, d/dt (J v) = J̇ v.
  const int nv = model_->nv();
  const double eps = 1e-6;
  Eigen::VectorXd q, v, q_plus(model_->nq()), q_minus(model_->nq());
  Matrix6Xd J_plus(6, nv), J_minus(6, nv);
  for (int trial = 0; trial < 5; ++trial) {
    test::randomState(*model_, rng_, 2.0, q, v);
    integrateConfiguration(model_->info().floating_base, q, v, eps, q_plus);
    integrateConfiguration(model_->info().floating_base, q, v, -eps, q_minus);
    for (int body = 0; body < static_cast<int>(robot_.links.size()); ++body) {
      const Eigen::Vector3d p_BP(0.05, -0.02, 0.03);
      model_->setState(q, v);
      const Vector6d drift = model_->pointJacobianDotTimesV(body, p_BP);
      model_->setState(q_plus, v);
      model_->pointJacobian(body, p_BP, J_plus);
      model_->setState(q_minus, v);
      model_->pointJacobian(body, p_BP, J_minus);
      const Vector6d drift_fd = (J_plus * v - J_minus * v) / (2 * eps);
      EXPECT_LT(test::relativeError(drift, drift_fd), 1e-7)
          << "body " << robot_.links[body].name << "\n" << drift.transpose() << "\n"
          << drift_fd.transpose();
    }
  }
}

TEST_P(DynamicsConsistency, BodyVelocityIsJacobianTimesV) {
  Eigen::VectorXd q, v;
  Matrix6Xd J(6, model_->nv());
  test::randomState(*model_, rng_, 2.0, q, v);
  model_->setState(q, v);
  for (int body = 0; body < static_cast<int>(robot_.links.size()); ++body) {
    model_->pointJacobian(body, Eigen::Vector3d::Zero(), J);
    EXPECT_LT(test::relativeError(model_->bodyVelocity(body), J * v), 1e-13);
  }
}

TEST_P(DynamicsConsistency, MassMatrixAndBiasMatchNewtonEulerSum) {
  Eigen::VectorXd q, v, b(model_->nv()), b_ref;
  Eigen::MatrixXd A(model_->nv(), model_->nv()), A_ref;
  for (int trial = 0; trial < 10; ++trial) {
    test::randomState(*model_, rng_, 2.0, q, v);
    model_->setState(q, v);
    model_->massMatrix(A);
    model_->bias(b);
    test::newtonEulerReference(*model_, masses_, kStandardGravity_W, A_ref, b_ref);
    EXPECT_LT(test::relativeError(A, A_ref), 1e-12);
    EXPECT_LT(test::relativeError(b, b_ref), 1e-12);
  }
}

TEST_P(DynamicsConsistency, ForwardDynamicsSatisfiesTheEquationOfMotion) {
  const ModelInfo& info = model_->info();
  Eigen::VectorXd q, v, b(info.nv), vdot(info.nv), tau(info.nj);
  Eigen::MatrixXd A(info.nv, info.nv);
  for (int trial = 0; trial < 10; ++trial) {
    test::randomState(*model_, rng_, 2.0, q, v);
    tau.setRandom();
    tau *= 10.0;
    model_->setState(q, v);
    model_->forwardDynamics(tau, vdot);
    model_->massMatrix(A);
    model_->bias(b);
    Eigen::VectorXd tau_G = Eigen::VectorXd::Zero(info.nv);
    for (int j = 0; j < info.nj; ++j) tau_G[info.velocityIndex(j)] = tau[j];
    EXPECT_LT(test::relativeError(A * vdot + b, tau_G), 1e-10);
  }
}

TEST_P(DynamicsConsistency, RejectsNonUnitQuaternionAndKeepsTheState) {
  if (!model_->info().floating_base) GTEST_SKIP() << "fixed base has no quaternion";
  Eigen::VectorXd q, v;
  test::randomState(*model_, rng_, 1.0, q, v);
  model_->setState(q, v);
  Eigen::VectorXd bad = q;
  bad.segment<4>(3) *= 1.01;
  EXPECT_THROW(model_->setState(bad, v), InvalidStateError);
  EXPECT_EQ(model_->q(), q);
}

INSTANTIATE_TEST_SUITE_P(
    AllBackends, DynamicsConsistency,
    testing::ValuesIn([] {
      std::vector<Case> cases;
      for (const auto& backend : test::allBackends()) {
        cases.push_back({backend, "models/human_figure.urdf", true});
        cases.push_back({backend, "tests/models/floating_chain.urdf", true});
        cases.push_back({backend, "tests/models/floating_chain.urdf", false});
        cases.push_back({backend, "tests/models/double_pendulum.urdf", false});
        cases.push_back({backend, "tests/models/quadruped.urdf", true});
        cases.push_back({backend, "tests/models/arm7.urdf", false});
        // Mimic followers (reduced coordinates), massless hip links, mesh soles.
        cases.push_back({backend, "tests/models/mimic_gripper.urdf", false});
        cases.push_back({backend, "tests/models/mimic_gripper.urdf", true});
        cases.push_back({backend, "tests/models/mesh_sole_biped.urdf", true});
      }
      return cases;
    }()),
    caseName);

}  // namespace
}  // namespace dynfilter
