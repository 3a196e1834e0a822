#include "dynfilter/core/reference_leash.hpp"

#include <cmath>

namespace dynfilter {

Eigen::Isometry3d leashMotion(const LeashOptions& options, const Eigen::Vector3d& n_W,
                              const Eigen::Ref<const Eigen::VectorXd>& q_filter,
                              const Eigen::Ref<const Eigen::VectorXd>& q_reference) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  if (!options.enabled) return X;
  const TiltHeading error = tiltAndHeading(basePoseFromConfiguration(q_filter).linear(),
                                           basePoseFromConfiguration(q_reference).linear());
  const Eigen::Vector3d p_ref = q_reference.head<3>();
  const double excess_rad = std::abs(error.heading_rad) - options.max_heading_rad;
  if (excess_rad > 0.0) {
    const double turn_rad = -std::copysign(excess_rad, error.heading_rad);
    X = Eigen::Translation3d(p_ref) * Eigen::AngleAxisd(turn_rad, n_W) * Eigen::Translation3d(-p_ref);
  }
  Eigen::Vector3d offset = X * p_ref - q_filter.head<3>();
  offset -= n_W * n_W.dot(offset);
  const double distance_m = offset.norm();
  if (distance_m > options.max_offset_m)
    X.pretranslate(-(distance_m - options.max_offset_m) / distance_m * offset);
  return X;
}

}  // namespace dynfilter
