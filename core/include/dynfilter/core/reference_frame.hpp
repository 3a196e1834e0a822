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

/// The reference between two frames at time @p t_s (clamped to [a.time_s, b.time_s]):
/// the base moves along the SE(3) geodesic from a to b, everything else linearly.
/// @p out must already have the sizes of @p a (no allocation).
void interpolateReference(bool floating_base, const ReferenceFrame& a, const ReferenceFrame& b,
                          double t_s, ReferenceFrame& out);

}  // namespace dynfilter
