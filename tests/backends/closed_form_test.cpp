// Backends against textbook closed forms: single and double pendulum, a free rigid body.
#include <cmath>

#include <gtest/gtest.h>

#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

class ClosedForm : public testing::TestWithParam<std::string> {
 protected:
  std::unique_ptr<IDynamicsModel> load(const std::string& name, bool floating,
                                       const Eigen::Vector3d& gravity = kStandardGravity_W) {
    ModelOptions options;
    options.floating_base = floating;
    options.gravity_W = gravity;
    return test::makeModel(GetParam(), urdf::loadUrdfFile(test::testModelPath(name)), options);
  }
};

TEST_P(ClosedForm, SinglePendulum) {
  // tests/models/pendulum.urdf: m = 2, l = 0.5, I_yy(CoM) = 0.03, hinge about +y.
  auto model = load("pendulum.urdf", false);
  const double m = 2.0, l = 0.5, I = 0.03;
  Eigen::MatrixXd A(1, 1);
  Eigen::VectorXd b(1), vdot(1);
  for (double theta : {-2.0, -0.4, 0.0, 0.9, 2.5}) {
    Eigen::VectorXd q(1), v(1);
    q << theta;
    v << 1.7;
    model->setState(q, v);
    model->massMatrix(A);
    model->bias(b);
    EXPECT_NEAR(A(0, 0), I + m * l * l, 1e-12);
    EXPECT_NEAR(b[0], m * kStandardGravity * l * std::sin(theta), 1e-12);
    Eigen::VectorXd tau(1);
    tau << 3.0;
    model->forwardDynamics(tau, vdot);
    EXPECT_NEAR(vdot[0], (3.0 - m * kStandardGravity * l * std::sin(theta)) / (I + m * l * l), 1e-12);
  }
}

TEST_P(ClosedForm, DoublePendulum) {
  // tests/models/double_pendulum.urdf (both joints about +y, angles from the downward vertical).
  auto model = load("double_pendulum.urdf", false);
  const double m1 = 1.5, c1 = 0.3, L1 = 0.7, I1 = 0.05;
  const double m2 = 0.8, c2 = 0.25, I2 = 0.02;
  Eigen::MatrixXd A(2, 2);
  Eigen::VectorXd b(2);
  for (int k = 0; k < 6; ++k) {
    const double t1 = -1.3 + 0.5 * k, t2 = 2.1 - 0.8 * k, w1 = 0.7 - 0.3 * k, w2 = -1.1 + 0.4 * k;
    Eigen::VectorXd q(2), v(2);
    q << t1, t2;
    v << w1, w2;
    model->setState(q, v);
    model->massMatrix(A);
    model->bias(b);
    const double c = std::cos(t2), s = std::sin(t2);
    Eigen::Matrix2d A_ref;
    A_ref(0, 0) = I1 + I2 + m1 * c1 * c1 + m2 * (L1 * L1 + c2 * c2 + 2 * L1 * c2 * c);
    A_ref(0, 1) = A_ref(1, 0) = I2 + m2 * (c2 * c2 + L1 * c2 * c);
    A_ref(1, 1) = I2 + m2 * c2 * c2;
    const double h = m2 * L1 * c2 * s;
    Eigen::Vector2d b_ref;
    b_ref[0] = -h * (2 * w1 * w2 + w2 * w2) + (m1 * c1 + m2 * L1) * kStandardGravity * std::sin(t1) +
               m2 * c2 * kStandardGravity * std::sin(t1 + t2);
    b_ref[1] = h * w1 * w1 + m2 * c2 * kStandardGravity * std::sin(t1 + t2);
    EXPECT_LT((A - A_ref).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((b - b_ref).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST_P(ClosedForm, FreeBodyInBodyCoordinates) {
  // For a free body with its CoM at the base origin and v = [v_B; ω_B] in the body frame:
  // A = diag(m, m, m, I) and b = [m ω × v − m R_WBᵀ g; ω × I ω].
  auto model = load("floating_box.urdf", true);
  const double m = 3.0;
  const Eigen::Vector3d I_diag(0.003125, 0.010625, 0.0125);
  Eigen::VectorXd q(7), v(6), b(6);
  q << 0.3, -0.2, 1.0, 0.8, 0.2, -0.4, 0.3;
  q.segment<4>(3).normalize();
  v << 0.5, -1.0, 0.3, 2.0, -1.5, 3.0;
  model->setState(q, v);
  Eigen::MatrixXd A(6, 6);
  model->massMatrix(A);
  Eigen::Matrix<double, 6, 1> diag;
  diag << m, m, m, I_diag;
  EXPECT_LT((A - Eigen::MatrixXd(diag.asDiagonal())).cwiseAbs().maxCoeff(), 1e-12);
  model->bias(b);
  const Eigen::Matrix3d R = basePoseFromConfiguration(q).linear();
  const Eigen::Vector3d w = v.tail<3>(), lin = v.head<3>();
  Eigen::Matrix<double, 6, 1> b_ref;
  b_ref.head<3>() = m * w.cross(lin) - m * R.transpose() * kStandardGravity_W;
  b_ref.tail<3>() = w.cross(I_diag.asDiagonal() * w);
  EXPECT_LT((b - b_ref).cwiseAbs().maxCoeff(), 1e-12);
}

INSTANTIATE_TEST_SUITE_P(AllBackends, ClosedForm, testing::ValuesIn(test::allBackends()),
                         test::BackendName());

}  // namespace
}  // namespace dynfilter
