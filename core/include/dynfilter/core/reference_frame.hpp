#pragma once
/// @file
/// One frame of a reference motion, in the model's coordinates (see model_info.hpp).

#include <Eigen/Core>

namespace dynfilter {

/// A reference state: where the motion wants the model to be at time_s.
struct ReferenceFrame {
  double time_s = 0.0;
  Eigen::VectorXd q;     ///< dim nq, unit base quaternion
  Eigen::VectorXd v;     ///< dim nv
  Eigen::VectorXd vdot;  ///< dim nv

  ReferenceFrame() = default;
  ReferenceFrame(int nq, int nv)
      : q(Eigen::VectorXd::Zero(nq)), v(Eigen::VectorXd::Zero(nv)), vdot(Eigen::VectorXd::Zero(nv)) {}
};

}  // namespace dynfilter
