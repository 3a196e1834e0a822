#include "dynfilter/io/terrain_follow.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "dynfilter/core/kinematic_tree.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/io/pose_ik.hpp"
#include "foot_ik_weights.hpp"

namespace dynfilter::io {
namespace {

constexpr double kBaseWeight = 1.0;  // the base gives way too where a leg cannot reach
constexpr double kLegWeight = 0.05;
constexpr double kContinuityWeight = 1.0;

}  // namespace

TerrainFollowReport followTerrain(ReferenceMotion& motion, IDynamicsModel& model, const GroundPlane& plane) {
  const ModelInfo& info = model.info();
  if (!info.floating_base) throw std::invalid_argument("followTerrain: the model must have a floating base");
  TerrainFollowReport report;
  if (motion.frames.empty()) return report;
  if (std::abs(plane.n_W.z()) < 0.1) throw std::invalid_argument("followTerrain: the plane is too steep");

  ContactList contacts(256);
  standingContacts(model, info.neutralConfiguration(), contacts);
  const std::vector<StandingSole> feet = standingSoles(contacts);
  if (feet.empty()) throw std::invalid_argument("followTerrain: model " + info.name + " stands on no body");
  report.feet = static_cast<int>(feet.size());

  const auto height = [&](const Eigen::Vector3d& p) { return plane.heightAt(p.x(), p.y()); };
  const double h0 = height(motion.frames.front().q.head<3>());
  const Eigen::Matrix3d R_tilt =
      Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), plane.n_W.normalized()).toRotationMatrix();

  const KinematicTree tree = kinematicTreeOf(model);
  Eigen::VectorXd weights = Eigen::VectorXd::Ones(info.nv);
  weights.head<6>().setConstant(kBaseWeight);
  for (const StandingSole& f : feet)
    for (const int j : tree.jointsBetween(tree.base_body, f.body)) weights[info.velocityIndex(j)] = kLegWeight;
  std::vector<IkTarget> targets(feet.size());
  for (std::size_t i = 0; i < feet.size(); ++i) {
    targets[i].body = feet[i].body;
    targets[i].p_BP = feet[i].centre_B;
    targets[i].position_weight = kFootPositionWeight;
    targets[i].orientation_weight = kFootOrientationWeight;
  }
  IkOptions ik;
  ik.max_iterations = 100;
  ik.tolerance = 1e-9;
  ik.continuity_weight = kContinuityWeight;

  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(info.nv);
  Eigen::VectorXd q_prev, q_ref_prev, dv_ref(info.nv);
  double change_sq = 0.0;
  for (std::size_t k = 0; k < motion.frames.size(); ++k) {
    const Eigen::VectorXd q_level = motion.frames[k].q;
    model.setState(q_level, v0);
    for (std::size_t i = 0; i < feet.size(); ++i) {
      const Eigen::Isometry3d X_WF = model.bodyPose(feet[i].body);
      Eigen::Vector3d p = X_WF * feet[i].centre_B;
      p.z() += height(p) - h0;
      targets[i].p_WP = p;
      targets[i].R_WB = R_tilt * X_WF.linear();
    }
    Eigen::VectorXd q_ref = q_level;
    q_ref[2] += height(q_level.head<3>()) - h0;
    // From the previous answer moved by the reference's own change, held near it: the clip
    // follows one branch of the IK's solutions.
    Eigen::VectorXd q = q_ref;
    if (k > 0) {
      differenceConfiguration(true, q_ref_prev, q_ref, dv_ref);
      integrateConfiguration(true, q_prev, dv_ref, 1.0, q);
    }
    const Eigen::VectorXd q_predicted = q;
    solvePoseIk(model, targets, q_ref, weights, ik, q, k > 0 ? &q_predicted : nullptr);
    const Eigen::Quaterniond a(q_ref[3], q_ref[4], q_ref[5], q_ref[6]), b(q[3], q[4], q[5], q[6]);
    if (a.dot(b) < 0) q.segment<4>(3) *= -1.0;
    model.setState(q, v0);
    for (const IkTarget& t : targets) {
      double position_m = 0.0, orientation_rad = 0.0;
      ikTargetError(model, t, position_m, orientation_rad);
      report.foot_position_error_max_m = std::max(report.foot_position_error_max_m, position_m);
      report.foot_orientation_error_max_rad = std::max(report.foot_orientation_error_max_rad, orientation_rad);
    }
    change_sq += (q.tail(info.nj) - q_ref.tail(info.nj)).squaredNorm();
    report.base_change_max_m = std::max(report.base_change_max_m, (q.head<3>() - q_ref.head<3>()).norm());
    motion.frames[k].q = q;
    q_prev = q;
    q_ref_prev = q_ref;
  }
  if (info.nj > 0)
    report.joint_change_rms_rad = std::sqrt(change_sq / (static_cast<double>(motion.frames.size()) * info.nj));
  if (motion.frames.size() >= 2) estimateDerivatives(motion.frames, true, ReferenceReadOptions{}.smoothing_window, true, true);
  return report;
}

}  // namespace dynfilter::io
