// The DART backend's allocation-free mass matrix against DART's own getMassMatrix.
#include <random>

#include <gtest/gtest.h>

#include "dynfilter/dart/dart_model.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter {
namespace {

TEST(DartMassMatrix, BodySumEqualsSkeletonGetMassMatrix) {
  for (const char* path : {"models/human_figure.urdf", "tests/models/floating_chain.urdf"}) {
    const auto robot = urdf::loadUrdfFile(test::sourcePath(path));
    auto fast = dart_backend::makeDartModel(robot, {}, dart_backend::DartMassMatrix::kBodySum);
    auto dart = dart_backend::makeDartModel(robot, {}, dart_backend::DartMassMatrix::kSkeleton);
    std::mt19937 rng(31);
    Eigen::VectorXd q, v;
    Eigen::MatrixXd A_fast(fast->nv(), fast->nv()), A_dart(fast->nv(), fast->nv());
    for (int trial = 0; trial < 50; ++trial) {
      test::randomState(*fast, rng, 1.0, q, v);
      fast->setState(q, v);
      dart->setState(q, v);
      fast->massMatrix(A_fast);
      dart->massMatrix(A_dart);
      EXPECT_LT(test::relativeError(A_fast, A_dart), 1e-12) << path;
    }
  }
}

}  // namespace
}  // namespace dynfilter
