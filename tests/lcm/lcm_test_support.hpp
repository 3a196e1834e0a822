#pragma once
// Models and frames shared by the LCM message tests.

#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "dynfilter/core/model_info.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/core/reference_frame.hpp"
#include "dynfilter/lcm/messages.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "support/test_support.hpp"

namespace dynfilter::test {

/// The human figure's ModelInfo (32 joints, floating base), loaded once through DART.
inline const ModelInfo& humanInfo() {
  static const std::unique_ptr<IDynamicsModel> model =
      makeModel("dart", urdf::loadUrdfFile(humanFigurePath()), ModelOptions{});
  return model->info();
}

/// A fixed-base model's ModelInfo (tests/models/arm7.urdf).
inline const ModelInfo& armInfo() {
  static const std::unique_ptr<IDynamicsModel> model = [] {
    ModelOptions options;
    options.floating_base = false;
    return makeModel("dart", urdf::loadUrdfFile(testModelPath("arm7.urdf")), options);
  }();
  return model->info();
}

/// The human figure's ModelInfo padded with made-up joints to @p nj joints (sizes only:
/// for message sizes and name mapping, no dynamics).
inline ModelInfo paddedHumanInfo(int nj) {
  ModelInfo info = humanInfo();
  const int extra = nj - info.nj;
  for (int k = 0; k < extra; ++k) info.joint_names.push_back("extra_finger_joint_" + std::to_string(k));
  info.nj += extra;
  info.nq += extra;
  info.nv += extra;
  const auto pad = [extra](Eigen::VectorXd& v, double value) {
    const Eigen::Index n = v.size();
    v.conservativeResize(n + extra);
    v.tail(extra).setConstant(value);
  };
  pad(info.q_lower, -1.0);
  pad(info.q_upper, 1.0);
  pad(info.v_max, 10.0);
  pad(info.tau_max, 100.0);
  return info;
}

/// The human figure's ModelInfo as the model of a robot with @p locked more joints, welded:
/// the extra joints of paddedHumanInfo(nj + locked) are its locked_joint_names.
inline ModelInfo lockedHumanInfo(int locked) {
  ModelInfo info = humanInfo();
  for (int k = 0; k < locked; ++k) info.locked_joint_names.push_back("extra_finger_joint_" + std::to_string(k));
  return info;
}

/// A robot with two joints more than the model of it, which locks them: they come last in
/// the robot's order, so the model's coordinates are the robot's first ones.
struct LockedPair {
  ModelInfo whole = paddedHumanInfo(humanInfo().nj + 2);
  ModelInfo model = lockedHumanInfo(2);
};

/// A random valid reference frame (unit quaternion, joints within limits).
inline ReferenceFrame randomFrame(const ModelInfo& info, std::mt19937& rng, double time_s) {
  ReferenceFrame frame(info.nq, info.nv);
  randomState(info, rng, 2.0, frame.q, frame.v);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  for (Eigen::Index i = 0; i < frame.vdot.size(); ++i) frame.vdot[i] = u(rng);
  frame.time_s = time_s;
  return frame;
}

template <class Message>
std::vector<std::uint8_t> encoded(const Message& msg) {
  std::vector<std::uint8_t> bytes;
  const int n = messages::encodeMessage(msg, bytes);
  EXPECT_GT(n, 0);
  bytes.resize(static_cast<std::size_t>(n > 0 ? n : 0));
  return bytes;
}

}  // namespace dynfilter::test
